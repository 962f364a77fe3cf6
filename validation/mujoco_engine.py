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
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import mujoco
import numpy as np

from dualmech.core.assembly import edge_status, foot_s4
from dualmech.core.status import Status, settle
from dualmech.core.table import NUMERIC_COLUMNS, REACTION_COLUMNS, ResultTable
from dualmech.models.case import Case
from dualmech.models.mjcf import MAX_TIMESTEP, case_to_mjcf, default_settings, slider_axis
from dualmech.validation.tolerances import ASSEMBLY_LIMIT_CONDITION, ASSEMBLY_REACH, DEAD_CENTRE_TRANSMISSION

ENGINE = "mujoco"

#: Newton on the site gap: stop below this gap (relative to a2) ...
_CLOSURE_TOL = 1e-15
#: ... or after this many iterations, or when the gap stops shrinking.
_MAX_ITER = 60


@dataclass
class MjLoop:
    """A compiled model of one case and the ids the solvers need (mutable scratch inside)."""

    model: mujoco.MjModel
    data: mujoco.MjData
    a1: float
    a2: float
    k4: np.ndarray  # (3,)
    rod: int  # body ids
    crank: int
    slider: int
    site_pin: int  # slider_pin (site1 of the connect)
    site_end: int  # rod_end (site2)
    qadr: np.ndarray  # qpos address of crank_angle, crank_axial, rod_ball (4), slider_stroke
    vadr: np.ndarray  # dof address of the same (rod_ball: 3 dofs)
    free: np.ndarray  # the 4 dofs Newton moves: rod_ball (3), slider_stroke


def build(case: Case, xml: str | None = None) -> MjLoop:
    """Compile the MJCF of ``case`` (or the given text) and collect the ids.

    The rigid path never steps in time, so its default model carries the settings of
    the ``MAX_TIMESTEP`` step (the time step and servo gains are read by nothing it
    calls): a case whose own simulation step would overflow (``crank_rpm = 1e308``)
    still builds, and its rows are judged ``not_finite`` one by one.
    """
    if xml is None:
        xml = case_to_mjcf(case, default_settings(case, MAX_TIMESTEP))
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    names = ("crank_angle", "crank_axial", "rod_ball", "slider_stroke")
    jid = [model.joint(n).id for n in names]
    qadr = np.array([model.jnt_qposadr[j] for j in jid])
    vadr = np.array([model.jnt_dofadr[j] for j in jid])
    free = np.array([vadr[2], vadr[2] + 1, vadr[2] + 2, vadr[3]])
    return MjLoop(
        model=model, data=data,
        a1=case.geometry.crank_length, a2=case.geometry.rod_length, k4=slider_axis(case),
        rod=model.body("rod").id, crank=model.body("crank").id, slider=model.body("slider").id,
        site_pin=model.site("slider_pin").id, site_end=model.site("rod_end").id,
        qadr=qadr, vadr=vadr, free=free,
    )


# ----------------------------------------------------------------------------- positions

def _positions(lp: MjLoop) -> None:
    """Kinematics and com-based frames for the current ``qpos`` (what ``mj_jac*`` needs)."""
    mujoco.mj_kinematics(lp.model, lp.data)
    mujoco.mj_comPos(lp.model, lp.data)


def _gap_jacobian(lp: MjLoop) -> np.ndarray:
    """:math:`J_c = J_\\mathrm{slider\\_pin} - J_\\mathrm{rod\\_end}`, shape (3, nv)."""
    jp = np.empty((3, lp.model.nv))
    je = np.empty((3, lp.model.nv))
    mujoco.mj_jacSite(lp.model, lp.data, jp, None, lp.site_pin)
    mujoco.mj_jacSite(lp.model, lp.data, je, None, lp.site_end)
    return jp - je


def _gap(lp: MjLoop) -> np.ndarray:
    d = lp.data
    return d.site_xpos[lp.site_pin] - d.site_xpos[lp.site_end]


def _slider_line(lp: MjLoop) -> tuple[np.ndarray, np.ndarray]:
    """Point F and unit direction ``-k4`` of the slider line, read from the model (world)."""
    m = lp.model
    jid = m.dof_jntid[lp.vadr[3]]
    # the slider body hangs from the fixed ground body at the world origin, world-aligned
    foot = m.body_pos[lp.slider] + m.body_pos[m.body_parentid[lp.slider]]
    return foot.copy(), m.jnt_axis[jid].copy()


def reach(lp: MjLoop) -> float:
    """Distance from the crank pin to the slider line minus ``a2`` (> 0: no assembly), current ``qpos``."""
    foot, axis = _slider_line(lp)
    d = lp.data.xpos[lp.rod] - foot
    dist2 = max(float(d @ d - (d @ axis) ** 2), 0.0)
    return math.sqrt(dist2) - lp.a2


def crude_guess(lp: MjLoop) -> None:
    """Set rod quaternion and ``S4`` to a rough pose on the dualmech branch (crank joints already set).

    The slider goes one rod length beyond the foot of the perpendicular from the crank
    pin P2 onto the slider line (along ``-k4``, the side where ``(P3 - P2)·k4 < 0``), and
    the rod points from P2 at it.  This guess is from geometry alone, never from a
    closure solution.
    """
    d, qa = lp.data, lp.qadr
    d.qpos[qa[2]:qa[2] + 4] = (1.0, 0.0, 0.0, 0.0)
    d.qpos[qa[3]] = 0.0
    mujoco.mj_kinematics(lp.model, lp.data)
    foot, axis = _slider_line(lp)
    p2 = d.xpos[lp.rod].copy()
    s4 = float((p2 - foot) @ axis) + lp.a2
    target = foot + s4 * axis
    direction = d.xmat[lp.crank].reshape(3, 3).T @ (target - p2)  # crank-frame axes
    d.qpos[qa[2]:qa[2] + 4] = _quat_x_to(direction)
    d.qpos[qa[3]] = s4


def _quat_x_to(v: np.ndarray) -> np.ndarray:
    """Unit quaternion (w, x, y, z) turning +x onto the direction of ``v`` (shortest arc)."""
    v = v / np.linalg.norm(v)
    w = 1.0 + v[0]
    if w < 1e-12:  # v = -x: half turn about z
        return np.array([0.0, 0.0, 0.0, 1.0])
    q = np.array([w, 0.0, -v[2], v[1]])
    return q / np.linalg.norm(q)


def close_loop(lp: MjLoop) -> tuple[bool, int, float]:
    """Newton on the site gap from the current ``qpos``; crank joints held.

    Returns
    -------
    converged, iterations, gap
        ``gap`` is :math:`|r|/a_2` at the returned pose.
    """
    m, d = lp.model, lp.data
    dq = np.zeros(m.nv)
    _positions(lp)
    r = _gap(lp)
    gap = float(np.linalg.norm(r)) / lp.a2
    for it in range(1, _MAX_ITER + 1):
        if gap <= _CLOSURE_TOL:
            return True, it - 1, gap
        j = _gap_jacobian(lp)[:, lp.free]
        step = -j.T @ np.linalg.solve(j @ j.T, r)  # minimum-norm step of the 3 x 4 system
        dq[:] = 0.0
        dq[lp.free] = step
        mujoco.mj_integratePos(m, d.qpos, dq, 1.0)
        _positions(lp)
        r = _gap(lp)
        new_gap = float(np.linalg.norm(r)) / lp.a2
        if new_gap >= gap and gap < 1e-12:  # at the floor of rounding: stop
            return True, it, min(gap, new_gap)
        gap = new_gap
    return gap < 1e-12, _MAX_ITER, gap


# ----------------------------------------------------------------------------- rates

def _rod_axis(lp: MjLoop) -> np.ndarray:
    """u = (P3 - P2)/|P3 - P2|, world, shape (3,)."""
    u = lp.data.site_xpos[lp.site_pin] - lp.data.xpos[lp.rod]
    return u / np.linalg.norm(u)


def condition(lp: MjLoop) -> float:
    """The closure condition ``|u·k4|`` of the current pose (:mod:`dualmech.core.assembly`)."""
    return abs(float(_rod_axis(lp) @ lp.k4))


def _rate_rows(lp: MjLoop) -> tuple[np.ndarray, np.ndarray]:
    """Rows of the closure and spin-gauge equations: (4, nv) matrix for rates, and the rod's ``J_omega``."""
    jr = np.empty((3, lp.model.nv))
    mujoco.mj_jacBody(lp.model, lp.data, None, jr, lp.rod)
    rows = np.vstack([_gap_jacobian(lp), _rod_axis(lp) @ jr])
    return rows, jr


def _solve_rates(lp: MjLoop, rows: np.ndarray, known: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Rates ``x`` (nv,) with ``x[crank dofs] = known`` and ``rows @ x = rhs``."""
    x = np.zeros(lp.model.nv)
    x[lp.vadr[:2]] = known
    x[lp.free] = np.linalg.solve(rows[:, lp.free], rhs - rows @ x)
    return x


def _drift(lp: MjLoop) -> np.ndarray:
    """:math:`[\\dot J_c \\dot q;\\ u^T \\dot J_\\omega \\dot q]`, shape (4,), at the current ``qvel`` (mj_jacDot)."""
    m, d = lp.model, lp.data
    nv = m.nv
    jp, je, jr = np.empty((3, nv)), np.empty((3, nv)), np.empty((3, nv))
    mujoco.mj_jacDot(m, d, jp, None, d.site_xpos[lp.site_pin], lp.slider)
    mujoco.mj_jacDot(m, d, je, None, d.site_xpos[lp.site_end], lp.rod)
    mujoco.mj_jacDot(m, d, None, jr, d.xpos[lp.rod], lp.rod)
    v = d.qvel
    return np.concatenate([(jp - je) @ v, [_rod_axis(lp) @ (jr @ v)]])


# ----------------------------------------------------------------------------- efforts

def _efforts(lp: MjLoop, mode: str, given: float) -> tuple[np.ndarray, float, float, float]:
    """Connect force and joint efforts by least squares on :math:`M\\ddot q + c = \\tau + J_c^T\\lambda`.

    The rows of the angular dofs (crank angle, rod ball; F·L) are divided by ``a2``, so that
    every row is a force and the fit weighs them alike in any length unit.  Returns ``(lam (3,), drive_torque, axial_force, slider_load)``; uses ``qacc``/``qvel``
    of ``data`` (``mj_rne`` reads ``qacc``: nothing may overwrite it in between).
    """
    m, d = lp.model, lp.data
    nv = m.nv
    lhs = np.empty(nv)
    mujoco.mj_rne(m, d, 1, lhs)
    jc = _gap_jacobian(lp)
    va = lp.vadr
    e_angle, e_axial, e_stroke = np.zeros(nv), np.zeros(nv), np.zeros(nv)
    e_angle[va[0]], e_axial[va[1]], e_stroke[va[3]] = 1.0, 1.0, -1.0  # slide axis is -k4
    w = np.ones(nv)
    w[[va[0], va[2], va[2] + 1, va[2] + 2]] = 1.0 / lp.a2  # angular rows: F·L -> F
    if mode == "torque":
        a = np.column_stack([jc.T, e_axial, e_stroke])
        b = lhs - given * e_angle
        x = np.linalg.lstsq(a * w[:, None], b * w, rcond=None)[0]
        return x[:3], given, x[3], x[4]
    a = np.column_stack([jc.T, e_angle, e_axial])
    b = lhs - given * e_stroke
    x = np.linalg.lstsq(a * w[:, None], b * w, rcond=None)[0]
    return x[:3], x[3], x[4], given


def joint_wrenches(lp: MjLoop) -> dict[str, float]:
    """Joint wrenches in the project's convention from MuJoCo's current ``efc_force`` and ``cfrc_int``.

    Call after ``mj_rnePostConstraint``.  ``cfrc_int[b]`` is [torque; force] exerted on
    body ``b`` by its parent, world axes, moment about ``subtree_com[body_rootid[b]]``
    (here the ``ground`` body's subtree: the mechanism's centre of mass); moments are
    moved to O (joint 1) and P3 (joint 4) with :math:`m_P = m_c + (c - P)\\times f`.
    Joint 3 is the connect: ``efc_force`` of its 3 rows is the force on site1's body
    (the slider), i.e. the force of the rod on the slider.
    """
    m, d = lp.model, lp.data
    ref = d.subtree_com[m.body_rootid[lp.crank]]
    p3 = d.site_xpos[lp.site_pin]

    def moved(body: int, point: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        torque, force = d.cfrc_int[body, :3], d.cfrc_int[body, 3:]
        return force.copy(), torque + _cross(ref - point, force)

    f1, m1 = moved(lp.crank, np.zeros(3))
    f2 = d.cfrc_int[lp.rod, 3:].copy()
    f3 = d.efc_force[:3].copy()  # the connect's rows are the only constraint rows
    f4, m4 = moved(lp.slider, p3)
    out = {}
    for name, vec in (("j1_f", f1), ("j1_m", m1), ("j2_f", f2), ("j3_f", f3), ("j4_f", f4), ("j4_m", m4)):
        for axis, value in zip("xyz", vec):
            out[name + axis] = float(value)
    out["slider_load"] = float(lp.k4 @ f4)
    out["drive_torque"] = out["j1_mz"]
    return out


def _wrenches(lp: MjLoop, lam: np.ndarray) -> dict[str, float]:
    """Rigid joint wrenches: the connect force ``lam`` into ``efc_force``, then ``mj_rnePostConstraint``."""
    lp.data.efc_force[:3] = lam
    mujoco.mj_rnePostConstraint(lp.model, lp.data)
    return joint_wrenches(lp)


def transmission(lp: MjLoop) -> float:
    """:math:`t = z\\cdot((P_2 - (0,0,S_1))\\times u)/a_1` at the current pose."""
    arm = lp.data.xpos[lp.rod] - lp.data.xpos[lp.crank]
    u = _rod_axis(lp)
    return float((arm[0] * u[1] - arm[1] * u[0]) / lp.a1)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a x b`` for two 3-vectors (numpy.cross costs ~10 us a call)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


# ----------------------------------------------------------------------------- one position

@dataclass(frozen=True)
class Position:
    """What the rigid path finds at one crank position."""

    status: str
    iterations: int
    values: dict[str, float]


def on_branch(lp: MjLoop) -> bool:
    """``(P3 - P2)·k4 < 0`` at the current pose: the assembly branch of ``docs/conventions.md``."""
    return bool((lp.data.site_xpos[lp.site_pin] - lp.data.xpos[lp.rod]) @ lp.k4 < 0.0)


def set_crank(lp: MjLoop, theta: float, s: float) -> None:
    lp.data.qpos[lp.qadr[0]] = theta
    lp.data.qpos[lp.qadr[1]] = s


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
        foot, axis = _slider_line(lp)
        lp.data.qpos[lp.qadr[3]] = float(foot_s4(lp.data.xpos[lp.rod], foot, -axis)[0])
        mujoco.mj_kinematics(lp.model, lp.data)
    if status != Status.OK:
        return status, iters, gap, c
    mujoco.mj_fwdPosition(lp.model, lp.data)  # efc rows of the connect, cinert, ...
    rows, _ = _rate_rows(lp)
    lp.data.qvel[:] = _solve_rates(lp, rows, np.array([theta_dot, s_dot]), np.zeros(4))
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
    rows, _ = _rate_rows(lp)
    qacc = _solve_rates(lp, rows, np.array(crank[4:6]), -_drift(lp))
    d.qacc[:] = qacc
    t = transmission(lp)
    values.update(
        S4=float(d.qpos[lp.qadr[3]]), S4_dot=float(d.qvel[lp.vadr[3]]),
        S4_ddot=float(qacc[lp.vadr[3]]), transmission=t, residual=gap,
    )
    if mode == "torque" and abs(t) < DEAD_CENTRE_TRANSMISSION.value:
        return Position(Status.DEAD_CENTRE.value, iters, values)
    lam, _, _, _ = _efforts(lp, mode, given)
    values.update(_wrenches(lp, lam))
    return Position(Status.OK.value, iters, values)


# ----------------------------------------------------------------------------- public

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
    state = case.motion.state(case.geometry.crank_axial_shift)
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
    status = settle(cols, status, REACTION_COLUMNS)
    meta = {"mujoco": mujoco.__version__, "newton_iterations": iters,
            "messages": status_messages(cols["theta1_deg"], status)}
    return ResultTable(ENGINE, case.name, cols, status, meta)


def assembled_qpos(case: Case, row: int = 0) -> np.ndarray:
    """``qpos`` (7,) of the MJCF with the loop closed at crank position ``row`` (crude guess + Newton).

    For :func:`dualmech.models.mjcf.case_to_mjcf`'s ``keyframe``.  Raises
    ``ValueError`` if the mechanism does not assemble there.
    """
    lp = build(case)
    st = case.motion.state(case.geometry.crank_axial_shift)
    if not 0 <= row < len(st):
        raise ValueError(f"row: expected 0 <= row < {len(st)}, got {row!r}")
    status, _, _, _ = assembled_state(lp, (float(st.theta[row]), float(st.s[row]), 0.0, 0.0), warm=False)
    if status != Status.OK:
        raise ValueError(f"case: the loop does not close at theta1 = {st.theta[row] * 180 / math.pi:g} deg ({status})")
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
