"""A universal joint between a spinning link and a translating one, compiled: the spin it determines.

The per-position twin of :mod:`dualmech.core.universal` (its module docstring has the equations):
the link's zero-spin twist and its rate gain the spin :math:`s` about the link's line and its rate.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from dualmech.core.kernel.dual_nb import JIT, cross, dot


@njit(**JIT)
def universal_motion(
    twist: np.ndarray,
    accel: np.ndarray,
    p2: np.ndarray,
    p3: np.ndarray,
    k4: np.ndarray,
    rot: np.ndarray,
    axis: np.ndarray,
    v: np.ndarray,
) -> None:
    """A link's twist ``(2, 3)`` and its rate, in place, with the spin of a universal joint at ``p3``
    whose other axis is the fixed ``k4`` (:func:`dualmech.core.universal.universal_motion`, with ``p2``
    the link's other end); the link's axes ``(u, a, u x a)`` into ``rot``, the moment axis ``n`` into
    ``axis``; ``v`` ``(7, 3)`` scratch."""
    u, a, vp, ud, om, t, nd = v[0], v[1], v[2], v[3], v[4], v[5], v[6]
    a2 = math.sqrt((p3[0] - p2[0]) ** 2 + (p3[1] - p2[1]) ** 2 + (p3[2] - p2[2]) ** 2)
    for i in range(3):
        u[i] = (p3[i] - p2[i]) / a2
    cross(u, k4, a)
    size = math.sqrt(dot(a, a))
    for i in range(3):
        a[i] /= size
    cross(a, k4, axis)
    cross(twist[0], p2, t)
    for i in range(3):
        vp[i] = twist[1, i] + t[i]
    cross(twist[0], u, ud)
    n_u = dot(axis, u)
    s = -dot(axis, twist[0]) / n_u
    for i in range(3):
        om[i] = twist[0, i] + s * u[i]
    cross(om, a, t)
    cross(t, k4, nd)
    sd = -(dot(nd, om) + dot(axis, accel[0]) + s * dot(axis, ud)) / n_u
    cross(p2, u, t)  # the rod's line: u + eps p2 x u
    for i in range(3):
        twist[0, i] = om[i]
        twist[1, i] += s * t[i]
        accel[0, i] += sd * u[i] + s * ud[i]
        accel[1, i] += sd * t[i]
    cross(vp, u, t)  # the line's rate: ud + eps (vp x u + p2 x ud)
    for i in range(3):
        accel[1, i] += s * t[i]
    cross(p2, ud, t)
    for i in range(3):
        accel[1, i] += s * t[i]
    cross(u, a, t)
    for i in range(3):
        rot[i, 0], rot[i, 1], rot[i, 2] = u[i], a[i], t[i]
