"""MuJoCo's free simulation of the RSSR (the simulated judge, ``validation/linkages/mujoco_rssr_sim.py``)
follows the in-house forward dynamics (``models/linkages/forward_dynamics.py``), and the check sees a
dropped velocity term."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from numpy.testing import assert_allclose

from dualmech.models.linkages import linkage_case
from dualmech.models.linkages.forward_dynamics import Coefficients, coefficients, simulate
from tests.tolerances import LINKAGE_SIM_FREE_ANGLE, LINKAGE_SIM_FREE_RATE

pytest.importorskip("mujoco")


def _free_run(coeffs: Coefficients | None = None) -> tuple[float, float]:
    """Worst angle error (rad) and rate error (over the peak rate) of MuJoCo's free simulation against the
    in-house forward dynamics (with ``coeffs`` if given), drive torque 0.3 N m, 0.5 s."""
    from dualmech.validation.linkages.mujoco_rssr_sim import simulate_rssr

    case = linkage_case("rssr")
    sim = simulate_rssr(case, 2e-5, 0.5, 250, runin=0.0, drive_torque=0.3)
    ours = simulate(case, float(sim["time"][-1]), torque=0.3, samples=len(sim["time"]), coeffs=coeffs)
    assert_allclose(ours.t, sim["time"], rtol=0, atol=1e-12)
    return (float(np.abs(sim["theta1"] - ours.psi).max()),
            float(np.abs(sim["theta1_dot"] - ours.psi_dot).max() / np.abs(ours.psi_dot).max()))


def test_mujoco_free_simulation_follows_the_in_house_forward_dynamics() -> None:
    angle, rate = _free_run()
    assert angle <= LINKAGE_SIM_FREE_ANGLE.value and rate <= LINKAGE_SIM_FREE_RATE.value


def test_the_check_sees_a_dropped_velocity_term() -> None:
    """Deliberate fault: the forward dynamics without the C(theta) theta_dot^2 term."""
    c = coefficients(linkage_case("rssr"))
    angle, rate = _free_run(replace(c, velocity=np.zeros_like(c.velocity)))
    assert angle > 10 * LINKAGE_SIM_FREE_ANGLE.value or rate > 10 * LINKAGE_SIM_FREE_RATE.value
