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
"""

from __future__ import annotations

import numpy as np

from dualmech.models.loop.description import LoopMechanism


def _rotation(axis: int, angle: np.ndarray) -> np.ndarray:
    """Rotations ``(n, 3, 3)`` by ``angle`` ``(n,)`` about axis 0 (x), 1 (y) or 2 (z)."""
    c, s = np.cos(angle), np.sin(angle)
    i, j = [k for k in range(3) if k != axis]
    out = np.zeros(angle.shape + (3, 3))
    out[:, axis, axis] = 1.0
    out[:, i, i], out[:, j, j], out[:, j, i], out[:, i, j] = c, c, s, -s
    return out


def _motion(axis: int, angle: np.ndarray, slide: np.ndarray) -> np.ndarray:
    """Homogeneous transforms ``(n, 4, 4)``: a turn by ``angle`` about ``axis`` and a slide by ``slide``
    along it."""
    out = np.zeros(angle.shape + (4, 4))
    out[:, :3, :3] = _rotation(axis, angle)
    out[:, axis, 3] = slide
    out[:, 3, 3] = 1.0
    return out


def _value(pose: dict[str, np.ndarray], name: str, constant: float, n: int) -> np.ndarray:
    return np.asarray(pose[name], dtype=float) if name in pose else np.full(n, constant)


def row_motions(mechanism: LoopMechanism, pose: dict[str, np.ndarray], k: int, n: int
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Row ``k``'s (not spherical) ``Z(theta + eps s)``, ``Y(eta)`` and ``X(alpha + eps a)``, each
    ``(n, 4, 4)``, from ``pose`` (the table's coordinate columns ``theta<i>``, ``s<i>``, ``eta<i>``)."""
    j = mechanism.joints[k]
    theta = _value(pose, f"theta{k + 1}", j.theta, n)
    s = _value(pose, f"s{k + 1}", j.s, n)
    eta = _value(pose, f"eta{k + 1}", 0.0, n)
    return (_motion(2, theta, s), _motion(1, eta, np.zeros(n)),
            _motion(0, np.full(n, j.alpha), np.full(n, j.a)))


def joint_frames(mechanism: LoopMechanism, pose: dict[str, np.ndarray]) -> list[np.ndarray | None]:
    """Each row's frame before its motion ``(n, 4, 4)`` (world), from the ground forward up to the first
    spherical joint and backward from the loop's end down past the last (module docstring); of a
    spherical joint only the origin (its centre) is meant; ``None`` for a row between two spherical
    joints."""
    n = np.asarray(next(iter(pose.values()))).shape[0]
    joints = mechanism.joints
    balls = [k for k, j in enumerate(joints) if j.type == "S"]
    first, last = (balls[0], balls[-1]) if balls else (len(joints), len(joints))
    frames: list[np.ndarray | None] = [None] * len(joints)
    frame = np.broadcast_to(np.eye(4), (n, 4, 4)).copy()
    for k in range(min(first + 1, len(joints))):
        frames[k] = frame
        if k < first:
            z, y, x = row_motions(mechanism, pose, k, n)
            frame = frame @ z @ y @ x
    if balls:
        after = np.broadcast_to(np.eye(4), (n, 4, 4)).copy()  # the frame after the last row: the world
        for k in range(len(joints) - 1, last - 1, -1):
            if joints[k].type == "S":  # its centre: the next frame moved back along x by its link's length
                frames[k] = after @ _motion(0, np.zeros(n), np.full(n, -joints[k].a))  # (twist: moves none)
                break
            z, y, x = row_motions(mechanism, pose, k, n)
            after = after @ np.linalg.inv(z @ y @ x)
            frames[k] = after
    return frames


def freedom_twists(mechanism: LoopMechanism, pose: dict[str, np.ndarray]
                   ) -> tuple[list[tuple[np.ndarray, np.ndarray | None]], np.ndarray]:
    """The solved freedoms' ``(axis, point)`` pairs, each ``(n, 3)`` world (``point`` ``None``: a slide),
    and every joint's point ``(n, J, 3)`` (an S joint's centre; a U joint's where its two axes meet)."""
    frames = joint_frames(mechanism, pose)
    prescribed = set(mechanism.prescribed)
    n = np.asarray(next(iter(pose.values()))).shape[0]
    nan = np.full((n, 3), np.nan)
    twists, points = [], []
    for k, (joint, frame) in enumerate(zip(mechanism.joints, frames)):
        rot = frame[:, :3, :3] if frame is not None else np.full((n, 3, 3), np.nan)
        point = frame[:, :3, 3] if frame is not None else nan
        if joint.type == "S":
            twists += [(np.broadcast_to(np.eye(3)[i], (n, 3)), point) for i in range(3)]
            points.append(point)
            continue
        if joint.type == "U":  # the second axis is y after the first turn (and the offset s along z)
            point = point + _value(pose, f"s{k + 1}", joint.s, n)[:, None] * rot[:, :, 2]
            turned = rot @ row_motions(mechanism, pose, k, n)[0][:, :3, :3]
            if (k, "eta") not in prescribed:
                twists.append((turned[:, :, 1], point))
        if joint.type in ("R", "C", "U") and (k, "theta") not in prescribed:
            twists.append((rot[:, :, 2], point))
        if joint.type in ("P", "C") and (k, "s") not in prescribed:
            twists.append((rot[:, :, 2], None))
        points.append(point)
    return twists, np.stack(points, axis=1)


def closure_condition(mechanism: LoopMechanism, pose: dict[str, np.ndarray]) -> np.ndarray:
    """The closure condition :math:`c` ``(n,)`` of ``mechanism`` at ``pose`` (module docstring): 1 for a
    well-conditioned closure, 0 at an assembly limit; NaN where a pose value is not finite."""
    twists, points = freedom_twists(mechanism, pose)
    centre = points.mean(axis=1)
    spread = np.sqrt(np.mean(np.sum((points - centre[:, None]) ** 2, axis=2), axis=1))
    length = np.where(spread > 0.0, spread, 1.0)[:, None]
    columns = []
    for axis, point in twists:
        if point is None:
            columns.append(np.concatenate([np.zeros_like(axis), axis], axis=1))
        else:
            columns.append(np.concatenate([axis, np.cross(point - centre, axis) / length], axis=1))
    jac = np.stack(columns, axis=2)
    good = np.isfinite(jac).all(axis=(1, 2))
    out = np.full(jac.shape[0], np.nan)
    if good.any():
        sigma = np.linalg.svd(jac[good], compute_uv=False)
        out[good] = sigma[:, 5] / sigma[:, 0]
    return out
