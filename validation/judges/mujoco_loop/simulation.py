"""MuJoCo's simulation as a judge of any loop table: what a user sees when MuJoCo integrates the loop.

MuJoCo steps the model of :mod:`.sim_mjcf` (the loop cut inside the ground, held by a soft ``weld``;
integrator ``implicitfast``) while a position servo with rate feed-forward drives the drive joint through
the prescribed motion and motors apply the table's loads; the rows are read from the simulated state.

**Starts.** The rigid judge's own continuation (:func:`.engine.sweep`: its start values or search, its
branch) closes every row first; it tells which rows assemble on the start's branch, their transmission
and the largest effective inertia the servo sees (:math:`v^T M v`, ``v`` the mechanism's velocity for a
unit drive rate, the idle spins held at zero).  Each run starts from a rigidly closed state (the rigid
closure from the nearest row's pose, its rates from the rigid rate equations), never from the in-house
engine.  Rows that do not assemble, or jump branch, keep the rigid word and are not simulated.

**Runs.** With a constant drive speed and every row assembled, one run passes every row (rows on the
step grid); otherwise each row gets its own run along the trajectory through its snapshot.  Each run
starts ``runin`` steps before its first row.

**Settings** (as the slider crank's simulated judge, ``validation/judges/mujoco_slider_crank/sim.py``, where
they are
measured): ``dt`` = one degree of the drive's fastest phase (a slide: one degree times the table's
length) over :data:`~dualmech.models.mjcf_settings.STEPS_PER_DEGREE`, at most
:data:`~dualmech.models.mjcf_settings.MAX_TIMESTEP`, and one degree of the fastest joint where a joint
turns faster than the drive (:func:`.sim_plan.timestep`, the survey's :attr:`.sim_plan.Survey.fastest`);
servo ``kp = I_low (0.5/dt)^2`` with ``I_low`` the
driven link's own inertia about (mass along) the drive axis, ``kv = 2 sqrt(kp I_high)`` with ``I_high``
the margin :data:`~dualmech.validation.judges.mujoco_slider_crank.sim_plan.SIM_INERTIA_MARGIN` times the
largest effective
inertia; weld ``solref = (2 dt, 2)`` (damping ratio 4 with a universal joint), ``solimp`` 0.9999; the run-in
:data:`~dualmech.validation.judges.mujoco_slider_crank.sim_plan.SIM_RUNIN_TIME_CONSTANTS` time constants of
the slower of the
servo's ``kv/kp`` and the weld's slow pole (:func:`.sim_plan.weld_time_constant`: ~63 steps at damping
ratio 4, whose transient from the rigid start otherwise biased a U joint's accelerations by 2e-3 of
their peak), at least :data:`~dualmech.validation.judges.mujoco_slider_crank.sim_plan.SIM_RUNIN_STEPS`.
Collision detection
and island discovery are switched off (no geoms, one equality).  A run in which MuJoCo warns (it blew up)
is not trusted: its rows are ``not_converged``.

**Reading a row.** After ``mj_forward`` the *integrated* acceleration
:math:`a = (M + \\Delta t K)^{-1} M \\ddot q` (``K`` the servos' velocity gains, which ``implicitfast``
treats implicitly) is written into ``qacc``, and ``mj_rnePostConstraint`` gives every body's wrench from
its parent (``cfrc_int``): joint i's wrench on link i from link i-1 (joint n's on ``ground_half``), the
moment moved to the joint's point as the rigid judge does (:func:`.dynamics.joint_points`).  Each effort
is its joint's wrench along (about) the joint axis.  The coordinates, rates and accelerations are
``qpos``, ``qvel`` and the integrated ``qacc``; ``residual`` is the weld's gap over the table's length.

**A solved load** (the drive's effort given): the forward simulation needs the load, so it runs twice, the
solved load's motor at 0 and at ``L_ref``; each row's efforts and wrenches are affine in the load, and
the row's weight :math:`w = (T - \\tau_0)/(\\tau_\\mathrm{ref} - \\tau_0)` (``T`` the given drive effort,
:math:`\\tau` the simulated ones) combines them; kinematics are the unloaded run's.  Rows whose rigid
transmission is below :data:`~dualmech.validation.tolerances.SIM_DEAD_CENTRE_TRANSMISSION` are
``dead_centre`` (the load grows like 1/t there and strains the soft loop): efforts and wrenches NaN.

The plan (rows, starts, settings, runs) is :mod:`.sim_plan`.  Error budget and tolerances:
``docs/conventions.md``, "Loop tables: the simulated loop judge".
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np
from mujoco import rollout

from dualmech.core.status import Status, settle
from dualmech.models.loop.description import LoopMechanism
from dualmech.models.loop.mobility import check_mobility
from dualmech.models.mjcf_settings import (
    STEPS_PER_DEGREE,
)
from dualmech.validation.judges.mujoco_loop.closure import MjLoop, build, close, move, prescribe
from dualmech.validation.judges.mujoco_loop.dynamics import joint_points, solve_free, velocity_rows
from dualmech.validation.judges.mujoco_loop.engine import (
    LoopTable,
    column_names,
    drive_at,
    drive_values,
    efforts,
)
from dualmech.validation.judges.mujoco_loop.mjcf import MJ_JOINTS, body_name, joint_name
from dualmech.validation.judges.mujoco_loop.sim_mjcf import (
    HALF_BODY,
    HALF_SITE,
    SimSettings,
    loop_sim_mjcf,
)
from dualmech.validation.judges.mujoco_loop.sim_plan import Survey, length, load_scale, plan, survey
from dualmech.validation.judges.mujoco_slider_crank.sim import (
    skip_collisions,
    skip_islands,
    stepped,
    velocity_gains,
)
from dualmech.validation.tolerances import SIM_DEAD_CENTRE_TRANSMISSION

ENGINE = "mujoco-loop-sim"


@dataclass
class SimModel:
    """The compiled simulation model and its addresses."""

    lp: MjLoop  # the simulation model with the rigid judge's addresses (joint points)
    coordinates: dict[str, tuple[int, int]]  # scalar variable -> (qpos, dof) address
    bodies: tuple[int, ...]  # joint i's following body: link1 .. link<n-1>, ground_half
    half_site: int
    ground_site: int


def compile_sim(mechanism: LoopMechanism, s: SimSettings, xml: str | None = None) -> SimModel:
    """Compile :func:`~.sim_mjcf.loop_sim_mjcf` (or the given text) and collect the addresses."""
    lp = build(mechanism, loop_sim_mjcf(mechanism, s) if xml is None else xml)
    m = lp.model
    skip_collisions(m)
    skip_islands(m)
    coordinates = {}
    for i, joint in enumerate(mechanism.joints):
        for coordinate, kind, _ in MJ_JOINTS[joint.type]:
            if kind != "ball":
                jid = m.joint(joint_name(i, coordinate)).id
                coordinates[f"{coordinate}{i + 1}"] = (int(m.jnt_qposadr[jid]), int(m.jnt_dofadr[jid]))
    n = len(mechanism.joints)
    bodies = tuple(m.body(body_name(k)).id for k in range(1, n)) + (m.body(HALF_BODY).id,)
    return SimModel(lp, coordinates, bodies, m.site(HALF_SITE).id, lp.sites[1])


def reference(mechanism: LoopMechanism, anchor: int, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The servos' references ``(k, servos)`` and rates ``(k, servos)`` at ``times`` (s, 0 at row
    ``anchor``): the trajectory through the anchor's snapshot."""
    d = mechanism.drive
    value = d.positions[anchor] + d.speed * times + 0.5 * d.accel * times**2
    rate = d.speed + d.accel * times
    values, rates, _ = drive_at(mechanism, value, rate, d.accel)
    return np.stack(list(values.values()), axis=-1), np.asarray(rates).T


def run_start(rigid: MjLoop, sv: Survey, anchor: int, values: np.ndarray,
              rates: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """The simulation's ``qpos``, ``qvel`` at a run's first step: the rigid loop closed at the first
    references ``values`` (servos,) from row ``anchor``'s pose moved along its tangent, with the rigid rates
    for ``rates`` (servos,); joint n's as ``ground_half``'s joints.  ``None`` where it does not close."""
    rigid.data.qpos[:], rigid.q_cut = sv.qpos[anchor], sv.q_cut[anchor].copy()
    row_values = np.array(list(drive_values(rigid.mechanism, anchor)[0].values()))
    move(rigid, (values - row_values) @ sv.tangent[anchor])  # the predictor: Newton then takes a step or two
    prescribe(rigid, dict(zip(drive_at(rigid.mechanism, 0.0, 0.0, 0.0)[0], values)))
    if close(rigid)[0] != Status.OK:
        return None
    rows = velocity_rows(rigid)
    u_dot = solve_free(rigid, rows, rates, np.zeros(rows.shape[0]))
    nv = rigid.model.nv
    if not rigid.ball_cut:
        return np.r_[rigid.data.qpos, rigid.q_cut], u_dot
    # the ground half turned by the ball into the ground's frame, at rest: its rate cancels link n-1's
    mujoco.mj_kinematics(rigid.model, rigid.data)
    jacr = np.empty((3, nv))
    mujoco.mj_jacBody(rigid.model, rigid.data, None, jacr, rigid.bodies[-1])
    site_link = rigid.data.site_xmat[rigid.sites[0]].reshape(3, 3)
    ground = rigid.data.site_xmat[rigid.sites[1]].reshape(3, 3)
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, (site_link.T @ ground).reshape(-1))
    return np.r_[rigid.data.qpos, quat], np.r_[u_dot[:nv], -ground.T @ (jacr @ u_dot[:nv])]


def run_starts(mechanism: LoopMechanism, sv: Survey, s: SimSettings, runs: list,
               runin: int) -> list[tuple[np.ndarray, np.ndarray] | None]:
    """:func:`run_start` of every run (shared by the two load runs of a solved load)."""
    rigid = build(mechanism)
    out = []
    for rows, _ in runs:
        values, rates = reference(mechanism, int(rows[0]), np.array([-runin * s.timestep]))
        out.append(run_start(rigid, sv, int(rows[0]), values[0], rates[0]))
    return out


def read_row(sim: SimModel, gains: np.ndarray, effort_names: list[str], size: float) -> dict[str, float]:
    """Columns of the current simulated state (module docstring, "Reading a row"); after ``mj_forward``
    (overwrites ``qacc``)."""
    m, d = sim.lp.model, sim.lp.data
    mass = np.empty((m.nv, m.nv))
    mujoco.mj_fullM(m, d, mass)
    d.qacc[:] = np.linalg.solve(mass + m.opt.timestep * gains, mass @ d.qacc)
    mujoco.mj_rnePostConstraint(m, d)
    out = {}
    for name, (qadr, dadr) in sim.coordinates.items():
        out[name], out[name + "_dot"], out[name + "_ddot"] = d.qpos[qadr], d.qvel[dadr], d.qacc[dadr]
    bodies = np.array(sim.bodies)
    forces = d.cfrc_int[bodies, 3:]
    arms = d.subtree_com[m.body_rootid[bodies]] - joint_points(sim.lp)
    moments = d.cfrc_int[bodies, :3] + np.cross(arms, forces)
    for i in range(bodies.size):
        for a, axis in enumerate("xyz"):
            out[f"joint{i + 1}_f{axis}"], out[f"joint{i + 1}_m{axis}"] = forces[i, a], moments[i, a]
    for name in effort_names:
        coordinate = name.rstrip("0123456789")
        i = int(name[len(coordinate):]) - 1
        z = d.xmat[sim.bodies[i]].reshape(3, 3)[:, 2]
        kind = "f" if coordinate == "s" else "m"
        out[f"effort_{name}"] = float(sum(out[f"joint{i + 1}_{kind}{a}"] * z[k] for k, a in enumerate("xyz")))
    out["residual"] = float(np.linalg.norm(d.site_xpos[sim.half_site] - d.site_xpos[sim.ground_site])) / size
    return out


def simulate(mechanism: LoopMechanism, starts: list, s: SimSettings, runs: list, runin: int,
             loads: np.ndarray, xml: str | None = None) -> dict[str, np.ndarray]:
    """One pass over ``runs`` from their ``starts`` (:func:`run_starts`) with the motors' efforts ``loads``
    ``(n_loads,)``: raw columns ``(n,)`` (:func:`read_row`'s, plus ``lag``: the drive's simulated minus
    prescribed coordinate), NaN where not simulated or not trusted."""
    sim = compile_sim(mechanism, s, xml)
    m, d = sim.lp.model, sim.lp.data
    kp, kv = np.array(s.servo_kp), np.array(s.servo_kv)
    gains = velocity_gains(m)
    given, solved = efforts(mechanism)
    names = list(given) + solved
    size = length(mechanism)
    drive = sim.coordinates[f"{mechanism.drive.coordinate}{mechanism.drive.joint + 1}"][0]
    n = mechanism.drive.positions.shape[0]
    out = {c: np.full(n, np.nan) for c in (*column_names(mechanism), "residual", "lag")}
    with rollout.Rollout(nthread=0) as roller:
        for (rows, steps), start in zip(runs, starts):
            if start is None:
                continue
            times = (np.arange(int(steps[-1]) + 1) - runin) * s.timestep
            values, rates = reference(mechanism, int(rows[0]), times)
            mujoco.mj_resetData(m, d)
            d.qpos[:], d.qvel[:] = start
            mujoco.mj_forward(m, d)
            ctrl = np.hstack([values + kv / kp * rates, np.broadcast_to(loads, (times.size, loads.size))])
            for i, k in enumerate(stepped(m, d, ctrl, steps, roller)):
                mujoco.mj_forward(m, d)
                row = read_row(sim, gains, names, size)
                row["lag"] = float(d.qpos[drive] - values[k, 0])
                for name, value in row.items():
                    out[name][rows[i]] = value
            if d.warning.number.any():  # MuJoCo blew up (mjWARN_BADQACC, ...): rows not trusted
                for column in out.values():
                    column[rows] = np.nan
    return out


def solve_loop_sim(mechanism: LoopMechanism, *, seed: int = 0, steps_per_degree: int = STEPS_PER_DEGREE,
                   xml: str | None = None) -> LoopTable:
    """Every drive position of ``mechanism`` simulated by MuJoCo (module docstring).

    Parameters
    ----------
    mechanism : LoopMechanism
        A one-degree-of-freedom table driven at one of joints 1 .. n-1.
    seed : int
        Seed of the rigid judge's start search (used only when no joint gives a start value).
    steps_per_degree : int
        Steps per degree of the drive's fastest phase.
    xml : str, optional
        The simulation MJCF to compile instead of :func:`~.sim_mjcf.loop_sim_mjcf`'s (same names: e.g. one
        with a deliberate fault).

    Returns
    -------
    LoopTable
        The rigid judge's columns (:func:`~.engine.column_names`); ``iterations`` the rigid start's,
        ``residual`` the weld's gap over the table's length, ``dynamics_residual`` NaN; ``meta`` the time
        step, steps per degree, run-in, servo gains, the largest drive lag and, with a solved load,
        ``L_ref``.
    """
    n_joints = len(mechanism.joints)
    if mechanism.drive.joint == n_joints - 1:
        raise ValueError(f"drive.joint: the simulated judge drives one of joints 1..{n_joints - 1}, got "
                         f"{n_joints} (the cut's joint, which carries the ground half)")
    if isinstance(steps_per_degree, bool) or not isinstance(steps_per_degree, int) or steps_per_degree < 1:
        raise ValueError(f"steps_per_degree: expected a positive integer, got {steps_per_degree!r}")
    check_mobility(mechanism)
    sv = survey(mechanism, seed)
    n = mechanism.drive.positions.shape[0]
    s, runs, runin = plan(mechanism, sv, steps_per_degree)
    meta: dict = {"mujoco": mujoco.__version__, "timestep": s.timestep, "steps_per_degree": steps_per_degree,
                  "runin_steps": runin, "servo_kp": s.servo_kp, "servo_kv": s.servo_kv}
    loads = np.array([load.value or 0.0 for load in mechanism.loads])
    starts = run_starts(mechanism, sv, s, runs, runin)
    raw = simulate(mechanism, starts, s, runs, runin, loads, xml)
    dead = sv.status == Status.DEAD_CENTRE.value
    if any(load.value is None for load in mechanism.loads):
        meta["L_ref"] = load_scale(mechanism)
        loads[[load.value is None for load in mechanism.loads]] = meta["L_ref"]
        _combine(mechanism, raw, simulate(mechanism, starts, s, runs, runin, loads, xml))
        dead |= sv.assembled & (np.abs(sv.transmission) < SIM_DEAD_CENTRE_TRANSMISSION.value)
    columns, status = _finish(mechanism, sv, raw, dead)
    meta["max_lag"] = float(np.nanmax(np.abs(raw["lag"]))) if np.isfinite(raw["lag"]).any() else math.nan
    return LoopTable(ENGINE, mechanism.name, columns, status, sv.iterations, raw["residual"],
                     np.full(n, np.nan), meta)


def _combine(mechanism: LoopMechanism, raw: dict[str, np.ndarray], loaded: dict[str, np.ndarray]) -> None:
    """Efforts and wrenches of ``raw`` (the solved load at 0) and ``loaded`` (at ``L_ref``) combined per row
    for the given drive effort (module docstring, "A solved load"), into ``raw``."""
    drive = f"effort_{mechanism.drive.coordinate}{mechanism.drive.joint + 1}"
    with np.errstate(divide="ignore", invalid="ignore"):
        w = (mechanism.drive.effort - raw[drive]) / (loaded[drive] - raw[drive])
    for c in raw:
        if c.startswith(("effort_", "joint")):
            raw[c] = raw[c] + w * (loaded[c] - raw[c])


def _finish(mechanism: LoopMechanism, sv: Survey, raw: dict[str, np.ndarray],
            dead: np.ndarray) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """The table's columns and status words: the survey's where not simulated, ``dead_centre`` at ``dead``
    (efforts and wrenches NaN), ``not_converged`` where an assembled row has no simulated value,
    ``not_finite`` where a given value is not finite (:func:`~dualmech.core.status.settle`)."""
    names = column_names(mechanism)
    columns = {c: raw[c].copy() for c in names}
    status = sv.status.copy()
    status[dead] = Status.DEAD_CENTRE.value
    status[sv.assembled & ~np.isfinite(raw["residual"])] = Status.NOT_CONVERGED.value
    dynamic = tuple(c for c in names if c.startswith(("effort_", "joint")))
    kinematic = [c for c in names if c not in dynamic]
    status = settle(columns, status, dynamic, pose=tuple(c for c in kinematic if "_" not in c),
                    rates=tuple(c for c in kinematic if "_" in c))
    return columns, status


__all__ = ["ENGINE", "SimModel", "compile_sim", "read_row", "reference", "run_start", "run_starts",
           "simulate", "solve_loop_sim"]
