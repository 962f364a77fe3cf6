"""Inverse dynamics of any single loop: the reaction wrench at every joint of a link-joint table.

Thesis section 2.8 (eq. 44-64) for any table, in world axes with moments about the world origin O
(:mod:`dualmech.core.reactions` for the dual momentum).  Row ``r``'s joint exerts the wrench
:math:`\\hat W_r = f_r + \\varepsilon(P_r\\times f_r + m_r)` on the link row ``r`` carries, from the link
before it (:math:`P_r` the joint's point: the origin of the frame before the row, for a U joint the point
where its two axes meet, :func:`joint_points`; :math:`m_r` the moment about it), and :math:`-\\hat W_{r+1}` is
what the next joint exerts back; so D'Alembert's principle (eq. 62-64) for
the link of row ``r`` reads

.. math:: \\hat W_r - \\hat W_{r+1} = \\dot{\\hat H}_r - m_r\\,\\hat g_r

(the link of the last row is the ground: no equation; each joint's wrench enters its two links with opposite
signs, errata E9).  Each wrench is split into

* its **constraint** part: in the joint's frame (x, y, z; for a U joint x', y', z with y' the second axis),
  a force along every axis the joint does not slide along and a moment about every axis it does not turn
  about: :math:`6 - f_i` unknowns (a ball: three forces);
* its **efforts** along the joint's own coordinates: a torque :math:`\\tau z` about a turning axis, a force
  :math:`F z` through :math:`P_r` along a sliding axis; each given (a load, 0 for a passive joint) or solved
  (the drive effort, or the load left to balance a given drive, and the axial force of a prescribed slide,
  a reaction: errata E10).

The batched linear system (moment rows over the length scale) is solved per position by QR least squares.
An S-S link's spin (fixed by the zero-spin gauge, ``docs/conventions.md``, "Rod spin") makes one equation
``0 = 0`` for an axisymmetric link: the system has one row more than unknowns and the solution is exact;
the relative Newton-Euler residual is reported (it is not small for a link that is not axisymmetric).

**Singular transmission.** The solved effort named ``transmission_effort`` is singular where its column lies
in the span of the others (a dead centre: the load cannot be balanced): the distance of that column from
their span over its length, from a QR factorization with it last, is returned as ``transmission``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dualmech.core.dual import Dual, origin, rot_x, scalar_type
from dualmech.core.loop import Chain, Loop, Var
from dualmech.core.rates import Rates
from dualmech.core.reactions import Body, body_motion, force_at, momentum_rate


@dataclass(frozen=True)
class JointWrenches:
    """Reactions at ``n`` positions of a table of ``J`` rows.

    Attributes
    ----------
    force : numpy.ndarray, shape (n, J, 3)
        Force of each joint on the link its row carries (from the previous link), world axes.
    moment : numpy.ndarray, shape (n, J, 3)
        Its moment about the joint's point :math:`P_r`, world axes (efforts included).
    point : numpy.ndarray, shape (n, J, 3)
        The joints' points :math:`P_r` (:func:`joint_points`), world.
    efforts : dict of name -> numpy.ndarray, shape (n,)
        The effort along every joint coordinate of the table (given and solved).
    residual : numpy.ndarray, shape (n,)
        :math:`|Ax - b| / |b|` of the weighted Newton-Euler equations.
    transmission : numpy.ndarray, shape (n,)
        Distance of the transmission effort's column from the others' span, over its length (0: singular).
    components : tuple of dict, one per row
        The constraint wrench's components in the joint's frame (x, y, z of :func:`_joint_axes`: frame
        ``{i}``, for a U joint ``x', y', z``), ``(n,)`` each, keyed ``fx`` ... ``mz``: the forces along the
        axes the joint does not slide along, the moments (about the joint's point) about those it does not
        turn about -- the thesis's joint-frame reactions, :math:`6 - f_i` of them.
    """

    force: np.ndarray
    moment: np.ndarray
    point: np.ndarray
    efforts: dict[str, np.ndarray]
    residual: np.ndarray
    transmission: np.ndarray
    components: tuple[dict[str, np.ndarray], ...]


def _value(v: float | Var, inputs: dict[str, np.ndarray], n: int) -> np.ndarray:
    return np.asarray(inputs[v.name]) if isinstance(v, Var) else np.full(n, float(v))


def link_frames(chain: Chain, loop: Loop,
                inputs: dict[str, np.ndarray]) -> list[tuple[np.ndarray, np.ndarray]]:
    """Rotation ``(n, 3, 3)`` and origin ``(n, 3)`` of each row's *link frame*: the frame after the row's
    joint motion, before its :math:`X(\\alpha + \\varepsilon a)` (origin on the joint axis at the foot of
    the common normal, x along it, z the joint axis), world.  ``alpha``, ``a`` constants or parameters."""
    n = chain.closure.re.shape[0]
    out = []
    for row, frame in zip(loop.rows, chain.frames):
        alpha, a = _value(row.alpha, inputs, n), _value(row.a, inputs, n)
        rot = frame.re @ np.swapaxes(rot_x(Dual.of(alpha)).re, -1, -2)
        out.append((rot, origin(frame) - a[:, None] * frame.re[:, :, 0]))
    return out


def joint_points(chain: Chain, loop: Loop, inputs: dict[str, np.ndarray]) -> np.ndarray:
    """Each row's joint point ``(n, J, 3)``, world: the origin of the frame before the row (frame {1} = world
    for the first), moved by the row's constant offset ``s`` along ``z`` where the row also turns about its y
    axis (a U joint: the point where its two axes meet)."""
    n = chain.closure.re.shape[0]
    points = []
    for r, row in enumerate(loop.rows):
        point = np.zeros((n, 3)) if r == 0 else origin(chain.frames[r - 1])
        if isinstance(row.eta, Var) and row.eta.kind != "param":
            z = np.broadcast_to(np.eye(3), (n, 3, 3))[:, :, 2] if r == 0 else chain.frames[r - 1].re[:, :, 2]
            point = point + _value(row.s, inputs, n)[:, None] * z
        points.append(point)
    return np.stack(points, axis=1)


def _screw(chain: Chain, loop: Loop, var: Var):
    """The elementary screw (:class:`~dualmech.core.loop.Screw`) of an input or unknown slot."""
    key = ("input", var.name) if var.kind == "input" else ("unknown", loop.unknowns.index(var.name))
    return next(s for s in chain.screws if s.var == key)


def _joint_axes(chain: Chain, loop: Loop, r: int) -> np.ndarray:
    """Axes ``(n, 3, 3)`` (columns x, y, z) of row ``r``'s joint frame: the frame before the row, or for a
    row turning about its y axis too (U) x', y', z with y' the turned y axis (its eta screw)."""
    n = chain.closure.re.shape[0]
    axes = np.broadcast_to(np.eye(3), (n, 3, 3)) if r == 0 else chain.frames[r - 1].re
    eta = loop.rows[r].eta
    if isinstance(eta, Var) and eta.kind != "param":
        z, y = axes[:, :, 2], _screw(chain, loop, eta).line.re
        axes = np.stack([np.cross(y, z), y, z], axis=2)
    return axes


def joint_freedoms(loop: Loop, r: int) -> tuple[set[int], set[int]]:
    """Axes (0 x, 1 y, 2 z of :func:`_joint_axes`) row ``r`` turns about and slides along."""
    row = loop.rows[r]
    if row.spherical:
        return {0, 1, 2}, set()
    moving = {f for f in ("theta", "s", "eta")
              if isinstance(getattr(row, f), Var) and getattr(row, f).kind != "param"}
    turns = {2} if "theta" in moving else set()
    if "eta" in moving:
        turns.add(1)
    return turns, ({2} if "s" in moving else set())


def effort_slots(loop: Loop) -> list[tuple[int, str, bool]]:
    """Every joint coordinate with an effort, ``(row, variable name, sliding)``: the inputs and unknowns of
    the non-spherical rows, in row order."""
    slots = []
    for r, row in enumerate(loop.rows):
        if row.spherical:
            continue
        for f, slide in (("theta", False), ("s", True), ("eta", False)):
            v = getattr(row, f)
            if isinstance(v, Var) and v.kind != "param":
                slots.append((r, v.name, slide))
    return slots


def solve_joint_wrenches(chain: Chain, loop: Loop, inputs: dict[str, np.ndarray], rates: Rates,
                         bodies: tuple[Body, ...], gravity: np.ndarray, efforts: dict[str, np.ndarray | None],
                         transmission_effort: str, length: np.ndarray) -> JointWrenches:
    """Every joint's reaction wrench and the solved efforts (module docstring).

    Parameters
    ----------
    chain, loop, inputs : the closed loop at ``n`` positions (:func:`dualmech.core.loop.evaluate`)
    rates : its :class:`~dualmech.core.rates.Rates`
    bodies : mass properties of the moving links (rows ``0 .. J-2``), link frames (:func:`link_frames`)
    gravity : ``(3,)`` or ``(n, 3)`` gravitational acceleration, world
    efforts : variable name -> given effort ``(n,)``, or ``None`` where it is solved; the coordinates of
        :func:`effort_slots` not named carry no effort (passive)
    transmission_effort : the solved effort whose singularity is the transmission (module docstring)
    length : ``(n,)`` the length the moment rows are divided by
    """
    points = joint_points(chain, loop, inputs)
    columns, known = _columns(chain, loop, points, efforts, transmission_effort)
    a, b = _equations(chain, loop, inputs, rates, bodies, gravity, columns, known)
    rows = len(loop.rows) - 1
    weight = np.tile(np.r_[np.ones(3), np.zeros(3)], rows)[None, :] + \
        np.tile(np.r_[np.zeros(3), np.ones(3)], rows)[None, :] / length[:, None]
    x, residual, transmission = _least_squares(a * weight[:, :, None], b * weight)
    wrench = [Dual(k.re.copy(), k.du.copy()) for k in known]
    components: tuple[dict[str, np.ndarray], ...] = tuple({} for _ in loop.rows)
    for c, (r, unit, name, label) in enumerate(columns):
        wrench[r] = wrench[r] + unit * x[:, c, None]
        if name is None:
            components[r][label] = x[:, c]
    force = np.stack([w.re for w in wrench], axis=1)
    moment = np.stack([w.du for w in wrench], axis=1) - np.cross(points, force)
    values = {name: np.asarray(v, dtype=float) for name, v in efforts.items() if v is not None}
    for c, (_, _, name, _) in enumerate(columns):
        if name is not None:
            values[name] = x[:, c]
    return JointWrenches(force, moment, points, values, residual, transmission, components)


def _columns(chain: Chain, loop: Loop, points: np.ndarray, efforts: dict[str, np.ndarray | None],
             transmission_effort: str) -> tuple[list[tuple[int, Dual, str | None, str]], list[Dual]]:
    """The unknown wrench columns ``(row, unit wrench, effort name or None, label)`` -- constraints (labels
    ``fx`` ... ``mz``), then the solved efforts with the transmission's last -- and each row's known (given
    effort) wrench."""
    n = chain.closure.re.shape[0]
    columns: list[tuple[int, Dual, str | None, str]] = []
    known = [Dual(np.zeros((n, 3)), np.zeros((n, 3))) for _ in loop.rows]
    for r in range(len(loop.rows)):
        axes = _joint_axes(chain, loop, r)
        turns, slides = joint_freedoms(loop, r)
        for k in range(3):
            if k not in slides:
                columns.append((r, force_at(points[:, r], axes[:, :, k]), None, "f" + "xyz"[k]))
            if k not in turns:
                columns.append((r, Dual(np.zeros((n, 3)), axes[:, :, k]), None, "m" + "xyz"[k]))
    solved = []
    for r, name, slide in effort_slots(loop):
        unit = _effort_unit(chain, loop, r, name, slide, points[:, r])
        value = efforts.get(name, np.zeros(n))
        if value is None:
            solved.append((r, unit, name, name))
        else:
            known[r] = known[r] + unit * np.asarray(value, dtype=float)[:, None]
    solved.sort(key=lambda c: c[2] == transmission_effort)
    return columns + solved, known


def _equations(chain, loop, inputs, rates, bodies, gravity, columns, known) -> tuple[np.ndarray, np.ndarray]:
    """Newton-Euler of every moving link, ``A (n, 6(J-1), k)`` and ``b (n, 6(J-1))`` (module docstring)."""
    n, n_rows = chain.closure.re.shape[0], len(loop.rows)
    a = np.zeros((n, 6 * (n_rows - 1), len(columns)), scalar_type(chain.closure.re))
    b = np.zeros(a.shape[:2], a.dtype)
    for c, (r, unit, _, _) in enumerate(columns):
        for target, sign in ((r, 1.0), (r - 1, -1.0)):
            if 0 <= target < n_rows - 1:
                a[:, 6 * target:6 * target + 3, c] += sign * unit.re
                a[:, 6 * target + 3:6 * target + 6, c] += sign * unit.du
    frames = link_frames(chain, loop, inputs)
    for r in range(n_rows - 1):
        motion = body_motion(bodies[r], *frames[r], rates.link_twist[r], rates.link_accel[r])
        mass = np.asarray(bodies[r].mass, dtype=float)
        weight = force_at(motion.com, mass * np.broadcast_to(gravity, (n, 3)))
        rhs = momentum_rate(bodies[r], motion) - weight - known[r] + known[r + 1]
        b[:, 6 * r:6 * r + 3], b[:, 6 * r + 3:6 * r + 6] = rhs.re, rhs.du
    return a, b


def _least_squares(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Least squares of ``a x = b`` per position by one QR factorization ``a = QR``: ``x = R^-1 Q^T b``; the
    relative residual; the last column's distance from the others' span over its length, ``|R_kk| / |a_k|``.
    Where ``R`` is singular (a dead centre) ``x`` is not finite."""
    tiny = np.finfo(float).tiny
    q, r = np.linalg.qr(a)
    diag = np.einsum("nii->ni", r)
    singular = np.abs(diag) <= tiny
    if singular.any():  # solve anyway, batched: those rows' answers are meaningless (and flagged)
        r = r.copy()
        idx = np.nonzero(singular)
        r[idx[0], idx[1], idx[1]] = tiny
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        x = np.linalg.solve(r, np.einsum("nmk,nm->nk", q, b)[..., None])[..., 0]
        residual = np.linalg.norm(np.einsum("nij,nj->ni", a, x) - b, axis=1) / np.maximum(
            np.linalg.norm(b, axis=1), tiny)
    return x, residual, np.abs(diag[:, -1]) / np.maximum(np.linalg.norm(a[:, :, -1], axis=1), tiny)


def _effort_unit(chain: Chain, loop: Loop, r: int, name: str, slide: bool, point: np.ndarray) -> Dual:
    """Unit effort of row ``r``'s coordinate ``name``: a couple :math:`(0, z)` about a turning axis, a force
    :math:`(z, P\\times z)` along a sliding one (``z`` from the coordinate's screw)."""
    row = loop.rows[r]
    var = next(getattr(row, f) for f in ("theta", "s", "eta")
               if isinstance(getattr(row, f), Var) and getattr(row, f).name == name)
    screw = _screw(chain, loop, var)
    if slide:
        return force_at(point, screw.line.du)
    return Dual(np.zeros_like(screw.line.re), screw.line.re)


__all__ = [
    "JointWrenches", "link_frames", "joint_points", "joint_freedoms", "effort_slots", "solve_joint_wrenches",
]
