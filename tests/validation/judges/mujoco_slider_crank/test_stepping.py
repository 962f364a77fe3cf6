"""MuJoCo simulation: the steps between the rows run in ``mujoco.rollout`` and are those of a Python loop of
``mj_step``, bit for bit (validation/judges/mujoco_slider_crank/sim.py, :func:`stepped`)."""

from __future__ import annotations

import numpy as np
import pytest

from dualmech.models.case import load_case, with_loads

mujoco = pytest.importorskip("mujoco")

from mujoco import rollout  # noqa: E402

from dualmech.models.mjcf import case_to_mjcf  # noqa: E402
from dualmech.validation.judges.mujoco_slider_crank import engine as rigid  # noqa: E402
from dualmech.validation.judges.mujoco_slider_crank.sim import skip_collisions, stepped  # noqa: E402
from dualmech.validation.judges.mujoco_slider_crank.sim_plan import prepare  # noqa: E402

READS = np.array([5, 6, 40, 41, 300])
STEPS = 350


def _started():
    """A loaded model of a thesis case, assembled at rest, and a servo command that moves it."""
    case = with_loads(load_case("thesis/a4-30-s1-3.5"), drive_torque=None, slider_force=-300.0)
    _, settings = prepare(case)
    lp = rigid.build(case, case_to_mjcf(case, settings))
    skip_collisions(lp.model)
    rigid.assembled_state(lp, (0.3, 3.5, 5.0, 0.0), warm=False)
    t = np.arange(STEPS) * settings.timestep
    ctrl = np.stack([0.3 + 5.0 * t + 0.01, np.full(STEPS, 3.5), np.full(STEPS, -300.0)], -1)
    return lp.model, lp.data, ctrl


def _snapshot(d) -> np.ndarray:
    return np.concatenate([d.qpos, d.qvel, d.qacc, d.efc_force[:3], d.qacc_warmstart, [d.time]])


def _looped() -> list[np.ndarray]:
    m, d, ctrl = _started()
    seen = []
    for k in range(STEPS):
        d.ctrl[:] = ctrl[k]
        if k in READS:
            mujoco.mj_forward(m, d)
            seen.append(_snapshot(d))
        mujoco.mj_step(m, d)
    return [*seen, _snapshot(d)]


def _rolled(roller) -> list[np.ndarray]:
    m, d, ctrl = _started()
    seen = []
    for k in stepped(m, d, ctrl, READS, roller):
        assert np.array_equal(d.ctrl, ctrl[k])
        mujoco.mj_forward(m, d)
        seen.append(_snapshot(d))
    return [*seen, _snapshot(d)]


class _ColdRoller:
    """The fault the test must see: each stretch starts with the solver's warm start cleared."""

    def __init__(self, roller):
        self.roller = roller

    def rollout(self, *args, initial_warmstart=None, **kwargs):
        return self.roller.rollout(*args, **kwargs)


def test_rollout_steps_are_the_loop_of_mj_step_bit_for_bit():
    """Why: ~1 us of Python a step (92,000 steps a torque-mode case) is gone; the simulation is unchanged."""
    looped = _looped()
    with rollout.Rollout(nthread=0) as roller:
        rolled = _rolled(roller)
    assert len(rolled) == len(READS) + 1
    for a, b in zip(looped, rolled):
        np.testing.assert_array_equal(a, b)


def test_a_stretch_started_cold_is_seen():
    looped = _looped()
    with rollout.Rollout(nthread=0) as roller:
        cold = _rolled(_ColdRoller(roller))
    assert not all(np.array_equal(a, b) for a, b in zip(looped, cold))


def test_stepping_stops_where_mujoco_warns():
    """A stretch in which MuJoCo warns (here a NaN command) ends the stepping; the warning stays for the
    caller, which drops the run (a stepper that went on would read row 300)."""
    m, d, ctrl = _started()
    ctrl[100, 0] = np.nan
    with rollout.Rollout(nthread=0) as roller:
        read = list(stepped(m, d, ctrl, READS, roller))
    assert read == [5, 6, 40, 41] and d.warning.number.any()
