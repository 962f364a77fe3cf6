"""Planning a MuJoCo simulation of a case: which rows can be simulated, on which time grid, with which servos.

:func:`survey` closes the loop rigidly at every row (MuJoCo's own geometry) to find the rows that
assemble and the largest effective inertias the crank servos see; :func:`schedule` splits the rows
into runs on a common time grid; :func:`prepare` gives both to
:mod:`~dualmech.validation.judges.mujoco_slider_crank.sim`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from dualmech.core.status import Status, flag_joint_lock, is_status, joint_locked
from dualmech.models.case import Case
from dualmech.models.mjcf import (
    MjcfSettings,
    default_settings,
    default_timestep,
    simulation_steps,
)
from dualmech.validation.judges.mujoco_slider_crank import engine as rigid
from dualmech.validation.judges.mujoco_slider_crank.dynamics import rate_rows, solve_rates

#: Fewest steps simulated before the first row of a run; more if the servos' slow pole needs them.
SIM_RUNIN_STEPS = 128
#: Run-in length in time constants of the servos' slow pole kp/kv (transients decay to e^-12).
SIM_RUNIN_TIME_CONSTANTS = 12.0
#: Margin on the largest effective inertia the servos see along the case (their damping).
SIM_INERTIA_MARGIN = 1.5


@dataclass(frozen=True)
class Schedule:
    """How the rows of a case are simulated.

    Attributes
    ----------
    timestep : float
        Seconds.
    runs : tuple[tuple[numpy.ndarray, numpy.ndarray], ...]
        Per run: the row indices it serves, shape (k,), and the step at which
        each is read, counted from the run's start, shape (k,), increasing.
    anchors : tuple[int, ...]
        Per run, the row whose snapshot the trajectory passes at time 0 (read at
        step ``runin``).
    runin : int
        Steps simulated before the first row of each run.
    """

    timestep: float
    runs: tuple[tuple[np.ndarray, np.ndarray], ...]
    anchors: tuple[int, ...]
    runin: int

    @property
    def steps(self) -> int:
        """Simulated steps of one pass over every run."""
        return sum(int(s[-1]) + 1 for _, s in self.runs)


def schedule(case: Case, steps_per_degree: int | None = None, rows: np.ndarray | None = None,
             runin: int = SIM_RUNIN_STEPS) -> Schedule:
    """Split the rows of ``case`` into simulation runs on a common time grid (module docstring).

    ``rows``: boolean mask, shape (n,), of the rows to simulate (default all).  One
    continuous run needs every row (a trajectory cannot pass where the mechanism
    does not assemble); otherwise each selected row gets its own run.  Each run
    starts ``runin`` steps before its first row.  ``steps_per_degree``: :func:`simulation_steps`.
    """
    steps_per_degree = simulation_steps(case, steps_per_degree)
    if (
        isinstance(steps_per_degree, bool)
        or int(steps_per_degree) != steps_per_degree
        or steps_per_degree < 1
    ):
        raise ValueError(f"steps_per_degree: expected a positive integer, got {steps_per_degree!r}")
    mo = case.motion
    deg = mo.angles_deg
    wanted = np.ones(deg.shape[0], dtype=bool) if rows is None else np.asarray(rows, dtype=bool)
    speed = abs(mo.speed)
    if mo.accel == 0.0 and speed > 0.0 and wanted.all():
        spacing = float(np.min(np.diff(np.sort(deg)))) if deg.shape[0] > 1 else 1.0
        gap = math.radians(spacing) / speed  # seconds between neighbouring rows
        dt = gap / max(1, math.ceil(gap / default_timestep(case, steps_per_degree) - 1e-9))
        t = np.radians(deg) / mo.speed  # row times on theta = speed * t
        order = np.argsort(t, kind="stable")
        elapsed = t[order] - t[order[0]]
        steps = np.rint(elapsed / dt).astype(np.int64)
        if np.max(np.abs(steps * dt - elapsed)) > 1e-6 * dt:
            raise ValueError("motion.angles_deg: the rows do not fall on a common time grid")
        return Schedule(dt, ((order, steps + runin),), (int(order[0]),), runin)
    dt = default_timestep(case, steps_per_degree)
    picked = np.flatnonzero(wanted)
    runs = tuple((np.array([i]), np.array([runin])) for i in picked)
    return Schedule(dt, runs, tuple(int(i) for i in picked), runin)


@dataclass(frozen=True)
class Survey:
    """What the rigid path's closure finds at every row before anything is simulated.

    ``status`` (n,) words of :func:`~dualmech.validation.judges.mujoco_slider_crank.engine.assembled_state`;
    ``s4`` and
    ``condition`` (n,) its pose's ``S4`` and ``|u·k4|``; ``inertia_high`` the largest effective inertias
    of the crank angle (F·L·s²) and axial (F·s²/L) joints over the rows that assemble.
    """

    status: np.ndarray
    s4: np.ndarray
    condition: np.ndarray
    inertia_high: tuple[float, float]

    @property
    def simulated(self) -> np.ndarray:
        """Rows a simulation can pass, (n,) bool: not ``no_assembly``, not at the ``assembly_limit``, not
        where a universal joint locks (``joint_lock``: the rod's spin rate, hence the servos' effective
        inertia and the time step, unbounded)."""
        return ~is_status(self.status, Status.NO_ASSEMBLY, Status.ASSEMBLY_LIMIT, Status.JOINT_LOCK)


def survey(case: Case) -> Survey:
    """Which rows assemble, and the largest effective inertias the two crank servos see there.

    Uses the rigid path's own closure at every row (MuJoCo geometry, never the
    in-house answer).  The effective inertia of a servo is :math:`v^T M v` with
    ``v`` the mechanism's velocity for a unit rate of that servo's joint (the
    other crank joint held, zero rod spin with a ball at P3); a revolute crank has no axial servo (0).
    """
    lp = rigid.build(case)
    st = case.own_crank_states()
    n = len(st)
    status = np.empty(n, dtype=object)
    s4, condition = np.full(n, np.nan), np.full(n, np.nan)
    high = [0.0, 0.0]
    mass = np.empty((lp.model.nv, lp.model.nv))
    warm = False
    for i in range(n):
        word, _, _, c = rigid.assembled_state(lp, (float(st.theta[i]), float(st.s[i]), 1.0, 0.0), warm)
        status[i], s4[i], condition[i] = word, lp.data.qpos[lp.qadr[3]], c
        warm = word == Status.OK and not joint_locked(c, case.joints.universal)  # its flag below
        if warm:
            mujoco.mj_fullM(lp.model, lp.data, mass)
            for k, v in enumerate(_unit_rates(lp)):
                high[k] = max(high[k], float(v @ mass @ v))
    status = flag_joint_lock(status, condition, case.joints.universal)
    return Survey(status, s4, condition, (high[0], high[1]))


def _unit_rates(lp: rigid.MjLoop) -> list[np.ndarray]:
    """The mechanism's velocity for a unit rate of each crank joint (the other held) at the closed pose, (nv,)
    each: ``qvel`` as :func:`~dualmech.validation.judges.mujoco_slider_crank.engine.assembled_state` left it
    for the crank
    angle, the same rate rows for the axial joint."""
    rates = [lp.data.qvel.copy()]
    if lp.crank_dofs.size == 2:
        rows, _ = rate_rows(lp)
        rates.append(solve_rates(lp, rows, np.array([0.0, 1.0]), np.zeros(rows.shape[0])))
    return rates


def runin_steps(settings: MjcfSettings) -> int:
    """Steps before the first row: ``SIM_RUNIN_TIME_CONSTANTS`` times ``kv/kp``, at least
    ``SIM_RUNIN_STEPS``."""
    slow = max(kv / kp for kp, kv in zip(settings.servo_kp, settings.servo_kv))
    return max(SIM_RUNIN_STEPS, math.ceil(SIM_RUNIN_TIME_CONSTANTS * slow / settings.timestep))


def sim_settings(case: Case, timestep: float, inertia_high: tuple[float, float]) -> MjcfSettings:
    """The simulation's MJCF settings: :func:`~dualmech.models.mjcf.default_settings` with measured
    inertias."""
    return default_settings(case, timestep, inertia_high=tuple(SIM_INERTIA_MARGIN * h for h in inertia_high))


def prepare(case: Case, steps_per_degree: int | None = None) -> tuple[np.ndarray, MjcfSettings]:
    """Rows to simulate (:attr:`Survey.simulated`) and the simulation settings for ``case``."""
    sv = survey(case)
    return sv.simulated, checked_settings(case, steps_per_degree, sv)


def checked_settings(case: Case, steps_per_degree: int | None, sv: Survey) -> MjcfSettings:
    """:func:`sim_settings` at the schedule's step; ``OverflowError`` if they leave the double range."""
    dt = schedule(case, steps_per_degree, sv.simulated).timestep
    if not (dt > 0.0 and math.isfinite(1.0 / dt)):
        raise OverflowError(f"time step {dt!r} s")
    s = sim_settings(case, dt, sv.inertia_high)
    if not all(math.isfinite(v) for v in (*s.servo_kp, *s.servo_kv)):
        raise OverflowError(f"servo gains {s.servo_kp!r}, {s.servo_kv!r} at the time step {dt!r} s")
    return s
