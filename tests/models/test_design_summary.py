"""The designer's summary (issue 14): peaks with their angles and units, dead and near-dead centres."""

from __future__ import annotations

import numpy as np
from numpy.testing import assert_allclose

from dualmech.core.thresholds import ROUND_OFF_RELATIVE
from dualmech.models.case import load_case, with_loads
from dualmech.models.design_summary import NEAR_DEAD_CENTRE_TRANSMISSION, PEAK_NAMES, design_summary
from dualmech.models.slider_crank.analysis import solve_case
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


def _force_mode(preset: str):
    """The preset in slider-load mode (the drive torque solved, the slider load given: constant)."""

    case = load_case(preset)
    return with_loads(case, drive_torque=None, slider_force=-100.0)


def test_structurally_zero_peaks_show_as_zero_with_their_round_off_level():
    """A ball joint at the slider carries no moment: j4's moment about P3 is round-off (~1e-16 of the case's
    moment scale), and must read 0, not a peak at an angle (issue 30, "Noise shown as results")."""
    case = load_case("thesis/a4-30-s1-3.5")
    table = solve_case(case)
    j4m = np.linalg.norm(np.stack([table[c] for c in ("j4_mx", "j4_my", "j4_mz")]), axis=0)
    assert 0 < np.nanmax(np.where(table.status == "ok", j4m, np.nan))  # round-off, not exact zeros
    s = design_summary(table, case.units)
    peak = next(p for p in s.peaks if p.name.startswith("joint 4") and "moment" in p.name)
    assert peak.kind == "zero" and peak.value == 0.0
    assert 0 < peak.round_off <= ROUND_OFF_RELATIVE.value * max(p.scale for p in s.peaks)
    assert "0 lbf·in" in str(peak) and "round-off" in str(peak) and " at " not in str(peak)
    genuine = [p for p in s.peaks if p.name != "|drive_torque|"  # the given load: constant
               and (not p.name.startswith(("joint 3", "joint 4")) or "force" in p.name)]
    assert all(p.kind == "peak" and p.value > 0 for p in genuine)


def test_a_constant_output_has_no_angle_of_its_peak():
    """The given slider load is the same at every position: "constant", not "at 55 deg"."""
    case = _force_mode("thesis/a4-30-s1-3.5")
    s = design_summary(solve_case(case), case.units)
    load = next(p for p in s.peaks if p.name == "|slider_load|")
    assert load.kind == "constant" and "constant" in str(load) and " at " not in str(load)
    assert_allclose(load.value, 100.0, rtol=ROUND_OFF_RELATIVE.value, atol=0)
    torque = next(p for p in s.peaks if p.name == "|drive_torque|")
    assert torque.kind == "peak" and " at " in str(torque)


def test_round_off_is_relative_to_the_case_not_a_list_of_columns():
    """The same rule makes a genuine moment (universal joint: j3 carries one) a peak: no column is zero by
    name."""

    case = load_case("thesis/a4-30-s1-3.5")
    case = case.with_values({"joints.rod_slider": "universal"})
    s = design_summary(solve_case(case), case.units)
    j3 = next(p for p in s.peaks if p.name.startswith("joint 3") and "moment" in p.name)
    assert j3.kind == "peak" and j3.value > 0


def test_a_table_summary_reads_every_joint_of_its_spec():
    """:func:`table_summary` of a hand-made table keyed on a slide ``s1`` (a loop table driven by a slide):
    per joint the largest |f| and |m| over the ``ok`` rows at the slide's value, a moment at 1e-12 of the
    case's moments shown as 0 with its round-off, a constant effort as constant, the dead-centre rows by their
    key, no stroke; units of the label (none for a label not in the unit systems)."""
    from dualmech.models.linkages import table_summary
    from dualmech.models.tables import LinkageTable, TableSpec

    rng = np.random.default_rng(7)
    n = 9
    s1 = np.linspace(0.0, 0.08, n)
    force = rng.normal(size=(n, 3))
    moment = rng.normal(size=(n, 3))
    columns = {"s1": s1, "theta2": rng.normal(size=n),
               **{f"joint1_f{a}": force[:, i] for i, a in enumerate("xyz")},
               **{f"joint1_m{a}": moment[:, i] for i, a in enumerate("xyz")},
               **{f"joint2_f{a}": 2 * force[:, i] for i, a in enumerate("xyz")},
               **{f"joint2_m{a}": 1e-12 * moment[:, i] for i, a in enumerate("xyz")},
               "effort_s1": np.full(n, -3.0), "dynamics_residual": np.zeros(n)}
    reactions = tuple(c for c in columns if c.startswith(("joint", "effort"))) + ("dynamics_residual",)
    spec = TableSpec(tuple(columns), ("theta2",), (), reactions, key="s1")
    status = np.array(["ok"] * n, dtype=object)
    status[[2, 6]] = "dead_centre"
    table = LinkageTable("dualmech", "slide", columns, status)
    names = ["joint1 |f|", "joint1 |m|", "joint2 |f|", "joint2 |m|", "|effort_s1|"]
    assert [name for name, _, _ in spec.loads] == names
    s = table_summary(table, spec, "m-N-s")
    ok = status == "ok"
    peaks = {p.name: p for p in s.peaks}
    for name, vector in (("joint1 |f|", force), ("joint1 |m|", moment), ("joint2 |f|", 2 * force)):
        magnitude = np.where(ok, np.sqrt((vector ** 2).sum(axis=1)), -1.0)
        i = int(np.argmax(magnitude))
        assert_allclose(peaks[name].value, magnitude[i], rtol=1e-15, atol=0)
        assert peaks[name].theta_deg == s1[i] and peaks[name].where == f"at s1 = {s1[i]:g}"
    assert peaks["joint1 |f|"].unit == "N" and peaks["joint1 |m|"].unit == "N·m"
    zero = peaks["joint2 |m|"]
    assert zero.kind == "zero" and zero.value == 0.0 and zero.where.startswith("round-off")
    assert peaks["|effort_s1|"].where == "constant" and peaks["|effort_s1|"].value == 3.0
    assert s.dead_centres == (s1[2], s1[6]) and np.isnan(s.stroke) and s.near_dead_centres == ()
    assert {p.unit for p in table_summary(table, spec, "SI").peaks} == {""}


def test_the_positions_without_an_answer_are_named_by_word():
    """A slider crank whose slider line is 45 in off the crank axis (a1 = 12, a2 = 50 in): the rod reaches
    it only where the crank points towards it, so most rows are ``no_assembly``; the summary counts them by
    word (what the report shows beside the peaks, which are taken over the rest)."""
    table = solve_case(load_case("thesis/ideal").with_values({"geometry.slider_offset": 45.0}))
    summary = design_summary(table)
    words = np.asarray(table.status, dtype=str)
    missing = int((words == "no_assembly").sum())
    assert 0 < missing < len(words) and set(words) <= {"ok", "dead_centre", "no_assembly", "assembly_limit"}
    others = [f"{w} {int((words == w).sum())}" for w in sorted(set(words) - {"ok", "dead_centre"})]
    assert summary.unsolved == ", ".join(others)
    assert design_summary(solve_case(load_case("thesis/ideal"))).unsolved == "none"
