"""Judge 2, simulation path (``--engine mujoco-sim``): what a user sees in a MuJoCo run.

MuJoCo integrates the MJCF of :mod:`dualmech.models.mjcf` forward in time
(``mj_step``, integrator ``implicitfast``) with the loop held by its *soft*
connect.  The crank coordinates follow the prescribed motion through the two
stiff PD servos of the model (``ctrl = q_ref + (kv/kp) q̇_ref``), the slider
load is the ``slider_load`` motor, gravity is the model's.  At each tabulated
crank angle the state is read after ``mj_forward``: ``S4``/``S4_dot`` from
``qpos``/``qvel``, joint 3 from the connect's ``efc_force``, joints 1, 2 and 4
from ``cfrc_int`` after ``mj_rnePostConstraint`` (mapped as in
:func:`dualmech.validation.judges.mujoco_slider_crank.engine.joint_wrenches`), ``residual`` = the
connect's gap / a2.  ``theta1_deg`` is the tabulated angle, ``S1`` the
simulated one.

**Accelerations.** With ``implicitfast`` ``mj_forward`` leaves the *explicit*
acceleration in ``qacc``; the step integrates
:math:`a = (M + \\Delta t\\,K)^{-1} M\\,\\mathrm{qacc}` (``K`` = the servos'
velocity gains), i.e. the servos act with :math:`f - \\Delta t\\,K a`.  Reading
``qacc`` as is biases the drive torque by :math:`\\Delta t\\,k_v\\ddot\\theta_1`
(the stiff servo's damping times the crank acceleration, ~10 % of the
torque in a random case); so ``a`` is written back into ``qacc`` before
``mj_rnePostConstraint`` and is the ``S4_ddot`` column.  The connect force is
not changed by the implicit step.

**Time step, servos and softness** (constants in :mod:`dualmech.models.mjcf`
and here; measured in the tests):

* ``dt`` = one degree of the fastest prescribed phase (crank angle, axial cycle, or the time in which
  a crank acceleration changes the speed by ``ACCEL_SPEED_FRACTION``, 1/64) over ``STEPS_PER_DEGREE``
  (128; a case may set its own, ``[simulation] steps_per_degree``), at most ``MAX_TIMESTEP`` (1e-4 s):
  2.6e-5 s for the bundled cases at 50 rpm.  Rows fall on the step grid.  The SIM_* tolerances
  are the same at any step: a coarser one is judged by them, not excused.
* Servo stiffness ``kp = I_low ω_n²``, :math:`\\omega_n = 0.5/dt`, with ``I_low``
  the crank's own inertia about its axis (its mass for the axial servo), a lower
  bound of what the servo sees: the explicit stiffness stays stable in every
  configuration, and the tracking lag ``τ/kp`` shrinks like ``dt²``.  Servo
  damping ``kv = 2 sqrt(kp I_high)`` with ``I_high`` = 1.5 x the largest
  effective inertia along the case (:func:`survey`): critically damped or more
  everywhere; ``implicitfast`` treats it implicitly.  Each run starts
  ``SIM_RUNIN_TIME_CONSTANTS`` time constants ``kv/kp`` (at least
  ``SIM_RUNIN_STEPS``) before its first row.
* Connect ``solref = (2 dt, 2)``, ``solimp`` dmin = dmax = 0.9999.  MuJoCo's
  constraint acceleration omits :math:`\\dot J\\dot q`, so the loop settles
  open by :math:`r \\approx |\\dot J\\dot q|/k`, :math:`k = 1/(d\\,t_c\\,\\zeta)^2`:
  MuJoCo's default ``solref`` (0.02 s, 1) leaves ~1e-3 of a2 here, this one
  ~1e-7.  In steady state the constraint force is the rigid one whatever the
  softness.  Damping ratio 2, not 1: ``implicitfast`` applies the servos'
  implicit damping after the constraint solve, and with a critically damped
  connect some configurations of random cases grew an oscillation (spectral
  radius of the step map up to 1.03); ratio 2 removed it in every case tried.
* Semi-implicit Euler lags velocities by :math:`\\tfrac12 dt\\,\\ddot q`
  (measured: ``S4_dot`` error = -dt/2 ``S4_ddot`` to 0.5 %).

So ``S4`` and the stroke converge like ``dt²``, ``S4_dot``, ``S4_ddot`` and the
reactions like ``dt``; the ``SIM_*`` tolerances of
:mod:`dualmech.validation.tolerances` hold at the default ``dt``.

**Runs.** With a constant crank speed (``crank_accel = 0``, speed != 0) every
row lies on one trajectory :math:`\\theta = \\theta_a + \\omega t`: one
continuous simulation passes all rows (one revolution for the bundled cases)
after the run-in from a rigidly assembled state (the rigid path's own Newton
from a crude guess, never the in-house answer).  Rows where the mechanism does
not assemble are ``no_assembly`` and the other rows are then simulated one by
one.  Otherwise the rows are snapshots of different trajectories (``theta1_dot`` equal at every row while
``theta1_ddot != 0``): each row gets its own run-in along the trajectory
through its snapshot.

**Drive-torque mode.** A forward simulation takes the slider load as an input,
and in torque mode it is the unknown, unbounded at a dead centre.  The
simulation therefore always runs in slider-load mode, twice: ``L = 0`` and
``L = L_ref``.  At a given crank state every reaction is affine in ``L``, so
the reactions for the given torque ``T`` are
:math:`X = X_0 + w (X_\\mathrm{ref} - X_0)`, with
:math:`w = (T - \\tau_0)/(\\tau_\\mathrm{ref} - \\tau_0)` from the simulated
drive torques (the slider load is then ``w L_ref``: what MuJoCo needs to hold
the prescribed motion against ``T``).  The kinematic columns are those of the
``L = 0`` run: in the rigid model they do not depend on the load, while the
loaded simulation would deflect under a load that grows like ``1/t`` near the
dead centres, which is where the stroke's extremes lie (``t = 0`` is
``dS4/dtheta1 = 0``).  Reaction errors grow like ``1/t²`` there (the comparison scales by ``1/|t|``): rows
with ``|transmission| < SIM_DEAD_CENTRE_TRANSMISSION`` are flagged ``dead_centre`` (reactions NaN,
kinematics given).  The plan of a simulation (rows, time grid, servo settings) is
:mod:`~dualmech.validation.judges.mujoco_slider_crank.sim_plan`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterator

import mujoco
import numpy as np
from mujoco import rollout

from dualmech.core.assembly import edge_status
from dualmech.core.status import Status, flag_joint_lock, settle
from dualmech.core.table import NUMERIC_COLUMNS, REACTION_COLUMNS, ResultTable
from dualmech.models.case import Case
from dualmech.models.mjcf import MjcfSettings, case_to_mjcf, simulation_steps
from dualmech.validation.judges.mujoco_slider_crank import closure as mujoco_closure
from dualmech.validation.judges.mujoco_slider_crank import dynamics as mujoco_dynamics
from dualmech.validation.judges.mujoco_slider_crank import engine as rigid
from dualmech.validation.judges.mujoco_slider_crank.sim_plan import (
    Survey,
    checked_settings,
    prepare,
    runin_steps,
    schedule,
    survey,
)
from dualmech.validation.tolerances import (
    ASSEMBLY_LIMIT_CONDITION,
    ASSEMBLY_REACH,
    SIM_DEAD_CENTRE_TRANSMISSION,
)

ENGINE = "mujoco-sim"


def reference(case: Case, anchor: int, times: np.ndarray) -> tuple[np.ndarray, ...]:
    """Prescribed ``theta, theta_dot, S1, S1_dot`` at ``times`` (s, 0 at row ``anchor``), shape (k,) each.

    The trajectory through the anchor's snapshot: constant crank acceleration,
    ``S1`` from thesis eq. (27)-(28) (``core/motion.py``).
    """
    mo, g = case.motion, case.geometry
    theta0 = math.radians(float(mo.angles_deg[anchor]))
    theta = theta0 + mo.speed * times + 0.5 * mo.accel * times**2
    theta_dot = mo.speed + mo.accel * times
    phase = mo.axial_cycles * theta
    s = g.crank_axial_shift + mo.axial_amplitude * np.sin(phase)
    s_dot = mo.axial_amplitude * mo.axial_cycles * np.cos(phase) * theta_dot
    return theta, theta_dot, s, s_dot


def velocity_gains(model: mujoco.MjModel) -> np.ndarray:
    """``K = -d(qfrc_actuator)/d(qvel)``, shape (nv, nv): what ``implicitfast`` treats implicitly here.

    Only the affine-bias servos depend on velocity (the model has no joint damping).
    """
    k = np.zeros((model.nv, model.nv))
    for a in range(model.nu):
        if model.actuator_biastype[a] == mujoco.mjtBias.mjBIAS_AFFINE:
            dof = model.jnt_dofadr[model.actuator_trnid[a, 0]]
            k[dof, dof] -= model.actuator_biasprm[a, 2] * model.actuator_gear[a, 0] ** 2
    return k


def read_state(lp: rigid.MjLoop, gains: np.ndarray) -> dict[str, float]:
    """Columns of the current simulated state; call after ``mj_forward`` (overwrites ``qacc``)."""
    m, d = lp.model, lp.data
    mass = np.empty((m.nv, m.nv))
    mujoco.mj_fullM(m, d, mass)
    d.qacc[:] = np.linalg.solve(mass + m.opt.timestep * gains, mass @ d.qacc)  # the integrated acceleration
    mujoco.mj_rnePostConstraint(m, d)
    values = mujoco_dynamics.joint_wrenches(lp)
    values.update(
        S1=float(d.qpos[lp.qadr[1]] if lp.qadr[1] >= 0 else d.xpos[lp.crank][2]),  # revolute: the crank's S1
        S4=float(d.qpos[lp.qadr[3]]),
        S4_dot=float(d.qvel[lp.vadr[3]]), S4_ddot=float(d.qacc[lp.vadr[3]]),
        transmission=mujoco_dynamics.transmission(lp), closure_condition=mujoco_closure.condition(lp),
        residual=float(np.linalg.norm(d.site_xpos[lp.site1] - d.site_xpos[lp.site2])) / lp.a2,
        theta=float(d.qpos[lp.qadr[0]]),
    )
    return values


def simulate(case: Case, slider_load: float, settings: MjcfSettings, rows: np.ndarray | None = None,
             steps_per_degree: int | None = None) -> dict[str, np.ndarray]:
    """Simulate the rows of ``case`` (mask ``rows``, default all) with a constant slider load.

    ``settings.timestep`` must be the schedule's (:func:`schedule` with the same
    ``rows`` and ``steps_per_degree``).  Returns raw columns, shape (n,) each: the
    numeric columns but ``theta1_deg``, plus ``theta_lag`` (simulated minus
    prescribed crank angle, rad).  Rows not simulated, of a run that cannot be
    assembled at its start, or of a run in which MuJoCo warns (it blew up:
    ``mjWARN_BADQACC``, ...), are NaN (``not_converged`` in :func:`solve_case`).
    """
    plan = schedule(case, steps_per_degree, rows, runin_steps(settings))
    if settings.timestep != plan.timestep:
        raise ValueError(f"settings.timestep: expected the schedule's {plan.timestep!r} s, got "
                         f"{settings.timestep!r}")
    lp = rigid.build(case, case_to_mjcf(case, settings))
    m, d = lp.model, lp.data
    skip_collisions(m)
    skip_islands(m)
    servos = lp.crank_dofs.size  # the crank-angle (and crank-axial) servos come first
    kp = m.actuator_gainprm[:servos, 0].copy()
    kv = -m.actuator_biasprm[:servos, 2].copy()
    gains = velocity_gains(m)
    n = case.motion.angles_deg.shape[0]
    out = {k: np.full(n, np.nan) for k in (*(c for c in NUMERIC_COLUMNS if c != "theta1_deg"), "theta_lag")}
    with rollout.Rollout(nthread=0) as roller:
        for (run_rows, steps), anchor in zip(plan.runs, plan.anchors):
            times = (np.arange(int(steps[-1]) + 1) - plan.runin) * plan.timestep
            theta, theta_dot, s, s_dot = reference(case, anchor, times)
            mujoco.mj_resetData(m, d)
            status, _, _, _ = rigid.assembled_state(lp, (theta[0], s[0], theta_dot[0], s_dot[0]), warm=False)
            if status != Status.OK:
                continue
            ctrl = np.stack([theta + kv[0] / kp[0] * theta_dot, s + kv[-1] / kp[-1] * s_dot,
                             np.full(times.shape, slider_load)], -1)[:, [*range(servos), 2]]
            for i, k in enumerate(stepped(m, d, ctrl, steps, roller)):
                mujoco.mj_forward(m, d)
                values = read_state(lp, gains)
                values["theta_lag"] = values.pop("theta") - theta[k]
                for name, value in values.items():
                    out[name][run_rows[i]] = value
            if d.warning.number.any():  # MuJoCo blew up (mjWARN_BADQACC, ...): rows not trusted
                for name in out:
                    out[name][run_rows] = np.nan
    return out


def stepped(model: mujoco.MjModel, data: mujoco.MjData, ctrl: np.ndarray, reads: np.ndarray,
            roller: rollout.Rollout) -> Iterator[int]:
    """Step ``data`` under ``ctrl`` (shape (k, nu): step ``i`` runs with ``ctrl[i]``), pausing at ``reads``.

    Yields each step of ``reads`` (increasing, < k) with ``data`` as it is before that step, its
    control set: the caller reads the state there (``mj_forward`` and what follows it; nothing they
    write enters a step).  The steps in between run in MuJoCo's ``rollout`` (C, no Python a step), each
    stretch from the full physics state and the constraint solver's warm start (``qacc_warmstart``)
    that ``data`` holds: the same steps as ``mj_step`` in a Python loop, bit for bit.  Ends after the
    last step, or early after a stretch in which MuJoCo warned (``rollout`` then stops stepping; the
    warnings stay in ``data.warning``, which each stretch clears first).
    """
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.empty((1, mujoco.mj_stateSize(model, spec)))
    warm = np.empty((1, model.nv))
    done = 0
    for k in (*reads.tolist(), ctrl.shape[0]):
        if k > done:
            mujoco.mj_getState(model, data, state[0], spec)
            warm[0] = data.qacc_warmstart
            roller.rollout([model], [data], state, ctrl[None, done:k], skip_checks=True, nstep=k - done,
                           initial_warmstart=warm)
            if data.warning.number.any():
                return
        done = k
        if k < ctrl.shape[0]:
            data.ctrl[:] = ctrl[k]
            yield k


def skip_collisions(model: mujoco.MjModel) -> None:
    """Switch collision detection off when no two geoms can collide (the same simulation, each step cheaper).

    The model's geoms are drawings only (``contype = conaffinity = 0``, no explicit contact pair):
    MuJoCo would test them for contacts at every step and find none.
    """
    no_pairs = model.npair == 0 and model.nflex == 0
    if no_pairs and (not model.geom_contype.any() or not model.geom_conaffinity.any()):
        model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT


def skip_islands(model: mujoco.MjModel) -> None:
    """Switch island discovery off when the model can hold one constraint at most (the same simulation, each
    step ~11 % cheaper).

    MuJoCo groups the constraint rows into independent islands at every step and solves them one by one;
    a model without contacts (:func:`skip_collisions` first), joint limits, friction loss, tendons or flexes
    and with one equality constraint (the loop's connect) has a single island whatever the pose.
    """
    contacts = not model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_CONTACT
    if (model.neq <= 1 and not contacts and not model.jnt_limited.any() and not model.dof_frictionloss.any()
            and model.ntendon == 0 and model.nflex == 0):
        model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_ISLAND


def load_scale(case: Case) -> float:
    """``L_ref`` of the torque-mode combination: the pin force of the drive torque, else an inertial force."""
    torque = case.loads.drive_torque
    if torque:
        return abs(torque) / case.geometry.crank_length
    b, mo = case.bodies, case.motion
    mass = b.crank.mass + b.rod.mass + b.slider.mass
    gravity = float(np.linalg.norm(case.loads.gravity))
    scale = mass * (case.geometry.crank_length * (mo.speed**2 + abs(mo.accel)) + gravity)
    return scale if scale > 0 else 1.0


def solve_case(case: Case, steps_per_degree: int | None = None) -> ResultTable:
    """Simulate ``case`` in MuJoCo (method, error budget and torque-mode handling: module docstring).

    Returns
    -------
    ResultTable
        Engine ``"mujoco-sim"``; ``meta`` holds the time step, steps per degree,
        the largest crank tracking lag (rad) and, in torque mode, ``L_ref``.
    """
    steps_per_degree = simulation_steps(case, steps_per_degree)
    n = case.motion.angles_deg.shape[0]
    sv = survey(case)
    reachable = sv.simulated
    try:
        settings = checked_settings(case, steps_per_degree, sv)
    except OverflowError:  # the step that resolves the motion needs servo gains beyond the double range
        return _overflowed(case, sv)
    meta: dict = {
        "mujoco": mujoco.__version__,
        "timestep": settings.timestep,
        "steps_per_degree": steps_per_degree,
        "runin_steps": runin_steps(settings),
        "servo_kp": settings.servo_kp,
        "servo_kv": settings.servo_kv,
    }
    if case.loads.mode == "force":
        raw = simulate(case, float(case.loads.slider_force), settings, reachable, steps_per_degree)
        dead = np.zeros(n, dtype=bool)
    else:
        l_ref = load_scale(case)
        zero = simulate(case, 0.0, settings, reachable, steps_per_degree)
        loaded = simulate(case, l_ref, settings, reachable, steps_per_degree)
        w = _load_weight(case, zero, loaded)
        raw = dict(zero)
        for c in REACTION_COLUMNS:
            raw[c] = zero[c] + w * (loaded[c] - zero[c])
        dead = np.abs(zero["transmission"]) < SIM_DEAD_CENTRE_TRANSMISSION.value
        meta["L_ref"] = l_ref
    cols = {c: raw[c] for c in NUMERIC_COLUMNS if c != "theta1_deg"}
    cols["theta1_deg"] = case.motion.angles_deg.astype(float).copy()
    status = np.where(dead, Status.DEAD_CENTRE.value, Status.OK.value).astype(object)
    status[~np.isfinite(cols["S4"])] = Status.NOT_CONVERGED.value
    status = flag_joint_lock(_edges(status, cols, sv), cols["closure_condition"], case.joints.universal)
    cols["S1"] = np.where(reachable, cols["S1"], case.own_crank_states().s)
    status = settle(cols, status, REACTION_COLUMNS)
    lag = raw["theta_lag"]
    meta["max_theta_lag"] = float(np.nanmax(np.abs(lag))) if np.isfinite(lag).any() else math.nan
    meta["messages"] = rigid.status_messages(cols["theta1_deg"], status)
    return ResultTable(ENGINE, case.name, cols, status, meta)


def _edges(status: np.ndarray, cols: dict[str, np.ndarray], sv: Survey) -> np.ndarray:
    """Status words with the edges of assembly: simulated rows by their own ``|u·k4|``, the others by the
    survey.

    Rows the survey put at the ``assembly_limit`` or beyond reach are not simulated: their
    words, ``S4`` and condition are the survey's (the rigid path's pose).  ``cols`` is updated in place.
    """
    closed = sv.simulated & np.isfinite(cols["closure_condition"])
    with np.errstate(invalid="ignore"):
        rho = np.sqrt(1.0 - np.minimum(cols["closure_condition"], 1.0) ** 2)
    status, condition = edge_status(status, closed, np.where(closed, rho, 0.0), cols["closure_condition"],
                                    ASSEMBLY_REACH.value, ASSEMBLY_LIMIT_CONDITION.value)
    skipped = ~sv.simulated
    status[skipped] = sv.status[skipped]
    cols["closure_condition"] = np.where(skipped, sv.condition, np.where(closed, condition, np.nan))
    cols["S4"] = np.where(skipped, sv.s4, cols["S4"])
    return status


def _load_weight(case: Case, zero: dict[str, np.ndarray], loaded: dict[str, np.ndarray]) -> np.ndarray:
    """Per row, ``w`` with zero + w (loaded - zero) = the case's drive torque (case units).

    ``zero`` and ``loaded`` are :func:`simulate` runs at slider load 0 and ``L_ref``;
    rows where the load does not move the drive torque give inf or NaN.  Shape (n,).
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        w = (case.loads.drive_torque - zero["drive_torque"]) / (loaded["drive_torque"] - zero["drive_torque"])
    return w


def _overflowed(case: Case, sv: Survey) -> ResultTable:
    """The table of a case whose simulation cannot be set up in double precision: every assembling row
    ``not_finite``."""
    n = sv.status.shape[0]
    cols = {c: np.full(n, np.nan) for c in NUMERIC_COLUMNS}
    cols["theta1_deg"] = case.motion.angles_deg.astype(float).copy()
    cols["S1"] = case.own_crank_states().s
    status = _edges(np.full(n, Status.NOT_FINITE.value, dtype=object), cols, sv)
    status = settle(cols, status, REACTION_COLUMNS)
    messages = rigid.status_messages(cols["theta1_deg"], status)
    return ResultTable(ENGINE, case.name, cols, status, {"mujoco": mujoco.__version__, "messages": messages})


def benchmark(case: Case, repeats: int = 1, steps_per_degree: int | None = None) -> dict:
    """Per-position cost of :func:`solve_case` (best of ``repeats``), and per simulated step.

    Returns
    -------
    dict
        ``engine``, ``positions``, ``steps`` (simulated, all runs), ``timestep``,
        ``seconds``, ``us_per_position``, ``us_per_step``.
    """
    if isinstance(repeats, bool) or int(repeats) != repeats or repeats < 1:
        raise ValueError(f"repeats: expected a positive integer, got {repeats!r}")
    steps_per_degree = simulation_steps(case, steps_per_degree)
    reachable, settings = prepare(case, steps_per_degree)
    plan = schedule(case, steps_per_degree, reachable, runin_steps(settings))
    steps = plan.steps * (1 if case.loads.mode == "force" else 2)
    best = math.inf
    for _ in range(int(repeats)):
        t0 = time.perf_counter()
        table = solve_case(case, steps_per_degree)
        best = min(best, time.perf_counter() - t0)
    n = len(table)
    return {"engine": ENGINE, "positions": n, "steps": steps, "timestep": plan.timestep, "seconds": best,
            "us_per_position": 1e6 * best / n, "us_per_step": 1e6 * best / steps}
