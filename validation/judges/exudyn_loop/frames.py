"""The loop table's frames in plain numpy: the judge's own forward kinematics of the open chain, and each
joint's coordinates, rates and accelerations read back from the two frames it relates.

Homogeneous transforms ``T`` (4 x 4).  Row ``k`` (0-based) of the table is
:math:`Z(\\theta_k + \\varepsilon s_k)\\,Y(\\eta_k)\\,X(\\alpha_k + \\varepsilon a_k)`, frame ``{0}`` the
world.
Joint ``k`` relates its **joint frame** :math:`G_k = \\{k\\}\\,C_k` on link ``k-1`` (``C_k`` the constant part
of its motion placed before its variables: ``Tz(s)`` for R and U, ``Rz(theta)`` for P) to the **link frame**
:math:`F_k = G_k\\,M_k(q_k)` of link ``k`` (``M_k``: ``Rz(theta)`` R, ``Tz(s)`` P, ``Rz(theta) Tz(s)`` C,
``Rz(theta) Ry(eta)`` U, a free rotation S), and :math:`\\{k+1\\} = F_k\\,X(\\alpha_k, a_k)`.  The loop closes
when :math:`\\{n\\} = I` (the last joint's link frame is the ground's, :math:`B = X(\\alpha_{n-1},
a_{n-1})^{-1}`).
"""

from __future__ import annotations

import math

import numpy as np

from dualmech.models.loop.description import LoopMechanism

#: Each joint type's scalar coordinates (an S joint has a rotation matrix instead).
COORDINATES: dict[str, tuple[str, ...]] = {"R": ("theta",), "P": ("s",), "C": ("theta", "s"),
                                           "U": ("theta", "eta"), "S": ()}


def rot(axis: int, angle: float) -> np.ndarray:
    """The rotation by ``angle`` (rad) about axis ``axis`` (0 x, 1 y, 2 z), ``(3, 3)``: Rodrigues'
    :math:`I + \\sin\\varphi\\,K + (1 - \\cos\\varphi)\\,K^2`, ``K`` the axis's cross-product matrix."""
    k = np.cross(np.eye(3)[axis], -np.eye(3))
    return np.eye(3) + math.sin(angle) * k + (1.0 - math.cos(angle)) * (k @ k)


def transform(rotation: np.ndarray | None = None, translation: np.ndarray | None = None) -> np.ndarray:
    """The homogeneous transform of ``rotation`` (default identity) and ``translation`` (default 0)."""
    t = np.eye(4)
    if rotation is not None:
        t[:3, :3] = rotation
    if translation is not None:
        t[:3, 3] = translation
    return t


def inverse(t: np.ndarray) -> np.ndarray:
    """:math:`T^{-1}` of a rigid transform."""
    return transform(t[:3, :3].T, -t[:3, :3].T @ t[:3, 3])


def link_step(alpha: float, a: float) -> np.ndarray:
    """:math:`X(\\alpha + \\varepsilon a)`: a slide ``a`` along x and a turn ``alpha`` about it."""
    return transform(rot(0, alpha), np.array([a, 0.0, 0.0]))


def constant_part(kind: str, theta: float, s: float) -> np.ndarray:
    """:math:`C_k`, the constant part of a joint's motion before its variables (module docstring)."""
    if kind in ("R", "U"):
        return transform(translation=np.array([0.0, 0.0, s]))
    if kind == "P":
        return transform(rot(2, theta))
    return np.eye(4)


def joint_motion(kind: str, values: dict[str, float], rotation: np.ndarray | None = None) -> np.ndarray:
    """:math:`M_k`, a joint's motion of its variables (``values`` by name; an S joint's ``rotation``)."""
    if kind == "S":
        return transform(rotation)
    turn = rot(2, values.get("theta", 0.0)) @ rot(1, values.get("eta", 0.0))
    return transform(turn, np.array([0.0, 0.0, values.get("s", 0.0)]))


def ground_frame(mechanism: LoopMechanism) -> np.ndarray:
    """:math:`B`, the ground's link frame at the last joint (module docstring)."""
    last = mechanism.joints[-1]
    return inverse(link_step(last.alpha, last.a))


def chain(mechanism: LoopMechanism, values: dict[tuple[int, str], float],
          rotations: dict[int, np.ndarray]) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """The joint frames :math:`G_k` and link frames :math:`F_k` (world) of every joint ``k = 0 .. n-1`` at
    the coordinates ``values`` (``(joint, name) -> value``) and S rotations ``rotations`` (joint -> R);
    ``F_{n-1}`` is where the chain puts the ground, :math:`B` when the loop is closed."""
    frame = np.eye(4)
    joint_frames, link_frames = [], []
    for k, joint in enumerate(mechanism.joints):
        g = frame @ constant_part(joint.type, joint.theta, joint.s)
        own = {name: values[(k, name)] for name in COORDINATES[joint.type]}
        f = g @ joint_motion(joint.type, own, rotations.get(k))
        joint_frames.append(g)
        link_frames.append(f)
        frame = f @ link_step(joint.alpha, joint.a)
    return joint_frames, link_frames


def joint_point(kind: str, s: float, joint_frame: np.ndarray) -> np.ndarray:
    """A joint's point (the moments' reference): the origin of frame ``{k}``, a U joint's moved by ``s``
    to where its axes meet; from its joint frame :math:`G_k` (which an R joint's ``s`` moved along z)."""
    back = s if kind == "R" else 0.0
    return joint_frame[:3, 3] - back * joint_frame[:3, 2]


def relative_coordinates(kind: str, relative: np.ndarray) -> dict[str, float]:
    """Joint coordinates from :math:`G^{-1}F` (``relative``): an angle about z by ``atan2``, a slide along
    z, a U joint's :math:`R_z(\\theta)R_y(\\eta)` split (angles in (-pi, pi])."""
    r, p = relative[:3, :3], relative[:3, 3]
    out = {}
    if kind in ("R", "C"):
        out["theta"] = math.atan2(r[1, 0], r[0, 0])
    if kind in ("P", "C"):
        out["s"] = float(p[2])
    if kind == "U":
        out["theta"] = math.atan2(-r[0, 1], r[1, 1])
        out["eta"] = math.atan2(-r[2, 0], r[2, 2])
    return out


def relative_rates(kind: str, relative: np.ndarray, omega: np.ndarray, omega_dot: np.ndarray,
                   velocity: np.ndarray, accel: np.ndarray) -> dict[str, tuple[float, float]]:
    """Each coordinate's rate and acceleration from the relative motion in joint-frame axes:
    :math:`\\omega = R_G^T(\\omega_F - \\omega_G)`, its derivative
    :math:`\\dot\\omega = R_G^T(\\dot\\omega_F - \\dot\\omega_G
    - \\omega_G\\times(\\omega_F - \\omega_G))`, and
    the same of the origins' relative position (``velocity``, ``accel``).  A U joint's
    :math:`\\omega = \\dot\\theta e_z + \\dot\\eta(-\\sin\\theta, \\cos\\theta, 0)`, so
    :math:`\\dot\\eta = -\\omega_x\\sin\\theta + \\omega_y\\cos\\theta` and
    :math:`\\ddot\\eta = -\\dot\\omega_x\\sin\\theta + \\dot\\omega_y\\cos\\theta
    - \\dot\\theta(\\omega_x\\cos\\theta + \\omega_y\\sin\\theta)`."""
    out = {}
    if kind in ("R", "C"):
        out["theta"] = (float(omega[2]), float(omega_dot[2]))
    if kind in ("P", "C"):
        out["s"] = (float(velocity[2]), float(accel[2]))
    if kind == "U":
        theta = relative_coordinates(kind, relative)["theta"]
        c, s = math.cos(theta), math.sin(theta)
        theta_dot = float(omega[2])
        out["theta"] = (theta_dot, float(omega_dot[2]))
        out["eta"] = (float(-omega[0] * s + omega[1] * c),
                      float(-omega_dot[0] * s + omega_dot[1] * c - theta_dot * (omega[0] * c + omega[1] * s)))
    return out


