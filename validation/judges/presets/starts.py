"""The crude starts of the generated judges on the RSSR and RCCC, and the reach of each case's geometry.

A judge is started on the case's branch from a crude pose of this module's own (``docs/conventions.md``,
"Linkages: engines, bundled cases, the simulated judge"), never from the in-house solver's: the cut joint's
angle at a grid point of a scan (:data:`SCAN_POINTS` points a turn) next to the wanted root of the loop's
mismatch (:func:`scan_starts`; :func:`rssr_start_angles`, :func:`rccc_start_angles`), the other joints aimed
from it (:func:`rssr_start`, :func:`rccc_start`); :func:`with_start` puts such a pose into the case's joint
table.  Rows where the geometry does not reach (:func:`rssr_reach`, :func:`rccc_reach`) are
``no_assembly`` for every engine.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.spatial.transform import Rotation

from dualmech.models.linkages.rccc_case import RcccCase
from dualmech.models.linkages.readback import rccc_axes
from dualmech.models.linkages.rssr_case import RssrCase
from dualmech.models.loop.description import LoopMechanism
from dualmech.models.loop.presets import rows

#: Values of the scanned cut angle in a start (10 deg apart).
SCAN_POINTS = 36


def _rx(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _rz(angle: np.ndarray) -> np.ndarray:
    """``Rz(angle)`` ``(..., 3, 3)`` of angles ``(...)``."""
    c, s, z, o = np.cos(angle), np.sin(angle), np.zeros_like(angle), np.ones_like(angle)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2)


def scan_starts(mismatch: np.ndarray, slope: int) -> list[float]:
    """Start angles (rad) for a root of the periodic ``mismatch`` ``(m,)`` sampled at ``k 2 pi / m``: grid
    points, never roots, best first.

    The mismatch has two roots a turn (a circle meets a sphere, a cone meets a cone): the one where it
    changes sign as ``slope`` (``+1`` rising) is wanted.  A start is taken on the longer of the two arcs
    between the roots, next to the root, so that Newton meets that root first, not the other one across
    the shorter arc (which near the assembly limit may be narrower than the grid step): of a bracket (two
    neighbours, cyclically, of opposite signs) the end with the sign most grid points have; with no sign
    change on the grid (both roots between two neighbours), the neighbour of the point of the smallest
    ``|mismatch|`` on the wanted root's outer side.  Order: the wanted root's start, then the other
    root's, then the ends on the shorter arc.
    """
    m = mismatch.shape[0]
    grid = 2.0 * np.pi * np.arange(m) / m
    below = mismatch < 0.0
    after = np.roll(below, -1)
    rising, falling = np.flatnonzero(below & ~after), np.flatnonzero(~below & after)
    if rising.size + falling.size == 0:
        i = int(np.argmin(np.abs(mismatch)))
        side = slope if mismatch[i] >= 0.0 else -slope
        return [float(grid[(i + side) % m]), float(grid[(i - side) % m])]
    negative_longer = 2 * int(below.sum()) >= m  # a rising bracket's outer end: its low one, if so
    pairs = [(rising, True), (falling, False)][::1 if slope > 0 else -1]
    order = [(int(lo) + int(up != negative_longer)) % m for brackets, up in pairs for lo in brackets]
    order += [(int(lo) + k) % m for lo in np.concatenate([rising, falling]) for k in (0, 1)]
    return [float(grid[i]) for i in dict.fromkeys(order)]


def rssr_start_angles(case: RssrCase, theta1: float) -> list[float]:
    """Joint 4's angles ``theta4 = pi - phi4`` (rad) to start the judge at the crank angle ``theta1`` (rad)
    on the case's branch, best first (:func:`scan_starts`): grid points next to the root of ``|P3(phi4) -
    P2|^2 - a2^2`` whose slope has the sign ``branch`` (the slope is ``2 a2 a3 t4``)."""
    g = case.geometry
    p2 = np.array([g.a1 * np.cos(theta1), g.a1 * np.sin(theta1), g.s1])
    phi = 2.0 * np.pi * np.arange(SCAN_POINTS) / SCAN_POINTS
    p3 = g.foot + g.a3 * np.stack([np.cos(phi), np.sin(phi), np.zeros_like(phi)], 1) @ g.ground_rotation().T
    return [np.pi - phi for phi in scan_starts(np.sum((p3 - p2) ** 2, axis=1) - g.a2**2, case.branch)]


def rccc_start_angles(case: RcccCase, theta1: float) -> list[float]:
    """Joint 4's angles (rad) to start the judge at the crank angle ``theta1`` (rad) on the case's branch,
    best first (:func:`scan_starts`): grid points next to the root of ``z3(theta4)·z2 - cos alpha23``
    (``z3`` from the ground through joint 4 and row 3, ``z2`` the input pose's) whose slope has the sign
    ``branch`` (the slope is ``det[z2, z3, z4]``)."""
    alpha = case.geometry.alpha
    z2, _, _ = rccc_axes(case, np.array([theta1]), np.zeros(1))
    theta4 = 2.0 * np.pi * np.arange(SCAN_POINTS) / SCAN_POINTS
    z3 = (_rx(-alpha[3]) @ _rz(-theta4) @ _rx(-alpha[2]))[..., 2]
    return scan_starts(z3 @ z2[0] - np.cos(alpha[1]), case.branch)


def _rotvec(rot: np.ndarray) -> tuple[float, float, float]:
    """The rotation vector (rad) of a rotation matrix ``(3, 3)``."""
    return tuple(Rotation.from_matrix(rot).as_rotvec().tolist())


def rssr_start(case: RssrCase, theta1: float, theta4: float) -> tuple:
    """Every joint's start at the crank angle ``theta1`` (rad; a crude pose of this module's own): joint 4's
    angle ``theta4`` (:func:`rssr_start_angles`), the coupler aimed from ``P2`` at that output pin (its spin
    any), ball 3 the rotation left to close the loop's axes (``docs/conventions.md``, "Loop tables")."""
    g = case.geometry
    p2 = np.array([g.a1 * np.cos(theta1), g.a1 * np.sin(theta1), g.s1])
    p3 = g.foot + g.ground_rotation() @ (g.a3 * np.array([-np.cos(theta4), np.sin(theta4), 0.0]))
    u = (p3 - p2) / np.linalg.norm(p3 - p2)
    v = np.cross([0.0, 0.0, 1.0] if abs(u[2]) < 0.9 else [1.0, 0.0, 0.0], u)
    v /= np.linalg.norm(v)
    coupler = np.column_stack([u, v, np.cross(u, v)])
    output = (_rz(np.array(theta4)) @ _rx(g.alpha4)).T  # link 3's frame: row 4 closes onto the world
    return (), _rotvec(_rz(np.array(theta1)).T @ coupler), _rotvec(coupler.T @ output), (theta4,)


def rccc_start(case: RcccCase, theta1: float, theta4: float) -> tuple:
    """Every joint's start at the crank angle ``theta1`` (rad; a crude pose of this module's own): joint
    4's angle ``theta4`` (:func:`rccc_start_angles`), joint 2's turning ``z3`` nearest to the ``z3`` that
    joint 4 and row 3 give from the ground, joint 3's turning the coupler's frame nearest to link 3's; then
    the slides that close the loop's translation at those angles (it is linear in them: ``s2 z2 + s3 z3 +
    s4 z4 = -(s1 z1 + sum a_i x_i)``, least squares)."""
    g = case.geometry
    alpha, a = g.alpha, g.a
    link3 = _rx(-alpha[3]) @ _rz(np.array(-theta4))  # frame {4} from the ground's side
    z3 = link3 @ _rx(-alpha[2])[:, 2]
    frame2 = _rz(np.array(theta1)) @ _rx(alpha[0])
    z2 = frame2[:, 2]
    now = frame2 @ _rx(alpha[1])[:, 2]  # z3 at theta2 = 0
    theta2 = float(np.arctan2(z2 @ np.cross(now, z3), now @ z3 - (z2 @ now) * (z2 @ z3)))
    turn = (frame2 @ _rz(np.array(theta2)) @ _rx(alpha[1])).T @ link3 @ _rx(-alpha[2])
    theta3 = float(np.arctan2(turn[1, 0], turn[0, 0]))
    frame, axes, rest = np.eye(3), [], np.zeros(3)
    for i, theta in enumerate((theta1, theta2, theta3, theta4)):
        turned = frame @ _rz(np.array(theta))
        axes.append(frame[:, 2])
        rest += a[i] * turned[:, 0]
        frame = turned @ _rx(alpha[i])
    rest += g.s1 * axes[0]
    slides = np.linalg.lstsq(np.column_stack(axes[1:]), -rest, rcond=None)[0]
    return (), (theta2, float(slides[0])), (theta3, float(slides[1])), (theta4, float(slides[2]))


def rssr_reach(case: RssrCase, theta1: np.ndarray) -> np.ndarray:
    """The RSSR's reach ratio ``(n,)`` at the crank angles ``theta1`` ``(n,)`` (rad): ``|P3(phi) - P2|^2 = K
    + A cos phi + B sin phi`` on the output pin's circle, ``rho = (a2^2 - K) / sqrt(A^2 + B^2)``; the coupler
    reaches the circle iff ``|rho| <= 1``."""
    g = case.geometry
    p2 = np.stack([g.a1 * np.cos(theta1), g.a1 * np.sin(theta1), np.full_like(theta1, g.s1)], 1)
    centre = g.foot[None] - p2
    x, y = g.ground_rotation()[:, 0], g.ground_rotation()[:, 1]
    k = np.sum(centre**2, axis=1) + g.a3**2
    return (g.a2**2 - k) / (2.0 * g.a3 * np.hypot(centre @ x, centre @ y))


def rccc_reach(case: RcccCase, theta1: np.ndarray) -> np.ndarray:
    """The RCCC's reach ``(n,)`` at the crank angles ``theta1`` ``(n,)`` (rad): ``z3`` on the cones
    ``z3·z2 = cos alpha23`` and ``z3·z4 = cos alpha34`` is ``a z2 + b z4 + c z2 x z4``; ``rho = |a z2 + b
    z4|^2`` (``> 1``: the cones miss)."""
    alpha = case.geometry.alpha
    z2, _, z4 = rccc_axes(case, theta1, np.zeros_like(theta1))
    c23, c34, g = np.cos(alpha[1]), np.cos(alpha[2]), z2 @ z4
    return (c23**2 + c34**2 - 2.0 * g * c23 * c34) / (1.0 - g**2)


def with_start(mechanism: LoopMechanism, starts: tuple, k: int = 0, stop: int | None = None) -> LoopMechanism:
    """``mechanism`` driven at its positions ``k`` to ``stop`` (exclusive; ``None``: the last), every joint
    started at ``starts`` (one tuple per joint, as :func:`rssr_start` and :func:`rccc_start` give them)."""
    return replace(rows(mechanism, k, stop), joints=tuple(replace(j, start=s) for j, s in
                                                          zip(mechanism.joints, starts)))
