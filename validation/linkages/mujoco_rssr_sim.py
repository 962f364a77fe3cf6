"""The RSSR simulated by MuJoCo: the input driven by a servo along the case's motion, the loop held by the
soft connect, the output torque applied at joint 4, MuJoCo's own constraint solver and integrator (the
simulated judge; a case in output-torque mode: the servo supplies the drive torque).

The simulation starts from the rigid MuJoCo judge's assembled state at the case's first crank angle
and runs ``duration`` seconds; every ``every`` steps it records the input's actual state
(``theta1, theta1_dot, theta1_ddot``), the output angle and rate and the connect's force on the output
crank (joint 3).  The in-house engine is then asked about the *recorded* input states, so the servo's
lag does not enter the comparison: what is compared is the soft loop against the rigid one.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from dualmech.core.motion import CrankState
from dualmech.core.status import Status
from dualmech.models.linkages.rssr import SPEC
from dualmech.models.linkages.rssr_case import RssrCase
from dualmech.models.linkages.table import LinkageTable
from dualmech.validation.linkages.judges import transmissions
from dualmech.validation.linkages.mjcf_rssr import rssr_mjcf
from dualmech.validation.linkages.mujoco_rssr import MjRssr, assemble, build

#: Servo natural frequency times the time step (the crank's own inertia; stable explicitly below 1).
SERVO_BANDWIDTH = 0.5


def servo_gains(case: RssrCase, timestep: float) -> tuple[float, float]:
    """``kp = I_low (SERVO_BANDWIDTH / dt)^2`` (the input crank's own inertia about z) and ``kv = 2
    sqrt(kp I_high)`` with ``I_high`` = twice the input crank with the coupler and output crank's masses at
    its pin: critically damped or more for any effective inertia up to it (``implicitfast`` integrates
    the damping implicitly)."""
    crank = case.bodies[0]
    i_low = crank.inertia[2, 2] + crank.mass * float(crank.com[0] ** 2 + crank.com[1] ** 2)
    i_high = 2.0 * (i_low + (case.bodies[1].mass + case.bodies[2].mass) * case.geometry.a1**2)
    kp = i_low * (SERVO_BANDWIDTH / timestep) ** 2
    return kp, 2.0 * math.sqrt(kp * i_high)


def _implicit_acceleration(m: mujoco.MjModel, d: mujoco.MjData, timestep: float, kv: float) -> np.ndarray:
    """The acceleration the ``implicitfast`` step integrates, ``(M + dt K)^{-1} M qacc`` (``K`` = the servo's
    velocity gain on joint 1; ``qacc`` after ``mj_forward`` is the explicit one).  The connect force of
    ``mj_forward`` is the rigid force at *this* acceleration (measured: 1e-5 of the peak, 2e-2 with qacc)."""
    mass = np.empty((m.nv, m.nv))
    column = np.empty(m.nv)
    for i in range(m.nv):
        mujoco.mj_mulM(m, d, column, np.eye(m.nv)[i])
        mass[:, i] = column
    damping = np.zeros((m.nv, m.nv))
    damping[0, 0] = kv
    return np.linalg.solve(mass + timestep * damping, mass @ d.qacc)


def simulate_rssr(case: RssrCase, timestep: float, duration: float, every: int,
                  runin: float = 0.01, drive_torque: float | None = None) -> dict[str, np.ndarray]:
    """Simulate ``case`` for ``duration`` s at ``timestep``; samples every ``every`` steps after ``runin`` s
    (the servo's start transient).  With ``drive_torque`` the input is free (no servo) and driven by that
    constant torque (forward dynamics).

    Returns ``time`` (s), ``theta1``, ``theta1_dot``, ``theta1_ddot``, ``phi4``, ``phi4_dot``, ``phi4_ddot``
    (rad, rad/s, rad/s^2; the accelerations the implicit step integrates), ``t1``, ``t4`` (the
    transmissions of the simulated pose), ``j3`` ``(m, 3)`` (the connect's force on the output crank,
    world axes) and ``gap`` (``|P_end - P_pin|`` over ``a2``), each over the ``m`` samples.
    """
    if case.mode != "output":
        raise ValueError("simulate_rssr: the input is servo-driven, so the case must give "
                         f"loads.output_torque (got drive_torque = {case.drive_torque!r})")
    kp, kv = servo_gains(case, timestep) if drive_torque is None else (0.0, 0.0)
    mr = build(case, rssr_mjcf(case, timestep, (kp, kv)))
    m, d = mr.model, mr.data
    theta0 = math.radians(float(case.motion.angles_deg[0]))
    w0, acc = case.motion.speed, case.motion.accel
    assemble(mr, case, theta0, w0, acc)  # the rigid judge's own crude start and Newton: qpos, qvel
    d.time = 0.0
    d.qfrc_applied[:] = 0.0
    d.qfrc_applied[4] = case.output_torque  # the ground's moment on the output crank about +k4 (joint 4)
    d.qfrc_applied[0] = 0.0 if drive_torque is None else drive_torque
    out: dict[str, list] = {}
    steps = int(round(duration / timestep))
    for step in range(steps + 1):
        t = d.time
        if drive_torque is None:
            d.ctrl[0] = theta0 + w0 * t + 0.5 * acc * t**2 + kv / kp * (w0 + acc * t)
        if step % every == 0 and t >= runin:
            for key, value in _sample(mr, case, timestep, kv).items():
                out.setdefault(key, []).append(value)
        mujoco.mj_step(m, d)
    return {k: np.array(v) for k, v in out.items()}


def _sample(mr: MjRssr, case: RssrCase, timestep: float, kv: float) -> dict[str, object]:
    """One row of :func:`simulate_rssr` at the current state (after ``mj_forward``)."""
    m, d = mr.model, mr.data
    mujoco.mj_forward(m, d)
    accel = _implicit_acceleration(m, d, timestep, kv)
    t1, t4 = transmissions(d.xpos[mr.coupler].copy(), d.site_xpos[mr.end].copy(), case)
    gap = np.linalg.norm(d.site_xpos[mr.pin] - d.site_xpos[mr.end]) / case.geometry.a2
    return {"time": d.time, "theta1": d.qpos[0], "theta1_dot": d.qvel[0], "theta1_ddot": accel[0],
            "phi4": d.qpos[5], "phi4_dot": d.qvel[4], "phi4_ddot": accel[4], "t1": t1, "t4": t4,
            "j3": d.efc_force[:3].copy(), "gap": gap}


def crank_states(sim: dict[str, np.ndarray]) -> CrankState:
    """The recorded input states as :class:`~dualmech.core.motion.CrankState` (no axial motion)."""
    zero = np.zeros_like(sim["theta1"])
    return CrankState(sim["theta1"], zero, sim["theta1_dot"], zero, sim["theta1_ddot"], zero)


#: Time step of the simulated judge (s): the one ``LINKAGE_SIM_*`` were measured at (errors ~dt and dt^2).
SIM_TIMESTEP = 2e-5
#: Columns the simulated judge gives; the other columns of its table are NaN (the connect's force is the
#: only reaction MuJoCo's soft loop reports as such).
SIM_COLUMNS: tuple[str, ...] = ("phi4_deg", "phi4_dot", "phi4_ddot", "transmission_in", "transmission_out",
                                "j3_fx", "j3_fy", "j3_fz")


def sim_plan(case: RssrCase, timestep: float = SIM_TIMESTEP) -> tuple[float, int]:
    """``duration`` (s) and sampling interval ``every`` (steps) of a run that turns the input once over the
    case's range of crank angles along its motion ``theta1(t) = theta_0 + w t + a t^2 / 2``, sampled about
    as densely as the case's angles."""
    deg = case.motion.angles_deg
    sweep = math.radians(abs(float(deg[-1] - deg[0])))
    w = abs(case.motion.speed)
    a = case.motion.accel * (1.0 if case.motion.speed >= 0 else -1.0)  # along the motion
    if w == 0.0 or w * w + 2.0 * a * sweep <= 0.0:
        raise ValueError(f"motion: the simulated judge turns the input along the case's motion; crank_rpm "
                         f"{case.motion.speed * 30 / math.pi:g} with crank_accel {case.motion.accel:g} "
                         "does not cover the case's angles")
    turn = sweep / w if a == 0.0 else (math.sqrt(w * w + 2.0 * a * sweep) - w) / a
    every = max(1, int(round(turn / max(len(deg) - 1, 1) / timestep)))
    return turn, every


def solve_mujoco_sim(case: RssrCase) -> LinkageTable:
    """The simulated judge's table (engine ``"mujoco-sim"``): one row per sample of :func:`simulate_rssr`
    over :func:`sim_plan`, at the *simulated* input states (``theta1_deg``; the rates are in
    ``meta["crank"]``), the columns :data:`SIM_COLUMNS` (``meta["gives"]``), ``residual`` the connect's gap
    over ``a2``; ``ok`` where every given value is finite, else ``not_finite``."""
    duration, every = sim_plan(case)
    sim = simulate_rssr(case, SIM_TIMESTEP, duration, every)
    n = sim["theta1"].shape[0]
    cols = {c: np.full(n, np.nan) for c in SPEC.columns}
    phi = np.mod(sim["phi4"] + np.pi, 2 * np.pi) - np.pi  # in [-pi, pi), as every engine gives it
    cols.update(theta1_deg=np.degrees(sim["theta1"]), phi4_deg=np.degrees(phi),
                phi4_dot=sim["phi4_dot"], phi4_ddot=sim["phi4_ddot"], transmission_in=sim["t1"],
                transmission_out=sim["t4"], residual=sim["gap"])
    for i, axis in enumerate("xyz"):
        cols[f"j3_f{axis}"] = sim["j3"][:, i]
    finite = np.all([np.isfinite(cols[c]) for c in SIM_COLUMNS], axis=0)
    status = np.where(finite, Status.OK.value, Status.NOT_FINITE.value)
    note = (f"simulated {duration:.3g} s at dt = {SIM_TIMESTEP:g} s, a row every {every} steps, at the "
            "simulated input states")
    return LinkageTable("mujoco-sim", case.name, cols, status,
                        {"crank": crank_states(sim), "gives": SIM_COLUMNS, "messages": [note]})
