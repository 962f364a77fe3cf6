"""Forward dynamics of the RSSR from the in-house inverse dynamics (generalized inertia): energy is kept
without torques, and MuJoCo's free simulation (no servo, the drive torque applied) follows it."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from numpy.testing import assert_allclose

from dualmech.models.linkages import linkage_case
from dualmech.models.linkages.forward_dynamics import Coefficients, coefficients, energy, simulate
from dualmech.models.linkages.tolerances import LINKAGE_ENERGY, LINKAGE_SIM_FREE_ANGLE, LINKAGE_SIM_FREE_RATE


def test_energy_is_kept_without_torques() -> None:
    case = replace(linkage_case("rssr"), output_torque=0.0)
    states = simulate(case, 0.0, np.linspace(0.0, 1.0, 201))
    total = energy(case, states[:, 0], states[:, 1])
    assert np.ptp(states[:, 0]) > 4.0  # it swings through most of a turn
    assert_allclose(total, total[0], rtol=LINKAGE_ENERGY.value, atol=0)


def _free_run(coeffs: Coefficients | None = None) -> tuple[float, float]:
    """Worst angle error (rad) and rate error (over the peak rate) of MuJoCo's free simulation against the
    in-house forward dynamics (with ``coeffs`` if given), drive torque 0.3 N m, 0.5 s."""
    pytest.importorskip("mujoco")
    from dualmech.models.linkages.mujoco_rssr_sim import simulate_rssr

    case = linkage_case("rssr")
    sim = simulate_rssr(case, 2e-5, 0.5, 250, runin=0.0, drive_torque=0.3)
    states = simulate(case, 0.3, sim["time"], coeffs)
    return (float(np.abs(sim["theta1"] - states[:, 0]).max()),
            float(np.abs(sim["theta1_dot"] - states[:, 1]).max() / np.abs(states[:, 1]).max()))


def test_mujoco_free_simulation_follows_the_in_house_forward_dynamics() -> None:
    angle, rate = _free_run()
    assert angle <= LINKAGE_SIM_FREE_ANGLE.value and rate <= LINKAGE_SIM_FREE_RATE.value


def test_the_check_sees_a_dropped_velocity_term() -> None:
    """Deliberate fault: the forward dynamics without the C(theta) theta_dot^2 term."""
    c = coefficients(linkage_case("rssr"))
    angle, rate = _free_run(replace(c, velocity=np.zeros_like(c.velocity)))
    assert angle > 10 * LINKAGE_SIM_FREE_ANGLE.value or rate > 10 * LINKAGE_SIM_FREE_RATE.value
