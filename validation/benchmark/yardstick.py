"""A compiled closed-form slider crank: the speed yardstick of the benchmark, never an engine.

Per position, in closed form (``docs/conventions.md``): ``S4`` from the sphere-line
intersection on the conventions' branch, its rates by differentiating
:math:`|P_3 - P_2|^2 = a_2^2`, the rod's zero-spin angular velocity
:math:`\\omega = u\\times\\dot u` and acceleration :math:`u\\times\\ddot u`, then the same
dual-momentum and elimination steps as the kernel
(:func:`~dualmech.core.kernel.dynamics_nb.required_wrench`,
:func:`~dualmech.models.slider_crank.position_nb._reactions`).  No loop closure, no
statuses: what this mechanism costs at the least on this machine, for the same
outputs (``S4``, its two rates and the 20 reaction columns).  Valid only where the
loop assembles away from its edge.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from dualmech.core.kernel.dual_nb import ALLOC, JIT
from dualmech.core.kernel.dynamics_nb import required_wrench
from dualmech.core.table import REACTION_COLUMNS
from dualmech.models.slider_crank.position_nb import _reactions

#: The yardstick's outputs, in order: the slider's motion and every reaction column of a ball-ball rod.
YARDSTICK_COLUMNS: tuple[str, ...] = ("S4", "S4_dot", "S4_ddot") + REACTION_COLUMNS


@njit(**JIT)
def _position(
    i: int,
    crank: np.ndarray,
    geo: np.ndarray,
    mass: np.ndarray,
    com: np.ndarray,
    inertia: np.ndarray,
    gravity: np.ndarray,
    torque: float,
    load: float,
    v: np.ndarray,
    m: np.ndarray,
    rot: np.ndarray,
    out: np.ndarray,
) -> None:
    th, s1, thd = crank[0, i], crank[1, i], crank[2, i]
    s1d, thdd, s1dd = crank[3, i], crank[4, i], crank[5, i]
    a1, a2, a4, al4 = geo[0], geo[1], geo[2], geo[3]
    c, s = math.cos(th), math.sin(th)
    k4, p2, p2d, p2dd, p3 = v[0], v[1], v[2], v[3], v[4]
    k4[0], k4[1], k4[2] = 0.0, math.sin(al4), math.cos(al4)
    p2[0], p2[1], p2[2] = a1 * c, a1 * s, s1
    p2d[0], p2d[1], p2d[2] = -a1 * s * thd, a1 * c * thd, s1d
    p2dd[0], p2dd[1], p2dd[2] = -a1 * c * thd**2 - a1 * s * thdd, -a1 * s * thd**2 + a1 * c * thdd, s1dd
    d0, d1, d2 = p2[0] + a4, p2[1], p2[2]
    kd = d1 * k4[1] + d2 * k4[2]
    s4 = -kd + math.sqrt(kd * kd - (d0 * d0 + d1 * d1 + d2 * d2) + a2 * a2)
    r = (-a4 - p2[0], -s4 * k4[1] - p2[1], -s4 * k4[2] - p2[2])
    rk = r[1] * k4[1] + r[2] * k4[2]
    s4d = -(r[0] * p2d[0] + r[1] * p2d[1] + r[2] * p2d[2]) / rk
    rd = (-p2d[0], -s4d * k4[1] - p2d[1], -s4d * k4[2] - p2d[2])
    s4dd = (rd[0] ** 2 + rd[1] ** 2 + rd[2] ** 2 - (r[0] * p2dd[0] + r[1] * p2dd[1] + r[2] * p2dd[2])) / rk
    rdd = (-p2dd[0], -s4dd * k4[1] - p2dd[1], -s4dd * k4[2] - p2dd[2])
    for k in range(3):
        p3[k] = p2[k] + r[k]
    out[0], out[1], out[2] = s4, s4d, s4dd
    # twists w + eps v_O and their rates: crank, rod (zero spin), slider
    tw, ac = m[0], m[1]
    tw[:], ac[:] = 0.0, 0.0
    tw[0, 0, 2], tw[0, 1, 2], ac[0, 0, 2], ac[0, 1, 2] = thd, s1d, thdd, s1dd  # about and along z, through O
    u = (r[0] / a2, r[1] / a2, r[2] / a2)
    ud = (rd[0] / a2, rd[1] / a2, rd[2] / a2)
    udd = (rdd[0] / a2, rdd[1] / a2, rdd[2] / a2)
    w = (u[1] * ud[2] - u[2] * ud[1], u[2] * ud[0] - u[0] * ud[2], u[0] * ud[1] - u[1] * ud[0])
    wd = (u[1] * udd[2] - u[2] * udd[1], u[2] * udd[0] - u[0] * udd[2], u[0] * udd[1] - u[1] * udd[0])
    for k in range(3):  # v_O = v_P2 - w x P2 (and its rate)
        k1, k2 = (k + 1) % 3, (k + 2) % 3
        tw[1, 0, k], ac[1, 0, k] = w[k], wd[k]
        tw[1, 1, k] = p2d[k] - (w[k1] * p2[k2] - w[k2] * p2[k1])
        ac[1, 1, k] = p2dd[k] - (wd[k1] * p2[k2] - wd[k2] * p2[k1]) - (w[k1] * p2d[k2] - w[k2] * p2d[k1])
        tw[2, 1, k], ac[2, 1, k] = -s4d * k4[k], -s4dd * k4[k]
    hub, need = v[5], m[2]
    _frames(c, s, s1, u, hub, rot)
    origins = (hub, p2, p3)
    for b in range(3):
        required_wrench(
            mass[b], com[b], inertia[b], rot[b], origins[b], tw[b], ac[b], gravity, v[8:16], need[b]
        )
    v[6] = 0.0  # joint 3 is a ball: no moment axis
    _reactions(need, p2, p3, k4, torque, load, v[6], v[16:32], out[3:26])


@njit(**JIT)
def _frames(c: float, s: float, s1: float, u: tuple, hub: np.ndarray, rot: np.ndarray) -> None:
    """Crank, rod (x along ``u``, zero spin) and slider axes into ``rot`` ``(3, 3, 3)``; the hub
    into ``hub``."""
    rot[0] = 0.0
    rot[0, 0, 0], rot[0, 0, 1], rot[0, 1, 0], rot[0, 1, 1], rot[0, 2, 2] = c, -s, s, c, 1.0
    hub[0], hub[1], hub[2] = 0.0, 0.0, s1
    ref = (1.0, 0.0, 0.0) if abs(u[2]) > 0.9 else (0.0, 0.0, 1.0)
    y = (ref[1] * u[2] - ref[2] * u[1], ref[2] * u[0] - ref[0] * u[2], ref[0] * u[1] - ref[1] * u[0])
    n = math.sqrt(y[0] ** 2 + y[1] ** 2 + y[2] ** 2)
    y = (y[0] / n, y[1] / n, y[2] / n)
    z = (u[1] * y[2] - u[2] * y[1], u[2] * y[0] - u[0] * y[2], u[0] * y[1] - u[1] * y[0])
    rot[2] = 0.0
    for k in range(3):
        rot[1, k, 0], rot[1, k, 1], rot[1, k, 2] = u[k], y[k], z[k]
        rot[2, k, k] = 1.0


@njit(**ALLOC)  # allocates its scratch once per range
def closed_form_range(
    lo: int,
    hi: int,
    crank: np.ndarray,
    geo: np.ndarray,
    mass: np.ndarray,
    com: np.ndarray,
    inertia: np.ndarray,
    gravity: np.ndarray,
    torque: float,
    load: float,
    out: np.ndarray,
) -> None:
    """Closed-form outputs of positions ``lo..hi-1`` of one case into ``out`` ``(26, n)``: S4, its two
    rates, the reaction columns of a ball-ball rod (:data:`YARDSTICK_COLUMNS`); ``crank`` ``(6, n)`` as in
    the kernel."""
    v, m, rot, row = np.zeros((32, 3)), np.zeros((3, 3, 2, 3)), np.zeros((3, 3, 3)), np.zeros(26)
    for i in range(lo, hi):
        _position(i, crank, geo, mass, com, inertia, gravity, torque, load, v, m, rot, row)
        for k in range(26):
            out[k, i] = row[k]
