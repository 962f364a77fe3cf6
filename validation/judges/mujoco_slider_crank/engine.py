"""Judge 2, rigid path (``--engine mujoco``): MuJoCo as the dynamics engine, the loop held rigid.

MuJoCo's own forward dynamics closes the loop with a *soft* equality
constraint, and ``mj_inverse`` at an exactly consistent state puts the whole
load into ``qfrc_inverse`` (the passive ball joint included) with a soft
constraint force of about zero.  Neither gives rigid loop reactions, so this
path uses MuJoCo's kinematics and dynamics routines and writes the rigid
equations around them; the model is the MJCF of :mod:`dualmech.models.mjcf`
(coordinates ``q = [theta1, S1, quat_rod, S4]``, ``v = [theta1_dot, S1_dot,
omega_rod (rod frame), S4_dot]``).  Per crank position:

1. **Closure.** ``theta1, S1`` are set from the prescribed motion; the rod
   quaternion and ``S4`` are found by Newton on the site gap
   :math:`r(q) = x_\\mathrm{slider\\_pin} - x_\\mathrm{rod\\_end}` (3 equations, 4
   unknowns: the minimum-norm step of ``mj_jacSite``'s Jacobian
   :math:`J_c = J_\\mathrm{slider\\_pin} - J_\\mathrm{rod\\_end}`, applied with
   ``mj_integratePos``).  The first position starts from a crude guess (the
   slider one rod length beyond the foot of the perpendicular from the crank
   pin, the rod pointing at it); later ones continue from the previous
   position.  Nothing in-house is used (independence).
2. **Velocity, acceleration.** With the crank rates prescribed,

   .. math::
       J_c \\dot q = 0, \\quad u^T J_\\omega \\dot q = 0, \\qquad
       J_c \\ddot q = -\\dot J_c \\dot q, \\quad
       u^T J_\\omega \\ddot q = -u^T \\dot J_\\omega \\dot q,

   where the second equation of each pair is the zero-spin gauge of the rod
   (``docs/conventions.md``, "Rod spin"), :math:`J_\\omega` its rotational
   Jacobian (``mj_jacBody``) and the drift terms come from ``mj_jacDot``.
3. **Efforts.** ``mj_rne`` gives :math:`M\\ddot q + c` (gravity included); the
   equations :math:`M\\ddot q + c = \\tau + J_c^T \\lambda` (6 rows, the
   ball-joint rows with :math:`\\tau = 0`, one of them the rod-spin identity
   ``0 = 0``) are solved by least squares for the connect force
   :math:`\\lambda` (force of the rod on the slider, world axes: ``efc_force``'s
   convention for a connect), the crank axial force and the unknown one of
   drive torque / slider load.
4. **Joint wrenches.** :math:`\\lambda` is written into ``efc_force`` and
   :math:`\\ddot q` into ``qacc``, then ``mj_rnePostConstraint`` fills
   ``cfrc_int``: per body, [torque; force] exerted by its parent, world axes,
   about ``subtree_com`` of the body's root (the ``ground`` body, i.e. the
   whole mechanism's centre of mass).  Moments are moved to the reference
   points of the conventions (joint 1 about O, joint 4 about P3).

Generalized forces on the joints: hinge ``crank_angle`` (axis +z) carries the
drive torque; slide ``slider_stroke`` (axis ``-k4``) carries ``-slider_load``.

Step 1 is :mod:`~dualmech.validation.judges.mujoco_slider_crank.closure`, steps 2-4
:mod:`~dualmech.validation.judges.mujoco_slider_crank.dynamics`;
this module runs them position by position and writes the table.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import mujoco
import numpy as np

from dualmech.core.assembly import edge_status, foot_s4
from dualmech.core.status import Status, flag_joint_lock, settle
from dualmech.core.table import NUMERIC_COLUMNS, REACTION_COLUMNS, ResultTable
from dualmech.models.case import Case
from dualmech.validation.judges.mujoco_slider_crank.closure import (
    MjLoop,
    build,
    close_loop,
    condition,
    crank_pin,
    crude_guess,
    on_branch,
    reach,
    set_crank,
    slider_line,
)
from dualmech.validation.judges.mujoco_slider_crank.dynamics import (
    drift,
    efforts,
    rate_rows,
    solve_rates,
    transmission,
    wrenches,
)
from dualmech.validation.tolerances import (
    ASSEMBLY_LIMIT_CONDITION,
    ASSEMBLY_REACH,
    DEAD_CENTRE_TRANSMISSION,
)

ENGINE = "mujoco"


@dataclass(frozen=True)
class Position:
    """What the rigid path finds at one crank position."""

    status: str
    iterations: int
    values: dict[str, float]


def assembled_state(lp: MjLoop, crank: tuple[float, ...], warm: bool) -> tuple[str, int, float, float]:
    """Close the loop and set ``qvel`` for crank state ``(theta, s, theta_dot, s_dot)``.

    ``warm``: start Newton from the current ``qpos`` (continuation) instead of the crude guess.
    Returns ``(status, iterations, gap, closure condition)``; status is ``ok``,
    ``assembly_limit``, ``no_assembly``, ``not_converged`` or ``branch_jump``, with the edges of
    assembly of :func:`dualmech.core.assembly.edge_status` (the condition ``|u·k4|`` of
    MuJoCo's own pose; an ``assembly_limit`` row whose Newton failed is put at the limit pose).
    """
    theta, s, theta_dot, s_dot = crank
    set_crank(lp, theta, s)
    mujoco.mj_kinematics(lp.model, lp.data)
    rho = 1.0 + reach(lp) / lp.a2
    if rho > 1.0 + ASSEMBLY_REACH.value:
        return Status.NO_ASSEMBLY.value, 0, math.nan, math.nan
    if not warm:
        crude_guess(lp)
    ok, iters, gap = close_loop(lp)
    if warm and not (ok and on_branch(lp)):  # continuation lost or jumped: once more from the crude guess
        crude_guess(lp)
        ok, more, gap = close_loop(lp)
        iters += more
    closed = ok and on_branch(lp)
    raw = Status.OK if closed else Status.NOT_CONVERGED if not ok else Status.BRANCH_JUMP
    words, conditions = edge_status(np.array([raw.value], dtype=object), np.array([closed]), np.array([rho]),
                                   np.array([condition(lp)]),
                                   ASSEMBLY_REACH.value, ASSEMBLY_LIMIT_CONDITION.value)
    status, c = str(words[0]), float(conditions[0])
    if status == Status.ASSEMBLY_LIMIT and not closed:  # the limit pose: the foot of the perpendicular
        foot, axis = slider_line(lp)
        lp.data.qpos[lp.qadr[3]] = float(foot_s4(crank_pin(lp), foot, -axis)[0])
        mujoco.mj_kinematics(lp.model, lp.data)
    if status != Status.OK:
        return status, iters, gap, c
    mujoco.mj_fwdPosition(lp.model, lp.data)  # efc rows of the connect, cinert, ...
    rows, _ = rate_rows(lp)
    known = np.array([theta_dot, s_dot][:lp.crank_dofs.size])
    lp.data.qvel[:] = solve_rates(lp, rows, known, np.zeros(rows.shape[0]))
    mujoco.mj_fwdVelocity(lp.model, lp.data)  # cvel, cdof_dot for jacDot and RNE
    return status, iters, gap, c


def solve_position(lp: MjLoop, crank: tuple[float, ...], mode: str, given: float, warm: bool) -> Position:
    """All columns at one crank state ``(theta, s, theta_dot, s_dot, theta_ddot, s_ddot)``."""
    theta, s = crank[0], crank[1]
    values = {c: math.nan for c in NUMERIC_COLUMNS}
    values["theta1_deg"] = math.degrees(theta)
    values["S1"] = s
    status, iters, gap, condition = assembled_state(lp, crank[:4], warm)
    values["closure_condition"] = condition
    if status == Status.ASSEMBLY_LIMIT:
        values.update(S4=float(lp.data.qpos[lp.qadr[3]]), residual=gap)
    if status != Status.OK:
        return Position(status, iters, values)
    d = lp.data
    rows, _ = rate_rows(lp)
    qacc = solve_rates(lp, rows, np.array(crank[4:4 + lp.crank_dofs.size]), -drift(lp))
    d.qacc[:] = qacc
    t = transmission(lp)
    values.update(
        S4=float(d.qpos[lp.qadr[3]]), S4_dot=float(d.qvel[lp.vadr[3]]),
        S4_ddot=float(qacc[lp.vadr[3]]), transmission=t, residual=gap,
    )
    if mode == "torque" and abs(t) < DEAD_CENTRE_TRANSMISSION.value:
        return Position(Status.DEAD_CENTRE.value, iters, values)
    values.update(wrenches(lp, efforts(lp, mode, given)))
    return Position(Status.OK.value, iters, values)


def _given(case: Case) -> tuple[str, float]:
    ld = case.loads
    return ld.mode, float(ld.drive_torque if ld.mode == "torque" else ld.slider_force)


def solve_case(case: Case) -> ResultTable:
    """Solve every crank position of ``case`` with MuJoCo, the loop held rigid (see module docstring).

    Returns
    -------
    ResultTable
        Engine ``"mujoco"``; columns and statuses of ``docs/conventions.md``.
        ``meta`` holds the MuJoCo version, Newton iterations per position and
        the largest least-squares residual of the effort equations.
    """
    lp = build(case)
    state = case.own_crank_states()
    mode, given = _given(case)
    n = len(state)
    cols = {c: np.full(n, np.nan) for c in NUMERIC_COLUMNS}
    status = np.empty(n, dtype=object)
    iters = np.zeros(n, dtype=int)
    fields = (state.theta, state.s, state.theta_dot, state.s_dot, state.theta_ddot, state.s_ddot)
    warm = False
    for i in range(n):
        pos = solve_position(lp, tuple(float(f[i]) for f in fields), mode, given, warm)
        for name, value in pos.values.items():
            cols[name][i] = value
        status[i] = pos.status
        iters[i] = pos.iterations
        warm = pos.status in (Status.OK, Status.DEAD_CENTRE)
    status = settle(cols, flag_joint_lock(status, cols["closure_condition"], case.joints.universal),
                    REACTION_COLUMNS)
    meta = {"mujoco": mujoco.__version__, "newton_iterations": iters,
            "messages": status_messages(cols["theta1_deg"], status)}
    return ResultTable(ENGINE, case.name, cols, status, meta)


def assembled_qpos(case: Case, row: int = 0) -> np.ndarray:
    """``qpos`` (7,) of the MJCF with the loop closed at crank position ``row`` (crude guess + Newton).

    For :func:`dualmech.models.mjcf.case_to_mjcf`'s ``keyframe``.  Raises
    ``ValueError`` if the mechanism does not assemble there.
    """
    lp = build(case)
    st = case.own_crank_states()
    if not 0 <= row < len(st):
        raise ValueError(f"row: expected 0 <= row < {len(st)}, got {row!r}")
    status, _, _, _ = assembled_state(lp, (float(st.theta[row]), float(st.s[row]), 0.0, 0.0), warm=False)
    if status != Status.OK:
        raise ValueError(f"case: the loop does not close at theta1 = {st.theta[row] * 180 / math.pi:g} deg "
                         f"({status})")
    return lp.data.qpos.copy()


def status_messages(theta_deg: np.ndarray, status: np.ndarray) -> list[str]:
    """One line per status word other than ok/dead_centre, with the crank angles it covers."""
    out = []
    for word in (Status.ASSEMBLY_LIMIT, Status.NO_ASSEMBLY, Status.NOT_CONVERGED, Status.BRANCH_JUMP,
                 Status.NOT_FINITE):
        rows = np.flatnonzero(status == word)
        if rows.size:
            shown = ", ".join(f"{a:g}" for a in theta_deg[rows[:8]]) + (", ..." if rows.size > 8 else "")
            out.append(f"{word}: {rows.size} positions (crank angles {shown} deg)")
    return out


def benchmark(case: Case, repeats: int = 3) -> dict:
    """Per-position cost of :func:`solve_case`: best of ``repeats`` whole-case runs.

    Returns
    -------
    dict
        ``engine``, ``positions``, ``seconds`` (best run), ``us_per_position``,
        ``build_seconds`` (compiling the MJCF once, included in ``seconds``).
    """
    if repeats < 1:
        raise ValueError(f"repeats: expected a positive integer, got {repeats!r}")
    t0 = time.perf_counter()
    build(case)
    build_s = time.perf_counter() - t0
    best = math.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        table = solve_case(case)
        best = min(best, time.perf_counter() - t0)
    n = len(table)
    return {"engine": ENGINE, "positions": n, "seconds": best,
            "us_per_position": 1e6 * best / n, "build_seconds": build_s}
