"""MuJoCo's free simulation of the RSSR (the model of the simulated judge generated from its joint table,
``validation/judges/mujoco_loop/``, with the drive's servo off and a drive torque applied) follows the
in-house forward dynamics (``models/loop/preset_dynamics.py``), and the check sees a dropped velocity
term."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from numpy.testing import assert_allclose

from dualmech.models.linkages import forward_dynamics, linkage_case
from dualmech.models.linkages.forward_dynamics import Coefficients
from dualmech.models.loop.preset_dynamics import at_states, simulate
from tests.tolerances import LINKAGE_SIM_FREE_ANGLE, LINKAGE_SIM_FREE_RATE

mujoco = pytest.importorskip("mujoco")

#: Time step (s), duration (s), steps between samples and the drive torque (N m) of the free run.
STEP, DURATION, EVERY, TORQUE = 2e-5, 0.5, 250, 0.3


def _mujoco_free_run() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Times, drive angles and rates of MuJoCo's free simulation of the bundled RSSR: its generated model
    started rigidly closed at the case's first angle and speed (the judge's own crude start), the drive
    servo's gains zeroed, :data:`TORQUE` applied about the drive axis, the output torque by its motor."""
    from dualmech.models.loop.presets import rssr_table
    from dualmech.validation.judges.mujoco_loop.closure import build
    from dualmech.validation.judges.mujoco_loop.sim_plan import settings, survey
    from dualmech.validation.judges.mujoco_loop.simulation import compile_sim, reference, run_start
    from dualmech.validation.judges.mujoco_loop.table import solve_table as mujoco_table
    from dualmech.validation.judges.presets.run import crude_start
    from dualmech.validation.judges.presets.starts import with_start

    case = linkage_case("rssr")
    mech = rssr_table(case)
    starts, on_branch, _ = crude_start(case, mech, 0, mujoco_table)
    assert on_branch
    mech = with_start(mech, starts)
    sv = survey(mech)
    sim = compile_sim(mech, settings(mech, STEP, sv))
    m, d = sim.lp.model, sim.lp.data
    m.actuator_gainprm[0, 0] = 0.0  # the drive's servo (the first actuator) off
    m.actuator_biasprm[0, :3] = 0.0
    values, rates = reference(mech, 0, np.array([0.0]))
    d.qpos[:], d.qvel[:] = run_start(build(mech), sv, 0, values[0], rates[0])
    d.ctrl[1:] = [load.value or 0.0 for load in mech.loads]
    qadr, dadr = sim.coordinates["theta1"]
    d.qfrc_applied[dadr] = TORQUE
    samples = int(round(DURATION / (STEP * EVERY))) + 1
    angle, rate = np.empty(samples), np.empty(samples)
    for k in range(samples):
        if k:
            for _ in range(EVERY):
                mujoco.mj_step(m, d)
        angle[k], rate[k] = d.qpos[qadr], d.qvel[dadr]
    assert not d.warning.number.any()
    return np.arange(samples) * STEP * EVERY, angle, rate


@pytest.fixture(scope="module")
def mujoco_run() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return _mujoco_free_run()


def _errors(run: tuple[np.ndarray, ...], coeffs: Coefficients | None = None) -> tuple[float, float]:
    """Worst angle error (rad) and rate error (over the peak rate) of MuJoCo's free run ``run`` against
    the in-house forward dynamics (with ``coeffs`` if given) at the same times."""
    t, angle, rate = run
    ours = simulate(linkage_case("rssr"), float(t[-1]), torque=TORQUE, samples=t.size, coeffs=coeffs)
    assert_allclose(ours.t, t, rtol=0, atol=1e-12)
    return (float(np.abs(angle - ours.psi).max()),
            float(np.abs(rate - ours.psi_dot).max() / np.abs(ours.psi_dot).max()))


def test_mujoco_free_simulation_follows_the_in_house_forward_dynamics(mujoco_run) -> None:
    angle, rate = _errors(mujoco_run)
    assert angle <= LINKAGE_SIM_FREE_ANGLE.value and rate <= LINKAGE_SIM_FREE_RATE.value


def test_the_check_sees_a_dropped_velocity_term(mujoco_run) -> None:
    """Deliberate fault: the forward dynamics without the C(theta) theta_dot^2 term."""
    c = forward_dynamics.coefficients(linkage_case("rssr"), at_states)
    angle, rate = _errors(mujoco_run, replace(c, velocity=np.zeros_like(c.velocity)))
    assert angle > 10 * LINKAGE_SIM_FREE_ANGLE.value or rate > 10 * LINKAGE_SIM_FREE_RATE.value
