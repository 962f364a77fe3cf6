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

from dualmech.core.kernel.closure_nb import Work
from dualmech.core.kernel.dual_nb import INLINE
from dualmech.core.kernel.linalg_nb import factorize, solve_factored
from dualmech.core.kernel.loop_nb import FlatLoop, screw_matrix


@njit(**INLINE)
def _rhs(
    screws: np.ndarray,
    gauges: np.ndarray,
    lines: np.ndarray,
    gauge: np.ndarray,
    axes: np.ndarray,
    values: np.ndarray,
    unknown: np.ndarray,
    per_screw: np.ndarray,
    transport: np.ndarray,
    with_transport: bool,
    scale: float,
    err: np.ndarray,
) -> None:
    """``per_screw``: each screw's value (inputs' from ``values``, indexed like ``vals``, unknowns' from
    ``unknown``); ``err``: minus the known screws' motion and, ``with_transport``, the carried screws'
    terms, with the gauge rows (:func:`dualmech.core.rates.solve_rates`), the dual rows over ``scale``
    (1: exactly as summed)."""
    for j in range(screws.shape[0]):
        col = screws[j, 2]
        per_screw[j] = values[screws[j, 3]] if col < 0 else unknown[col]
    err[: 6 + gauges.size] = 0.0
    for j in range(screws.shape[0]):
        v = 0.0 if screws[j, 2] >= 0 else per_screw[j]  # the unknowns' part is on the left-hand side
        for i in range(3):
            err[i] -= lines[j, 0, i] * v + (transport[j, 0, i] if with_transport else 0.0)
            err[3 + i] -= lines[j, 1, i] * v + (transport[j, 1, i] if with_transport else 0.0)
        for g in range(gauges.size):
            err[6 + g] -= gauge[g, j] * v
            if with_transport and screws[j, 0] <= gauges[g]:
                err[6 + g] -= (
                    axes[g, 0] * transport[j, 0, 0]
                    + axes[g, 1] * transport[j, 0, 1]
                    + axes[g, 2] * transport[j, 0, 2]
                )
    for i in range(3, 6):
        err[i] /= scale


@njit(**INLINE)
def _transport(
    screws: np.ndarray, lines: np.ndarray, rates: np.ndarray, cum: np.ndarray, transport: np.ndarray
) -> None:
    """``transport[j]`` = :math:`\\hat V_{c(j)}\\times\\hat s_j \\dot q_j`, with ``cum`` ``(M + 1, 2, 3)`` the
    running sums of the screws' motions (:func:`dualmech.core.rates._transport`): a dual cross product."""
    cum[0] = 0.0
    for j in range(screws.shape[0]):
        for p in range(2):
            for i in range(3):
                cum[j + 1, p, i] = cum[j, p, i] + lines[j, p, i] * rates[j]
        a, r = cum[screws[j, 1]], rates[j]
        for i in range(3):
            i1, i2 = (i + 1) % 3, (i + 2) % 3
            b0i1, b0i2, b1i1, b1i2 = (
                lines[j, 0, i1] * r,
                lines[j, 0, i2] * r,
                lines[j, 1, i1] * r,
                lines[j, 1, i2] * r,
            )
            transport[j, 0, i] = a[0, i1] * b0i2 - a[0, i2] * b0i1
            transport[j, 1, i] = (a[0, i1] * b1i2 - a[0, i2] * b1i1) + (a[1, i1] * b0i2 - a[1, i2] * b0i1)


@njit(**INLINE)
def solve_rates(fl: FlatLoop, vdot: np.ndarray, vddot: np.ndarray, w: Work, factored: float = 0.0) -> None:
    """Rates and accelerations of the loop evaluated in ``w`` (closed), for input rates ``vdot``
    and accelerations ``vddot`` (indexed like ``vals``, parameters 0).  Fills ``w.q_dot``,
    ``w.q_ddot``, ``w.twists``, ``w.accels``.

    ``factored``: 0 to factor the screw matrix here; else the length scale of the LU factors that ``w.sq``,
    ``w.piv`` already hold at this point (the screw matrix with its dual rows over that scale, and
    ``w.gauge``, ``w.axes``, as :func:`~dualmech.core.kernel.continuation_nb.branch_sign` leaves them): the
    same equations with their dual rows over the scale, one factorization for the branch and the rates.
    """
    screws, gauges, lines, mat, gauge, axes, err = (
        fl.screws,
        fl.gauges,
        w.lines,
        w.mat,
        w.gauge,
        w.axes,
        w.err,
    )
    rate, acc, transport, q_dot, q_ddot = w.per_screw[0], w.per_screw[1], w.transport, w.q_dot, w.q_ddot
    rows = err[: 6 + gauges.size]
    lu, scale = True, factored
    if factored == 0.0:
        screw_matrix(fl, w.frames, lines, 1.0, mat, gauge, axes)
        lu, scale = factorize(mat, w.sq, w.svd, w.piv), 1.0  # one for the rates and the accelerations
    _rhs(screws, gauges, lines, gauge, axes, vdot, q_dot, rate, transport, False, scale, err)
    solve_factored(mat, rows, q_dot, w.sq, w.rhs, w.svd, w.piv, lu)
    for j in range(screws.shape[0]):
        if screws[j, 2] >= 0:
            rate[j] = q_dot[screws[j, 2]]
    _transport(screws, lines, rate, w.cum, transport)
    _rhs(screws, gauges, lines, gauge, axes, vddot, q_ddot, acc, transport, True, scale, err)
    solve_factored(mat, rows, q_ddot, w.sq, w.rhs, w.svd, w.piv, lu)
    for j in range(screws.shape[0]):
        if screws[j, 2] >= 0:
            acc[j] = q_ddot[screws[j, 2]]
    twists, accels = w.twists, w.accels
    j = 0  # the screws come in row order: each row's twist is the previous row's plus its own screws'
    for i in range(twists.shape[0]):
        for p in range(2):
            for c in range(3):
                twists[i, p, c] = twists[i - 1, p, c] if i else 0.0
                accels[i, p, c] = accels[i - 1, p, c] if i else 0.0
        while j < screws.shape[0] and screws[j, 0] <= i:
            for p in range(2):
                for c in range(3):
                    twists[i, p, c] += lines[j, p, c] * rate[j]
                    accels[i, p, c] += lines[j, p, c] * acc[j] + transport[j, p, c]
            j += 1
