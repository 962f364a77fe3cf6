"""How far a loop's pose is from an assembly limit: the closure condition of its solved joint freedoms.

The closure's linearization maps the joint rates to the loop's relative twist,
:math:`\\sum_k \\dot q_k \\hat\\$_k = 0` (the derivative of the loop equation, thesis eq. 3.6, with the
joint screws :math:`\\hat\\$_k`).  The prescribed coordinates' screws go to the right-hand side; the solved
freedoms' screws are the columns of :math:`J` (6 rows).  Where :math:`J` loses rank the rates are unbounded:
the loop is at an *assembly limit* (or a joint locks).  The scale-free measure (``docs/conventions.md``,
"Loop tables"):

.. math:: c = \\sigma_6(\\bar J) / \\sigma_1(\\bar J), \\qquad
          \\bar J_{:,k} = (\\omega_k,\\ v_{O,k} / L)

with each freedom's unit twist (a turn about axis :math:`a` through :math:`p`: :math:`\\omega = a`,
:math:`v_O = (p - O) \\times a`; a slide along :math:`a`: :math:`\\omega = 0`, :math:`v_O = a`), ``O`` the
centroid of the joint points, ``L`` their root-mean-square distance from it (the pose's own size: a
table's constant lengths would not do, as a C joint's slides can carry its points far beyond them) and
:math:`\\sigma_1 \\ge \\dots \\ge \\sigma_6` its singular values.  A spherical joint's three turns about
any orthonormal axes give the same singular values (its three columns change by an orthogonal matrix; so
the columns are not scaled one by one), and an S-S
link's idle spin is a null combination of its two balls' columns, so with it :math:`\\bar J` has seven
columns and rank six: :math:`\\sigma_6` is then the smallest that matters.  :math:`c` is invariant to the
world frame and the units.

The screws come from a pose's scalar joint coordinates (a loop table's pose columns) by the table's own
forward kinematics, written here apart from the in-house engine's: every row's
:math:`Z(\\theta + \\varepsilon s)\\, Y(\\eta)\\, X(\\alpha + \\varepsilon a)`, walked from the ground up to
the first spherical joint and down from the ground's other side to the last (a ball's rotation is not a
column, and no joint's axis needs it: a mobile single loop has no joint between two balls but a driven one,
whose screw is not a column; there :math:`c` is NaN).  So every engine's words follow from its own pose by
one rule (:func:`~dualmech.models.loop.columns.loop_table`).

**Joint locks.** :math:`J` also loses rank where the drive still moves the loop but a passive joint's rate is
not determined (a universal joint whose axis lines up with a ball's: the slider crank's rod along its
slider line): a *joint lock*.  The two differ in the drive's twist :math:`\\hat\\$_d` (the prescribed
coordinates' unit twists, each times its rate per unit drive rate): at an assembly limit it leaves the span
of :math:`J`'s columns (the drive cannot move on: the rates are unbounded), at a lock it stays in it (the
drive moves the loop with bounded rates; the singular direction is a motion of the passive joints alone).
So the condition of :math:`[\\bar J\\ \\bar\\$_d]`, :math:`c_d` (:func:`drive_condition`), stays of the
order of :math:`c` at a lock and does not go to zero at an assembly limit.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from dualmech.core.kernel.pool import side_pool, threads
from dualmech.models.loop.description import LoopMechanism
from dualmech.models.loop.translate import drive_state, variable

#: Implicit QL iterations at most per eigenvalue (:func:`_ql_eigenvalues`): one or two reach rounding.
QL_ITERATIONS = 30
#: An off-diagonal of a tridiagonal matrix counts as zero below this much of its diagonal neighbours (unit
#: roundoff of double precision).
EPS = 2.220446049250313e-16

#: A frame: its rotation ``(n, 3, 3)`` and origin ``(n, 3)``, world.
Frame = tuple[np.ndarray, np.ndarray]
#: A unit twist: its axis ``(n, 3)`` and a point of it ``(n, 3)`` (``None``: a slide), world.
Twist = tuple[np.ndarray, np.ndarray | None]


def _value(pose: dict[str, np.ndarray], name: str, constant: float, n: int) -> np.ndarray:
    return np.asarray(pose[name], dtype=float) if name in pose else np.full(n, constant)


def _rx(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def row_motion(mechanism: LoopMechanism, pose: dict[str, np.ndarray], k: int, n: int) -> Frame:
    """Row ``k``'s (not spherical) motion :math:`Z(\\theta + \\varepsilon s)\\, Y(\\eta)\\,
    X(\\alpha + \\varepsilon a)` from ``pose`` (the table's coordinate columns ``theta<i>``, ``s<i>``,
    ``eta<i>``): its rotation ``Rz Ry Rx`` and translation ``s z + a (Rz Ry x)``."""
    j = mechanism.joints[k]
    theta = _value(pose, f"theta{k + 1}", j.theta, n)
    eta = _value(pose, f"eta{k + 1}", 0.0, n)
    ct, st, ce, se = np.cos(theta), np.sin(theta), np.cos(eta), np.sin(eta)
    zero = np.zeros(n)
    turn = np.stack([np.stack([ct * ce, -st, ct * se], -1), np.stack([st * ce, ct, st * se], -1),
                     np.stack([-se, zero, ce], -1)], 1)  # Rz(theta) Ry(eta)
    shift = np.stack([zero, zero, _value(pose, f"s{k + 1}", j.s, n)], -1) + j.a * turn[:, :, 0]
    return turn @ _rx(j.alpha), shift


def joint_frames(mechanism: LoopMechanism, pose: dict[str, np.ndarray], n: int) -> list[Frame | None]:
    """Each row's frame before its motion (world) at the ``n`` rows of ``pose``, from the ground forward up
    to the first spherical joint and backward from the loop's end down past the last (module docstring); of
    a spherical joint only the origin (its centre) is meant; ``None`` for a row between two spherical
    joints."""
    joints = mechanism.joints
    balls = [k for k, j in enumerate(joints) if j.type == "S"]
    first, last = (balls[0], balls[-1]) if balls else (len(joints), len(joints))
    frames: list[Frame | None] = [None] * len(joints)
    rot, origin = np.broadcast_to(np.eye(3), (n, 3, 3)), np.zeros((n, 3))
    for k in range(min(first + 1, len(joints))):
        frames[k] = (rot, origin)
        if k < first:
            turn, shift = row_motion(mechanism, pose, k, n)
            rot, origin = rot @ turn, origin + (rot @ shift[:, :, None])[:, :, 0]
    if balls:  # back from the frame after the last row (the world): F_k = F_(k+1) M_k^-1
        rot, origin = np.broadcast_to(np.eye(3), (n, 3, 3)), np.zeros((n, 3))
        for k in range(len(joints) - 1, last - 1, -1):
            if joints[k].type == "S":  # its centre: the next frame moved back along x by its link's length
                frames[k] = (rot, origin - joints[k].a * rot[:, :, 0])  # (its twist moves no point of x)
                break
            turn, shift = row_motion(mechanism, pose, k, n)
            rot = rot @ np.swapaxes(turn, 1, 2)
            origin = origin - (rot @ shift[:, :, None])[:, :, 0]
            frames[k] = (rot, origin)
    return frames


def coordinate_twists(mechanism: LoopMechanism, pose: dict[str, np.ndarray]
                      ) -> tuple[dict[tuple[int, str], Twist], np.ndarray]:
    """Every joint coordinate's unit twist by ``(joint, coordinate)`` (0-based joint; ``theta``, ``s``,
    ``eta``, or ``ball0`` ... ``ball2`` for an S joint's three turns): its ``(axis, point)`` pair, each
    ``(n, 3)`` world (``point`` ``None``: a slide); and every joint's point ``(n, J, 3)`` (an S joint's
    centre; a U joint's where its two axes meet)."""
    n = np.asarray(next(iter(pose.values()))).shape[0]
    frames = joint_frames(mechanism, pose, n)
    nan = np.full((n, 3), np.nan)
    twists: dict[tuple[int, str], Twist] = {}
    points = []
    for k, (joint, frame) in enumerate(zip(mechanism.joints, frames)):
        rot, point = frame if frame is not None else (np.full((n, 3, 3), np.nan), nan)
        if joint.type == "S":
            twists.update({(k, f"ball{i}"): (np.broadcast_to(np.eye(3)[i], (n, 3)), point) for i in range(3)})
            points.append(point)
            continue
        if joint.type == "U":  # the second axis is y after the first turn (and the offset s along z)
            point = point + _value(pose, f"s{k + 1}", joint.s, n)[:, None] * rot[:, :, 2]
            theta = _value(pose, f"theta{k + 1}", 0.0, n)[:, None]
            twists[(k, "eta")] = (np.cos(theta) * rot[:, :, 1] - np.sin(theta) * rot[:, :, 0], point)
        if joint.type in ("R", "C", "U"):
            twists[(k, "theta")] = (rot[:, :, 2], point)
        if joint.type in ("P", "C"):
            twists[(k, "s")] = (rot[:, :, 2], None)
        points.append(point)
    return twists, np.stack(points, axis=1)


def freedom_twists(mechanism: LoopMechanism, pose: dict[str, np.ndarray]
                   ) -> tuple[list[Twist], np.ndarray]:
    """The solved freedoms' ``(axis, point)`` pairs and every joint's point (:func:`coordinate_twists`
    without the prescribed coordinates)."""
    twists, points = coordinate_twists(mechanism, pose)
    prescribed = set(mechanism.prescribed)
    return [twist for key, twist in twists.items() if key not in prescribed], points


def _columns(twists: list[Twist], points: np.ndarray) -> np.ndarray:
    """The columns :math:`\\bar J_{:,k} = (\\omega_k, v_{O,k} / L)` ``(n, m, 6)`` of ``twists`` (module
    docstring: ``O`` the centroid of ``points``, ``L`` their RMS distance from it; :func:`_columns_rows`)."""
    axes = np.stack([axis for axis, _ in twists], axis=1)
    anchors = np.stack([axis if point is None else point for axis, point in twists], axis=1)
    slide = np.array([point is None for _, point in twists])
    return _columns_rows(axes, anchors, slide, points)  # each stacked anew: C-contiguous


@njit(cache=True, nogil=True, error_model="numpy", fastmath={"contract", "arcp"})
def _columns_rows(axes: np.ndarray, anchors: np.ndarray, slide: np.ndarray, points: np.ndarray) -> np.ndarray:
    """:func:`_columns` per row, compiled: ``axes``, ``anchors`` ``(n, m, 3)`` (a turn's point; a slide's is
    not read), ``slide`` ``(m,)`` bool, ``points`` ``(n, J, 3)``.  ``L`` is 1 where the points do not spread
    (or are not finite: the row's columns are then not finite either)."""
    n, m, joints = axes.shape[0], axes.shape[1], points.shape[1]
    out = np.empty((n, m, 6))
    centre = np.empty(3)
    for i in range(n):
        for c in range(3):
            total = 0.0
            for j in range(joints):
                total += points[i, j, c]
            centre[c] = total / joints
        spread = 0.0
        for j in range(joints):
            for c in range(3):
                spread += (points[i, j, c] - centre[c]) ** 2
        spread = np.sqrt(spread / joints)
        length = spread if spread > 0.0 else 1.0
        for k in range(m):
            a = axes[i, k]
            if slide[k]:
                for c in range(3):
                    out[i, k, c], out[i, k, 3 + c] = 0.0, a[c]
                continue
            p = anchors[i, k]
            r0, r1, r2 = p[0] - centre[0], p[1] - centre[1], p[2] - centre[2]
            out[i, k, 0], out[i, k, 1], out[i, k, 2] = a[0], a[1], a[2]
            out[i, k, 3] = (r1 * a[2] - r2 * a[1]) / length
            out[i, k, 4] = (r2 * a[0] - r0 * a[2]) / length
            out[i, k, 5] = (r0 * a[1] - r1 * a[0]) / length
    return out


def _condition(jac: np.ndarray) -> np.ndarray:
    """:math:`\\sigma_6 / \\sigma_1` ``(n,)`` of the columns ``jac`` ``(n, m, 6)``; NaN where one is not
    finite."""
    good = np.isfinite(jac).all(axis=(1, 2))
    out = np.full(jac.shape[0], np.nan)
    blocks = np.array_split(jac if good.all() else jac[good], threads())  # beside the kernel's: nogil
    out[good] = np.concatenate(list(side_pool().map(_condition_rows, blocks)))
    return out


def closure_condition(mechanism: LoopMechanism, pose: dict[str, np.ndarray]) -> np.ndarray:
    """The closure condition :math:`c` ``(n,)`` of ``mechanism`` at ``pose`` (module docstring): 1 for a
    well-conditioned closure, 0 at an assembly limit; NaN where a pose value is not finite."""
    return _condition(_columns(*freedom_twists(mechanism, pose)))


def drive_condition(mechanism: LoopMechanism, pose: dict[str, np.ndarray]) -> np.ndarray:
    """The closure condition with the drive's twist as one more column, :math:`c_d` ``(n,)`` (module
    docstring, "Joint locks"): the prescribed coordinates' unit twists, each times its rate per unit rate of
    the drive (a C joint's slide: the axial law's :math:`ds/d\\theta`)."""
    twists, points = coordinate_twists(mechanism, pose)
    prescribed = mechanism.prescribed
    solved = [twist for key, twist in twists.items() if key not in prescribed]
    x = np.asarray(pose[variable(*mechanism.driven_coordinate)], dtype=float)
    rates = drive_state(mechanism, x, np.ones_like(x), np.zeros_like(x)).rates
    cols = _columns([twists[key] for key in prescribed] + solved, points)
    drive = sum(rates[variable(*key)][:, None] * cols[:, i] for i, key in enumerate(prescribed))
    return _condition(np.concatenate([cols[:, len(prescribed):], drive[:, None]], axis=1))


@njit(cache=True, nogil=True, error_model="numpy", fastmath={"contract", "arcp"})
def _condition_rows(jac: np.ndarray) -> np.ndarray:
    """:math:`\\sqrt{\\lambda_{min} / \\lambda_{max}}` of each row's Gram matrix :math:`J J^T` ``(6, 6)``
    (its eigenvalues are :math:`\\sigma_k^2`), ``jac`` ``(n, m, 6)`` (the columns): the Gram matrix
    reduced to tridiagonal form (:func:`_tridiagonalize`), its eigenvalues by implicit QL
    (:func:`_ql_eigenvalues`), 1.1 us a row.  numpy's ``eigvalsh`` costs ~5 us a row in LAPACK's call
    overhead, more than the in-house engine's whole position; cyclic Jacobi rotations took 2.8 us.
    The squares keep :math:`c` to ~1e-8 absolute, far below the band."""
    n, m = jac.shape[0], jac.shape[1]
    out = np.empty(n)
    g, d, e, v, p = np.empty((6, 6)), np.empty(6), np.empty(6), np.empty(6), np.empty(6)
    for i in range(n):
        for r in range(6):
            for c in range(r, 6):
                total = 0.0
                for k in range(m):
                    total += jac[i, k, r] * jac[i, k, c]
                g[r, c] = total
                g[c, r] = total
        _tridiagonalize(g, d, e, v, p)
        _ql_eigenvalues(d, e)
        low, high = d[0], d[0]
        for r in range(1, 6):
            low, high = min(low, d[r]), max(high, d[r])
        out[i] = np.sqrt(max(low, 0.0) / high)
    return out


@njit(cache=True, inline="always", fastmath={"contract", "arcp"})
def _tridiagonalize(g: np.ndarray, d: np.ndarray, e: np.ndarray, v: np.ndarray, p: np.ndarray) -> None:
    """The symmetric ``g`` ``(k, k)`` (overwritten) reduced by Householder reflections to a tridiagonal
    matrix of the same eigenvalues (Golub & Van Loan, *Matrix Computations*, 4th ed., Algorithm 8.3.1):
    its diagonal into ``d`` ``(k,)``, its off-diagonal into ``e`` ``(k,)`` (``e[i]`` couples ``i`` and
    ``i + 1``; ``e[k - 1]`` = 0).  ``v``, ``p`` ``(k,)``: scratch."""
    k = g.shape[0]
    for c in range(k - 2):
        tail = 0.0  # the column below the subdiagonal: what the reflection zeroes
        for i in range(c + 2, k):
            tail += g[i, c] * g[i, c]
        x0 = g[c + 1, c]
        if tail == 0.0:
            e[c] = x0
            continue
        alpha = -np.sqrt(x0 * x0 + tail) if x0 >= 0.0 else np.sqrt(x0 * x0 + tail)
        for i in range(c + 1, k):
            v[i] = g[i, c]
        v[c + 1] -= alpha
        vv = v[c + 1] * v[c + 1] + tail
        vp = 0.0
        for i in range(c + 1, k):  # p = 2 A v / v.v, then p - (v.p / v.v) v: A - v p^T - p v^T = H A H
            s = 0.0
            for j in range(c + 1, k):
                s += g[i, j] * v[j]
            p[i] = 2.0 * s / vv
            vp += v[i] * p[i]
        for i in range(c + 1, k):
            p[i] -= vp / vv * v[i]
        for i in range(c + 1, k):
            for j in range(c + 1, k):
                g[i, j] -= v[i] * p[j] + p[i] * v[j]
        e[c] = alpha
    for i in range(k):
        d[i] = g[i, i]
    e[k - 2], e[k - 1] = g[k - 1, k - 2], 0.0


@njit(cache=True, inline="always", fastmath={"contract", "arcp"})
def _ql_eigenvalues(d: np.ndarray, e: np.ndarray) -> None:
    """The eigenvalues of the symmetric tridiagonal matrix of diagonal ``d`` and off-diagonal ``e``
    (:func:`_tridiagonalize`'s) into ``d``, unordered, by the implicit QL method with Wilkinson's shift
    (EISPACK's ``tql1``: Bowdler, Martin, Reinsch & Wilkinson, *Numer. Math.* 11, 1968); ``e`` is
    destroyed.  An off-diagonal below :data:`EPS` of its two diagonal neighbours splits the matrix."""
    k = d.shape[0]
    for lo in range(k):
        for _ in range(QL_ITERATIONS):
            hi = lo
            while hi < k - 1 and abs(e[hi]) > EPS * (abs(d[hi]) + abs(d[hi + 1])):
                hi += 1
            if hi == lo:
                break
            g = (d[lo + 1] - d[lo]) / (2.0 * e[lo])
            r = np.sqrt(g * g + 1.0)
            g = d[hi] - d[lo] + e[lo] / (g + (r if g >= 0.0 else -r))
            s, c, p, split = 1.0, 1.0, 0.0, False
            for i in range(hi - 1, lo - 1, -1):  # the plane rotations chase the bulge up to lo
                f, b = s * e[i], c * e[i]
                r = np.sqrt(f * f + g * g)
                e[i + 1] = r
                if r == 0.0:  # an off-diagonal underflowed: the matrix splits there
                    d[i + 1] -= p
                    e[hi], split = 0.0, True
                    break
                s, c = f / r, g / r
                g = d[i + 1] - p
                r = (d[i] - g) * s + 2.0 * c * b
                p = s * r
                d[i + 1] = g + p
                g = c * r - b
            if not split:
                d[lo] -= p
                e[lo], e[hi] = g, 0.0
