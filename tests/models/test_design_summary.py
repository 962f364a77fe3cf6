"""The designer's summary (issue 14): peaks with their angles and units, dead and near-dead centres."""

from __future__ import annotations

import numpy as np
from numpy.testing import assert_allclose

from dualmech.models.case import load_case
from dualmech.models.design_summary import NEAR_DEAD_CENTRE_TRANSMISSION, PEAK_NAMES, design_summary
from dualmech.models.slider_crank import solve_case
from dualmech.models.units import axis_label, column_unit


def test_peaks_are_the_largest_magnitudes_at_their_angles_in_the_case_units():
    case = load_case("thesis/a4-30-s1-3.5")
    table = solve_case(case)
    s = design_summary(table, case.units)
    assert tuple(p.name for p in s.peaks) == PEAK_NAMES
    ok = table.status == "ok"
    j3 = np.linalg.norm(np.stack([table[c] for c in ("j3_fx", "j3_fy", "j3_fz")]), axis=0)
    i = int(np.nanargmax(np.where(ok, j3, np.nan)))
    peak = next(p for p in s.peaks if p.name.startswith("joint 3"))
    assert_allclose(peak.value, j3[i], rtol=0, atol=0)
    assert peak.theta_deg == table["theta1_deg"][i] and peak.unit == "lbf"
    assert s.length_unit == "in" and "lbf·in" in {p.unit for p in s.peaks}


def test_dead_and_near_dead_centres_are_listed_not_hidden():
    case = load_case("thesis/ideal")
    s = design_summary(solve_case(case), case.units)
    assert s.dead_centres == (90.0, 270.0)
    t = np.abs(solve_case(case)["transmission"])
    assert len(s.near_dead_centres) == int(np.sum((t < NEAR_DEAD_CENTRE_TRANSMISSION) & (t >= 1e-9)))
    assert any(line.startswith("warning: |transmission| < 0.05") for line in s.lines())


def test_units_are_never_invented():
    assert column_unit("S4_ddot", "m-N-s") == "m/s²" and column_unit("j1_mz", "inch-lbf-s") == "lbf·in"
    assert axis_label("S4", "consistent") == "S4" and axis_label("j2_fx", "mm-N-s") == "j2_fx [N]"
