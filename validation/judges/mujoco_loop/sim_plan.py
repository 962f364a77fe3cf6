"""Planning a simulation of a loop table (:mod:`.simulation`): which rows, from which rigid poses, on which
time grid, with which servos.

:func:`survey` closes every row by the rigid judge's own continuation (:func:`.engine.sweep`) and
measures what the servo will see; :func:`plan` gives the time step, servo gains, weld softness, runs and
run-in ("Settings" and "Runs" in :mod:`.simulation`'s docstring, where they are explained).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from dualmech.core.status import Status
from dualmech.models.loop.description import LoopMechanism
from dualmech.models.mjcf_settings import (
    CLOSURE_DAMPRATIO,
    CLOSURE_DAMPRATIO_UNIVERSAL,
    SERVO_BANDWIDTH,
    STEPS_PER_DEGREE,
    phase_timestep,
)
from dualmech.validation.judges.mujoco_loop.closure import MjLoop, build, positions
from dualmech.validation.judges.mujoco_loop.dynamics import balance, solve_free, velocity_rows
from dualmech.validation.judges.mujoco_loop.engine import efforts, sweep
from dualmech.validation.judges.mujoco_loop.sim_mjcf import SimSettings, servoed
from dualmech.validation.judges.mujoco_slider_crank.sim_plan import (
    SIM_INERTIA_MARGIN,
    SIM_RUNIN_STEPS,
    SIM_RUNIN_TIME_CONSTANTS,
)
from dualmech.validation.tolerances import DEAD_CENTRE_TRANSMISSION


@dataclass(frozen=True)
class Survey:
    """The rigid judge's sweep (:mod:`.simulation`'s docstring, "Starts").

    ``status`` (n,) its words; ``qpos`` (n, nq) and ``q_cut`` (n, c) its closed poses (NaN elsewhere);
    ``tangent`` (n, servos, n_u) their velocity-space motion per unit of each servoed coordinate;
    ``iterations`` (n,); ``transmission`` (n,); ``inertia_high`` per servo the largest effective inertia;
    ``fastest`` the largest rate of any scalar joint coordinate per unit rate of the drive over the closed
    rows (:func:`joint_speeds`), at least 1.
    """

    status: np.ndarray
    qpos: np.ndarray
    q_cut: np.ndarray
    tangent: np.ndarray
    iterations: np.ndarray
    transmission: np.ndarray
    inertia_high: tuple[float, ...]
    fastest: float

    @property
    def assembled(self) -> np.ndarray:
        """Rows closed on the start's branch, (n,) bool."""
        return np.isin(self.status.astype(str), (Status.OK.value, Status.DEAD_CENTRE.value))


def _unit_rates(lp: MjLoop) -> np.ndarray:
    """The velocity ``(servos, n_u)`` for a unit rate of each servoed coordinate (the other held)."""
    positions(lp)
    rows = velocity_rows(lp)
    zero = np.zeros(rows.shape[0])
    return np.array([solve_free(lp, rows, unit, zero) for unit in np.eye(lp.prescribed.size)])


def joint_speeds(lp: MjLoop, tangent: np.ndarray) -> np.ndarray:
    """The rate of every scalar joint coordinate of the table (``docs/conventions.md``, "Loop tables": an R,
    P, C or U joint's ``theta``, ``s``, ``eta``, the columns the gate compares) per unit rate of the drive,
    ``(n, n_u)``, from the drive servo's ``tangent`` ``(n, n_u)``: angles in rad, slides over the table's
    length, per radian of an angle drive or per table length of a slide drive; 0 at a ball's three rates
    (no column)."""
    types = lp.model.jnt_type[lp.model.dof_jntid]
    slide = np.concatenate([types == mujoco.mjtJoint.mjJNT_SLIDE, [c == "s" for c in lp.cut]])
    ball = np.concatenate([types == mujoco.mjtJoint.mjJNT_BALL, np.zeros(len(lp.cut), dtype=bool)])
    per_drive = lp.size if lp.mechanism.drive.coordinate == "s" else 1.0
    return np.where(ball, 0.0, np.abs(tangent) * per_drive / np.where(slide, lp.size, 1.0))


def survey(mechanism: LoopMechanism, seed: int = 0) -> Survey:
    """Close every row by the rigid judge (:mod:`.simulation`'s docstring, "Starts"); ``seed`` of its
    start search."""
    lp = build(mechanism)
    n = mechanism.drive.positions.shape[0]
    given, solved = efforts(mechanism)
    status = np.full(n, Status.NOT_CONVERGED.value, dtype=object)
    qpos, q_cut = np.full((n, lp.model.nq), np.nan), np.full((n, len(lp.cut)), np.nan)
    tangent = np.full((n, lp.prescribed.size, lp.n_u), np.nan)
    iterations, transmission = np.zeros(n, dtype=int), np.full(n, np.nan)
    high = [0.0] * lp.prescribed.size
    mass = np.empty((lp.model.nv, lp.model.nv))
    for k, outcome, iterations[k], _ in sweep(lp, seed):
        status[k] = outcome
        if outcome != Status.OK:
            continue
        qpos[k], q_cut[k] = lp.data.qpos, lp.q_cut
        tangent[k] = _unit_rates(lp)
        # the transmission is the balance matrix's alone, a function of the pose: any rates will do
        transmission[k] = balance(lp, np.zeros(lp.n_u), given, solved).transmission
        if transmission[k] < DEAD_CENTRE_TRANSMISSION.value:
            status[k] = Status.DEAD_CENTRE.value
        mujoco.mj_crb(lp.model, lp.data)
        mujoco.mj_fullM(lp.model, lp.data, mass)
        for s, v in enumerate(tangent[k, :, :lp.model.nv]):
            high[s] = max(high[s], float(v @ mass @ v))
    speeds = joint_speeds(lp, tangent[:, 0, :])
    fastest = float(np.max(speeds[np.isfinite(speeds).all(axis=1)], initial=1.0))
    return Survey(status, qpos, q_cut, tangent, iterations, transmission, tuple(high), fastest)


def timestep(mechanism: LoopMechanism, steps_per_degree: int = STEPS_PER_DEGREE,
             fastest: float = 1.0) -> float:
    """Seconds per step (:mod:`.simulation`'s docstring, "Settings"): one degree of the drive's fastest phase
    over ``steps_per_degree`` (a slide drive's degree is one degree times the table's length), over
    ``fastest`` (:attr:`Survey.fastest`) where a joint moves faster than the drive: one degree of the
    fastest *joint*."""
    d = mechanism.drive
    degree = math.radians(1.0) * (length(mechanism) if d.coordinate == "s" else 1.0)
    drive = phase_timestep(d.speed, d.accel, d.axial_amplitude, d.axial_cycles, steps_per_degree, degree)
    return drive / max(1.0, fastest)


def length(mechanism: LoopMechanism) -> float:
    """The table's length: its largest constant length, or 1."""
    sizes = [abs(v) for j in mechanism.joints for v in (j.a, j.s)]
    return max(sizes) if max(sizes) > 0.0 else 1.0


def _inertia_low(mechanism: LoopMechanism) -> tuple[float, ...]:
    """The driven link's own inertia about the drive axis through its frame origin, its mass along it."""
    d = mechanism.drive
    body = mechanism.bodies[d.joint]
    i, c = np.asarray(body.inertia), np.asarray(body.com)
    about = float(i[2, 2] + body.mass * (c[0] ** 2 + c[1] ** 2))
    return tuple(about if c == "theta" else body.mass for c in (d.coordinate, "s")[:len(servoed(mechanism))])


def settings(mechanism: LoopMechanism, dt: float, sv: Survey) -> SimSettings:
    """Servo gains and weld softness at step ``dt`` (:mod:`.simulation`'s docstring, "Settings")."""
    low = _inertia_low(mechanism)
    high = tuple(max(SIM_INERTIA_MARGIN * h, lo) for h, lo in zip(sv.inertia_high, low))
    wn = SERVO_BANDWIDTH / dt
    kp = tuple(lo * wn**2 for lo in low)
    kv = tuple(2.0 * math.sqrt(k * h) for k, h in zip(kp, high))
    universal = any(j.type == "U" for j in mechanism.joints)
    damping = CLOSURE_DAMPRATIO_UNIVERSAL if universal else CLOSURE_DAMPRATIO
    return SimSettings(dt, kp, kv, (2.0 * dt, damping), (0.9999, 0.9999, 0.001, 0.5, 2.0))


def weld_time_constant(s: SimSettings) -> float:
    """The weld's slowest time constant (s): MuJoCo's reference acceleration :math:`-b\\dot r - k r` with
    :math:`b = 2/(d\\,t_c)`, :math:`k = 1/(d\\,t_c\\,\\zeta)^2` (``solref = (t_c, zeta)``, ``d`` the
    impedance), the root of :math:`s^2 + b s + k` nearest 0: ~63 steps at ``zeta = 4``, ~15 at 2."""
    tc, zeta = s.weld_solref
    d = s.weld_solimp[1]
    b, k = 2.0 / (d * tc), 1.0 / (d * tc * zeta) ** 2
    return 2.0 / (b - math.sqrt(max(b * b - 4.0 * k, 0.0)))


def runin_steps(s: SimSettings) -> int:
    """Steps before a run's first row: :data:`SIM_RUNIN_TIME_CONSTANTS` of the slower of the servo's
    ``kv/kp`` and the weld's :func:`weld_time_constant` (at least :data:`SIM_RUNIN_STEPS`), so that the
    transient from the rigid start decays in both."""
    slow = max(max(kv / kp for kp, kv in zip(s.servo_kp, s.servo_kv)), weld_time_constant(s))
    return max(SIM_RUNIN_STEPS, math.ceil(SIM_RUNIN_TIME_CONSTANTS * slow / s.timestep))


def schedule(mechanism: LoopMechanism, dt: float, rows: np.ndarray,
             runin: int) -> tuple[float, list[tuple[np.ndarray, np.ndarray]]]:
    """The time step and the runs: per run the rows it serves ``(k,)`` and the step each is read at
    ``(k,)`` (the first at ``runin``, the run's anchor)."""
    d = mechanism.drive
    p = d.positions
    if d.accel == 0.0 and d.speed != 0.0 and rows.all() and p.shape[0] > 1:
        t = (p - p[0]) / d.speed
        order = np.argsort(t, kind="stable")
        elapsed = t[order] - t[order[0]]
        gap = float(np.min(np.diff(elapsed)))
        if gap > 0.0:
            step = gap / max(1, math.ceil(gap / dt - 1e-9))
            steps = np.rint(elapsed / step).astype(np.int64)
            if np.max(np.abs(steps * step - elapsed)) <= 1e-6 * step:
                return step, [(order, steps + runin)]
    return dt, [(np.array([k]), np.array([runin])) for k in np.flatnonzero(rows)]


def load_scale(mechanism: LoopMechanism) -> float:
    """``L_ref`` of the solved load (:mod:`.simulation`'s docstring, "A solved load"): the given drive
    effort's, else an inertial one, as a force along (times the table's length about) the loaded axis."""
    d, size = mechanism.drive, length(mechanism)
    load = next(load for load in mechanism.loads if load.value is None)
    lever = size if load.coordinate == "theta" else 1.0
    drive_lever = size if d.coordinate == "theta" else 1.0
    if d.effort:
        return abs(d.effort) / drive_lever * lever
    mass = sum(b.mass for b in mechanism.bodies)
    scale = mass * (size * (d.speed**2 + abs(d.accel)) / (size if d.coordinate == "s" else 1.0)
                    + float(np.linalg.norm(mechanism.gravity)))
    return (scale if scale > 0 else 1.0) * lever


def plan(mechanism: LoopMechanism, sv: Survey,
         steps_per_degree: int = STEPS_PER_DEGREE) -> tuple[SimSettings, list, int]:
    """The simulation's settings, runs (:func:`schedule`) and run-in steps for the rows ``sv`` assembles."""
    s = settings(mechanism, timestep(mechanism, steps_per_degree, sv.fastest), sv)
    runin = runin_steps(s)
    dt, runs = schedule(mechanism, s.timestep, sv.assembled, runin)
    return (settings(mechanism, dt, sv) if dt != s.timestep else s), runs, runin


__all__ = ["Survey", "joint_speeds", "length", "load_scale", "plan", "runin_steps", "schedule", "settings",
           "survey", "timestep", "weld_time_constant"]
