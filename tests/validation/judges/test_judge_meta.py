"""The judges' metadata (Pinocchio, MuJoCo rigid and simulated) against oracles: the loaded libraries, the
independent Newton-Euler equations, the clock, the closed-form reach, the servo's physics and the plan's
rules by hand (the inventory of every engine's outputs is ``tests/test_outputs_have_oracles.py``)."""

from __future__ import annotations

import math
import time

import mujoco
import numpy as np
import pinocchio
from numpy.testing import assert_allclose

from dualmech.models.case import load_case, with_loads
from dualmech.validation.engines import run_engine
from dualmech.validation.judges.mujoco_slider_crank.sim_plan import (
    SIM_RUNIN_STEPS,
    SIM_RUNIN_TIME_CONSTANTS,
    prepare,
)
from tests.newton_euler_oracle import table_violation
from tests.oracles import assembly_margin
from tests.tolerances import NEWTON_EULER_ROUND_OFF, SERVO_LAG

#: A small case in torque mode (mujoco-sim then gives L_ref too).
SMALL = load_case("thesis/a4-30-s1-3.5").with_values({"motion.angles_deg": {"start": 0.0, "stop": 360.0,
                                                                            "step": 30.0}})


def test_library_versions_are_the_loaded_libraries() -> None:
    assert run_engine("pinocchio", SMALL).meta["pinocchio_version"] == pinocchio.__version__
    assert run_engine("mujoco", SMALL).meta["mujoco"] == mujoco.__version__
    assert run_engine("mujoco-sim", SMALL).meta["mujoco"] == mujoco.__version__


def test_pinocchio_meta() -> None:
    """``ls_residual_max``: the closed loop's least-squares residual is round-off, as the independent
    Newton-Euler equations evaluated on the table's columns say; the Newton counts: a cold first position
    takes a few steps, the mean at most the max; ``seconds``: its parts within the wall time around the
    call."""
    start = time.perf_counter()
    table = run_engine("pinocchio", SMALL)
    wall = time.perf_counter() - start
    meta = table.meta
    violation = np.nanmax(table_violation(SMALL, table)[table.status == "ok"])
    assert violation <= NEWTON_EULER_ROUND_OFF
    assert 0.0 <= meta["ls_residual_max"] <= NEWTON_EULER_ROUND_OFF
    assert 1 <= meta["newton_iterations_mean"] <= meta["newton_iterations_max"] <= 50
    assert isinstance(meta["newton_iterations_max"], int)
    parts = meta["seconds"]
    assert set(parts) == {"model", "positions", "dynamics"} and all(v >= 0.0 for v in parts.values())
    assert sum(parts.values()) <= wall


def test_mujoco_iterations() -> None:
    """One count per row: a row beyond reach (the closed form's ``assembly_margin`` < 0) is decided by
    geometry, with no Newton step; every assembled row takes one at least (the MuJoCo closure counts from
    1) and fewer than its cap, which a row that assembles never reaches."""
    case = SMALL.with_values({"geometry.slider_offset": 45.0, "geometry.crank_axial_shift": 0.0,
                              "motion.angles_deg": {"start": 90.0, "stop": 450.0, "step": 5.0}})
    table = run_engine("mujoco", case)
    iters = table.meta["newton_iterations"]
    cannot = assembly_margin(case, np.radians(table["theta1_deg"])) < 0
    assert iters.shape == (len(table),) and cannot.any()
    assert np.all(iters[cannot] == 0) and np.all((iters[~cannot] >= 1) & (iters[~cannot] < MUJOCO_MAX_ITER))


#: The MuJoCo closure's iteration cap (validation/judges/mujoco_slider_crank/closure.py).
MUJOCO_MAX_ITER = 60


def test_mujoco_sim_settings_and_servo_lag() -> None:
    """Force mode: the servo holds the crank against the drive torque the table reports, so its largest
    lag is ``max |drive_torque| / kp`` (kp the crank servo's gain, the table's own ``servo_kp``); the
    settings are the plan's (:func:`~dualmech.validation.judges.mujoco_slider_crank.sim_plan.prepare`), the
    run-in its rule by
    hand; torque mode: ``L_ref`` the pin force of the drive torque, ``|T| / a1``."""
    forced = with_loads(SMALL, drive_torque=None, slider_force=50.0)
    table = run_engine("mujoco-sim", forced)
    meta = table.meta
    settings = prepare(forced)[1]
    assert meta["timestep"] == settings.timestep
    assert meta["servo_kp"] == settings.servo_kp and meta["servo_kv"] == settings.servo_kv
    slow = max(kv / kp for kp, kv in zip(meta["servo_kp"], meta["servo_kv"]))
    assert meta["runin_steps"] == max(SIM_RUNIN_STEPS, math.ceil(SIM_RUNIN_TIME_CONSTANTS * slow
                                                                  / meta["timestep"]))
    lag = np.nanmax(np.abs(table["drive_torque"])) / meta["servo_kp"][0]
    assert_allclose(meta["max_theta_lag"], lag, rtol=SERVO_LAG)
    torque = run_engine("mujoco-sim", SMALL).meta["L_ref"]
    assert_allclose(torque, abs(SMALL.loads.drive_torque) / SMALL.geometry.crank_length, rtol=1e-15)
