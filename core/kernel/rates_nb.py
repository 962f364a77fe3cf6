"""Velocity and acceleration of a closed loop at one position, compiled (thesis section 2.7).

The per-position form of :func:`dualmech.core.rates.solve_rates`: the screws times
their rates sum to zero (eq. 29-37 in world coordinates), each carried screw turns
with the twist of the body that carries it (the Lie bracket of screws, replacing the
printed (38a)-(42a), errata E4-E5), and the spin gauge adds :math:`u\\cdot\\omega = 0`,
:math:`u\\cdot\\dot\\omega = 0`.  Results go into ``w.q_dot``, ``w.q_ddot``,
``w.twists`` and ``w.accels`` (one twist :math:`\\omega + \\varepsilon v_O` per table row).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from dualmech.core.kernel.closure_nb import Work, least_squares
from dualmech.core.kernel.dual_nb import JIT
from dualmech.core.kernel.loop_nb import FlatLoop, screw_matrix


@njit(**JIT)
def _known(fl: FlatLoop, values: np.ndarray, unknown: np.ndarray, out: np.ndarray) -> None:
    """Per-screw values: the inputs' from ``values`` (indexed like ``vals``), the unknowns' from ``unknown``."""
    for j in range(fl.screws.shape[0]):
        col = fl.screws[j, 2]
        out[j] = values[fl.screws[j, 3]] if col < 0 else unknown[col]


@njit(**JIT)
def _bracket(a: np.ndarray, b: np.ndarray, out: np.ndarray) -> None:
    """Dual cross product ``out = a x b`` of dual vectors ``(2, 3)`` (:func:`dualmech.core.dual.dcross`)."""
    for i in range(3):
        i1, i2 = (i + 1) % 3, (i + 2) % 3
        out[0, i] = a[0, i1] * b[0, i2] - a[0, i2] * b[0, i1]
        out[1, i] = (a[0, i1] * b[1, i2] - a[0, i2] * b[1, i1]) + (a[1, i1] * b[0, i2] - a[1, i2] * b[0, i1])


@njit(**JIT)
def _rhs(fl: FlatLoop, w: Work, values: np.ndarray, with_transport: bool) -> None:
    """``w.err``: minus the known screws' motion (and the carried screws' terms), gauge rows too."""
    rows = 6 + fl.gauges.size
    w.err[:rows] = 0.0
    for j in range(fl.screws.shape[0]):
        for i in range(3):
            w.err[i] -= w.lines[j, 0, i] * values[j]
            w.err[3 + i] -= w.lines[j, 1, i] * values[j]
            if with_transport:
                w.err[i] -= w.transport[j, 0, i]
                w.err[3 + i] -= w.transport[j, 1, i]
        for g in range(fl.gauges.size):
            w.err[6 + g] -= w.gauge[g, j] * values[j]
            if with_transport and fl.screws[j, 0] <= fl.gauges[g]:
                a = w.axes[g]
                w.err[6 + g] -= a[0] * w.transport[j, 0, 0] + a[1] * w.transport[j, 0, 1] + a[2] * w.transport[j, 0, 2]


@njit(**JIT)
def _transport(fl: FlatLoop, w: Work, rates: np.ndarray, motion: np.ndarray, cum: np.ndarray) -> None:
    """``w.transport[j]`` = :math:`\\hat V_{c(j)}\\times\\hat s_j \\dot q_j`, with ``cum`` ``(M + 1, 2, 3)`` the
    running sums of the screws' motions (:func:`dualmech.core.rates._transport`)."""
    cum[0] = 0.0
    for j in range(fl.screws.shape[0]):
        for p in range(2):
            for i in range(3):
                motion[p, i] = w.lines[j, p, i] * rates[j]
                cum[j + 1, p, i] = cum[j, p, i] + motion[p, i]
        _bracket(cum[fl.screws[j, 1]], motion, w.transport[j])


@njit(**JIT)
def solve_rates(fl: FlatLoop, vdot: np.ndarray, vddot: np.ndarray, w: Work) -> None:
    """Rates and accelerations of the loop evaluated in ``w`` (closed), for input rates ``vdot``
    and accelerations ``vddot`` (indexed like ``vals``, parameters 0).  Fills ``w.q_dot``, ``w.q_ddot``, ``w.twists``, ``w.accels``."""
    m = fl.screws.shape[0]
    screw_matrix(fl, w.frames, w.lines, 1.0, w.mat, w.gauge, w.axes)
    rate, acc = w.per_screw[0], w.per_screw[1]
    w.q_dot[:] = 0.0
    _known(fl, vdot, w.q_dot, rate)
    _rhs(fl, w, rate, False)
    least_squares(w.mat, w.err[:6 + fl.gauges.size], w.q_dot, w.sq, w.rhs)
    _known(fl, vdot, w.q_dot, rate)
    _transport(fl, w, rate, w.tmp[0, 0, :2], w.cum)
    w.q_ddot[:] = 0.0
    _known(fl, vddot, w.q_ddot, acc)
    _rhs(fl, w, acc, True)
    least_squares(w.mat, w.err[:6 + fl.gauges.size], w.q_ddot, w.sq, w.rhs)
    _known(fl, vddot, w.q_ddot, acc)
    w.twists[:] = 0.0
    w.accels[:] = 0.0
    for i in range(w.twists.shape[0]):
        for j in range(m):
            if fl.screws[j, 0] > i:
                continue
            for p in range(2):
                for c in range(3):
                    w.twists[i, p, c] += w.lines[j, p, c] * rate[j]
                    w.accels[i, p, c] += w.lines[j, p, c] * acc[j] + w.transport[j, p, c]
