"""The MuJoCo loop judge's rates, inverse dynamics and joint wrenches at a closed pose (:mod:`.closure`).

**Rates.** With ``A`` the cut rows and the spin-gauge rows over ``u`` (:func:`.closure.cut_rows`,
:func:`.closure.gauge_rows`; square over the free columns),

.. math:: A\\,\\dot u = 0, \\qquad A\\,\\ddot u = -\\dot A\\,\\dot u,

the prescribed columns moved to the right.  The drift :math:`\\dot A \\dot u` (:func:`drift`) is MuJoCo's
``mj_jacDot`` of link n-1 at ``p_C`` and of each idle link, plus joint n's own terms: a turning axis
carried by the link turns with it (:math:`(\\omega\\times z)\\dot\\theta`; the U joint's second axis with
:math:`\\omega + \\dot\\theta z`), and a slide adds the Coriolis term :math:`2\\dot s\\,\\omega\\times z` to
``p_C``.

**Inverse dynamics.** ``mj_rne`` gives :math:`M\\ddot q + c` (gravity included).  The cut's wrench
:math:`W = (f, m)` of link n-1 on the ground through joint n (force, world; moment about ``p_C``) enters
the tree as :math:`-J_C^T W` (``J_C`` the cut rows over MuJoCo's dofs: the multipliers of the cut are its
reaction), so with the joints' efforts :math:`\\tau` (given, 0 if passive, or solved)

.. math:: M\\ddot q + c = \\tau - J_C^T W, \\qquad a_k \\cdot W = \\tau_{n,k}

for each of joint n's coordinates (its axis ``a_k`` against ``f`` for a slide, ``m`` for a turn: joint
n's effort on the ground from link n-1).  Unknowns: ``W`` (3 forces for a ball cut) and the solved efforts;
solved by least squares (an idle spin's row is ``0 = 0``).  The solved effort that decides the
transmission is last: its column's distance from the others' span over its length (from the QR
factorization) is the transmission, and below
:data:`~dualmech.core.thresholds.DEAD_CENTRE_TRANSMISSION` the position is a dead centre.  Rows of
torques are divided by the table's length so that every row is a force.

**Joint wrenches.** ``-W`` is applied to link n-1 (``xfrc_applied``), ``qacc`` set, and
``mj_rnePostConstraint`` fills ``cfrc_int``: each body's wrench from its parent (world axes, about the
``subtree_com`` of its root), which is joint i's wrench on link i from link i-1; moments are moved to
the joints' points (``docs/conventions.md``, "Loop tables": frame {i}'s origin; a U joint's where its
axes meet).  Joint n's wrench is ``W`` itself.  MuJoCo's constraint solver is never called (no
``efc`` rows are made): the equality's sites are read, its soft force is not.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from dualmech.validation.judges.mujoco_loop.closure import (
    MjLoop,
    cut_frame,
    cut_rows,
    gauge_axes,
    gauge_rows,
    variable,
)


def velocity_rows(lp: MjLoop) -> np.ndarray:
    """``A`` ``(m + g, n_u)``: the cut rows and the gauge rows (module docstring), current pose."""
    return np.vstack([cut_rows(lp), gauge_rows(lp)])


def solve_free(lp: MjLoop, rows: np.ndarray, known: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """``u``-space vector ``x`` ``(n_u,)`` with ``x[prescribed] = known`` and ``rows @ x = rhs``."""
    x = np.zeros(lp.n_u)
    x[lp.prescribed] = known
    x[lp.free] = np.linalg.solve(rows[:, lp.free], rhs - rows[:, lp.prescribed] @ known)
    return x


def set_velocity(lp: MjLoop, u_dot: np.ndarray) -> None:
    """``qvel`` and the cut's rates from ``u_dot``; MuJoCo's velocity-dependent quantities (``cvel``,
    ``cdof_dot``) for ``mj_jacDot`` and ``mj_rne``."""
    lp.data.qvel[:] = u_dot[:lp.model.nv]
    mujoco.mj_comVel(lp.model, lp.data)


def drift(lp: MjLoop, u_dot: np.ndarray) -> np.ndarray:
    """:math:`\\dot A \\dot u` ``(m + g,)`` (module docstring), after :func:`set_velocity`."""
    m, d = lp.model, lp.data
    qvel = u_dot[:m.nv]
    rates = dict(zip(lp.cut, u_dot[m.nv:]))
    p_c, _, axes = cut_frame(lp)
    jacp, jacr = np.empty((3, m.nv)), np.empty((3, m.nv))
    link = lp.bodies[-1]
    mujoco.mj_jac(m, d, None, jacr, p_c, link)
    omega = jacr @ qvel
    mujoco.mj_jacDot(m, d, jacp, jacr, p_c, link)
    translation, rotation = jacp @ qvel, jacr @ qvel
    if "s" in rates:
        translation = translation + 2.0 * rates["s"] * np.cross(omega, axes["s"])
    if "theta" in rates:
        rotation = rotation + rates["theta"] * np.cross(omega, axes["theta"])
    if "eta" in rates:
        carrier = omega + rates.get("theta", 0.0) * axes["theta"]
        rotation = rotation + rates["eta"] * np.cross(carrier, axes["eta"])
    out = [translation] if lp.ball_cut else [translation, rotation]
    for body, u in gauge_axes(lp):
        mujoco.mj_jacDot(m, d, None, jacr, d.xpos[body], body)
        out.append(np.array([u @ jacr @ qvel]))
    return np.concatenate(out)


@dataclass(frozen=True)
class Balance:
    """The cut's wrench and the solved efforts at one position (module docstring).

    ``force``, ``moment`` ``(3,)``: ``W`` (moment about ``p_C``; zero for a ball cut); ``efforts``: every
    given and solved effort by variable name; ``transmission``; ``residual`` the relative least-squares
    residual of the equations.
    """

    force: np.ndarray
    moment: np.ndarray
    efforts: dict[str, float]
    transmission: float
    residual: float


def _tree_torque_rows(lp: MjLoop) -> np.ndarray:
    """``(nv,)`` weights making every generalized-force row a force: 1/length for a turning dof."""
    w = np.ones(lp.model.nv)
    for j in range(lp.model.njnt):
        if lp.model.jnt_type[j] != mujoco.mjtJoint.mjJNT_SLIDE:
            adr = lp.model.jnt_dofadr[j]
            w[adr:adr + (3 if lp.model.jnt_type[j] == mujoco.mjtJoint.mjJNT_BALL else 1)] = 1.0 / lp.size
    return w


def balance(lp: MjLoop, u_ddot: np.ndarray, given: dict[str, float], solved: list[str]) -> Balance:
    """Solve the inverse dynamics (module docstring) with ``qacc`` from ``u_ddot``.

    ``given``: efforts by variable name (missing coordinates are passive); ``solved``: the names solved
    for, the transmission's last.  After :func:`set_velocity`.
    """
    m, d = lp.model, lp.data
    nv, wrench = m.nv, 3 if lp.ball_cut else 6
    d.qacc[:] = u_ddot[:nv]
    bias = np.empty(nv)
    mujoco.mj_rne(m, d, 1, bias)
    rows = cut_rows(lp)
    _, _, axes = cut_frame(lp)
    n_eq = nv + len(lp.cut)
    a = np.zeros((n_eq, wrench + len(solved)))
    b = np.zeros(n_eq)
    a[:nv, :wrench] = -rows[:, :nv].T
    b[:nv] = bias
    for name, value in given.items():  # tree efforts to the right; the cut's to its rows
        index = lp.coordinates[name][0]
        b[index] += -value if index < nv else value
    for k, coordinate in enumerate(lp.cut):
        offset = 0 if coordinate == "s" else 3
        a[nv + k, offset:offset + 3] = axes[coordinate]
    for c, name in enumerate(solved):
        index = lp.coordinates[name][0]
        a[index, wrench + c] = 1.0 if index < nv else -1.0
    weight = np.r_[_tree_torque_rows(lp), [1.0 if c == "s" else 1.0 / lp.size for c in lp.cut]]
    a, b = a * weight[:, None], b * weight
    q, r = np.linalg.qr(a)
    x = np.linalg.solve(r, q.T @ b)
    residual = float(np.linalg.norm(a @ x - b) / max(np.linalg.norm(b), np.finfo(float).tiny))
    transmission = float(abs(r[-1, -1]) / np.linalg.norm(a[:, -1]))
    efforts = dict(given)
    efforts.update({name: float(x[wrench + c]) for c, name in enumerate(solved)})
    moment = x[3:6] if wrench == 6 else np.zeros(3)
    return Balance(x[:3].copy(), moment.copy(), efforts, transmission, residual)


def joint_points(lp: MjLoop) -> np.ndarray:
    """Each joint's point ``(n, 3)``, world (module docstring), current pose."""
    d, joints = lp.data, lp.mechanism.joints
    points = []
    for i, joint in enumerate(joints):
        if i == 0:
            frame = (np.zeros(3), np.eye(3))
        else:
            body = lp.bodies[i - 1]
            rot = d.xmat[body].reshape(3, 3)
            twist = joints[i - 1].alpha
            c, s = np.cos(twist), np.sin(twist)
            frame = (d.xpos[body] + joints[i - 1].a * rot[:, 0], rot @ np.array([[1, 0, 0], [0, c, -s],
                                                                                 [0, s, c]]))
        point = frame[0] + (joint.s * frame[1][:, 2] if joint.type == "U" else 0.0)
        points.append(point)
    return np.array(points)


def joint_wrenches(lp: MjLoop, cut: Balance) -> tuple[np.ndarray, np.ndarray]:
    """Every joint's force and moment ``(n, 3)`` each (module docstring), world axes, moments about the
    joints' points.  After :func:`balance` (``qacc`` set)."""
    m, d = lp.model, lp.data
    p_c, _, _ = cut_frame(lp)
    link = lp.bodies[-1]
    force = -cut.force
    d.xfrc_applied[:] = 0.0
    d.xfrc_applied[link, :3] = force
    d.xfrc_applied[link, 3:] = -cut.moment + np.cross(p_c - d.xipos[link], force)
    mujoco.mj_rnePostConstraint(m, d)
    d.xfrc_applied[:] = 0.0
    points = joint_points(lp)
    n = len(lp.mechanism.joints)
    forces, moments = np.zeros((n, 3)), np.zeros((n, 3))
    for i, body in enumerate(lp.bodies):
        torque, f = d.cfrc_int[body, :3], d.cfrc_int[body, 3:]
        centre = d.subtree_com[m.body_rootid[body]]
        forces[i], moments[i] = f, torque + np.cross(centre - points[i], f)
    forces[-1] = cut.force
    moments[-1] = cut.moment + np.cross(p_c - points[-1], cut.force)
    return forces, moments


__all__ = ["velocity_rows", "solve_free", "set_velocity", "drift", "Balance", "balance", "joint_points",
           "joint_wrenches", "variable"]
