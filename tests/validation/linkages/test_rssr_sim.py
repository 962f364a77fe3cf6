"""The RSSR simulated by MuJoCo (soft connect, servo-driven input, the output torque applied) against the
in-house rigid answer at the simulated input states."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from numpy.testing import assert_allclose

from dualmech.models.linkages.rssr import analyze_rssr, to_table
from dualmech.models.linkages.rssr_case import RssrCase, rssr_from_dict
from tests.models.linkages.cases import bundled
from tests.tolerances import LINKAGE_SIM_ANGLE, LINKAGE_SIM_FORCE, LINKAGE_SIM_RATE

pytest.importorskip("mujoco")


def _disagreement(case: RssrCase, judged: RssrCase | None = None) -> dict[str, float]:
    """Output angle (rad), output rate and joint-3 force (relative to their peaks): the simulation of
    ``judged`` (default ``case``) against the in-house answer for ``case`` at the simulated input states."""
    from dualmech.validation.linkages.mujoco_rssr_sim import crank_states, simulate_rssr

    sim = simulate_rssr(case if judged is None else judged, 2e-5, 0.5, 250)
    an = analyze_rssr(case, crank=crank_states(sim))
    j3 = np.stack([to_table(an)[f"j3_f{axis}"] for axis in "xyz"], 1)
    assert (an.status == "ok").all() and len(an.phi) > 90
    return {"phi4": float(np.abs(np.mod(sim["phi4"] - an.phi + np.pi, 2 * np.pi) - np.pi).max()),
            "phi4_dot": float(np.abs(sim["phi4_dot"] - an.phi_dot).max() / np.abs(an.phi_dot).max()),
            "j3": float(np.abs(sim["j3"] - j3).max() / np.abs(j3).max())}


def test_simulation_agrees_with_the_rigid_in_house_answer() -> None:
    got = _disagreement(rssr_from_dict(bundled()))
    assert_allclose(got["phi4"], 0.0, rtol=0, atol=LINKAGE_SIM_ANGLE.value)
    assert_allclose(got["phi4_dot"], 0.0, rtol=0, atol=LINKAGE_SIM_RATE.value)
    assert_allclose(got["j3"], 0.0, rtol=0, atol=LINKAGE_SIM_FORCE.value)


def test_the_simulation_check_sees_a_wrong_load() -> None:
    """Deliberate fault: the simulation run with the output torque of the other sign."""
    case = rssr_from_dict(bundled())
    got = _disagreement(case, replace(case, output_torque=-case.output_torque))
    assert got["j3"] > 10 * LINKAGE_SIM_FORCE.value
