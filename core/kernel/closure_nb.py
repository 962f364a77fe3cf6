"""Displacement analysis at one position, compiled: Newton with the screws, the DFP fallback.

The per-position form of :mod:`dualmech.core.closure` (same steps, same tolerances,
same decisions): Newton-Raphson on the loop-closure equation (thesis eq. 5) with the
screws as derivative operators (eq. 8-17) and the spin gauge, step halving,
stall and rounding tests; where Newton stalls, Davidon-Fletcher-Powell on
:math:`\\tfrac12\\|\\hat B - \\hat I\\|^2` from both the estimate and Newton's end point
(thesis section 2.6.1), Newton polishing near a root, and the verdict ``no_assembly``
at a non-zero stationary minimum.

Every function works on one position and writes into the scratch arrays of a
:class:`Work` (allocated once per thread by :func:`make_work`, outside compiled code: the kernel
runs without numba's runtime and allocates nothing, see :mod:`~dualmech.core.kernel.linalg_nb`).
The tolerances arrive as a :class:`ClosureTols` argument, read from
:mod:`dualmech.core.closure` at call time (their one home; constants frozen into
cached machine code would outlive an edit of that module).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from dualmech.core import closure
from dualmech.core.kernel.dual_nb import ALLOC, INLINE, JIT, copy, tmul, trodrigues
from dualmech.core.kernel.linalg_nb import least_squares
from dualmech.core.kernel.loop_nb import (
    FlatLoop,
    _same,
    closure_residual,
    evaluate,
    length_scale,
    screw_matrix,
    state_size,
)

#: Closure outcome codes (:class:`dualmech.core.closure.ClosureStatus`).
OK, NOT_CONVERGED, NO_ASSEMBLY = (
    int(closure.ClosureStatus.OK),
    int(closure.ClosureStatus.NOT_CONVERGED),
    int(closure.ClosureStatus.NO_ASSEMBLY),
)


class ClosureTols(NamedTuple):
    """The closure's tolerances and limits (names and reasons in :mod:`dualmech.core.closure`)."""

    closure: float
    rounding: float
    stationary: float
    near_root: float
    dfp_restart: int
    max_newton: int
    max_dfp: int


def closure_tols() -> ClosureTols:
    """The current values of :mod:`dualmech.core.closure`'s constants and ``solve_closure``'s limits."""
    return ClosureTols(
        closure.CLOSURE_TOL,
        closure.ROUNDING_TOL,
        closure.STATIONARY_COSINE,
        closure.NEAR_ROOT,
        closure.DFP_RESTART,
        30,
        200,
    )


class Work(NamedTuple):
    """Scratch arrays of one thread (``R`` rows, ``M`` screws, ``G`` gauges, ``K`` step, ``S`` state)."""

    frames: np.ndarray  # (R, 2, 3, 3)
    lines: np.ndarray  # (M, 2, 3)
    turns: np.ndarray  # (R, 3, 20): the last evaluation's joint factors (loop_nb.evaluate)
    mat: np.ndarray  # (6 + G, K)
    gauge: np.ndarray  # (G, M)
    axes: np.ndarray  # (G, 3)
    t33: np.ndarray  # (3, 3)
    v3: np.ndarray  # (3,)
    err: np.ndarray  # (max(6 + G, K),)
    sq: np.ndarray  # (K, K)
    rhs: np.ndarray  # (K,)
    step: np.ndarray  # (K,)
    base: np.ndarray  # (S,)
    guess: np.ndarray  # (S,)
    seen: np.ndarray  # (S,): the point Newton last evaluated (newton_held)
    runs: np.ndarray  # (3, S): two DFP runs and a polish
    trial: np.ndarray  # (S,)
    jac: np.ndarray  # (18 + G, K): DFP objective's Jacobian, with the gauge rows
    res18: np.ndarray  # (18,)
    grads: np.ndarray  # (4, K): gradient, trial gradient, search direction, scratch
    hess: np.ndarray  # (K, K): inverse-Hessian estimate
    q_dot: np.ndarray  # (K,) unknown rates
    q_ddot: np.ndarray  # (K,) unknown accelerations
    per_screw: np.ndarray  # (2, M): each screw's rate and acceleration
    transport: np.ndarray  # (M, 2, 3): the carried screws' terms
    cum: np.ndarray  # (M + 1, 2, 3): running sums of the screws' motions
    twists: np.ndarray  # (R, 2, 3): link twists
    accels: np.ndarray  # (R, 2, 3): link accelerations
    svd: np.ndarray  # (3, K, K): the pseudo-inverse's scratch (linalg_nb.factorize)
    piv: np.ndarray  # (K,) int: LU pivot rows (linalg_nb.factorize)


def make_work(fl: FlatLoop) -> Work:
    """Allocate a :class:`Work` for ``fl``."""
    return _make_work(fl, state_size(fl))


@njit(**ALLOC)
def _make_work(fl: FlatLoop, s: int) -> Work:
    r, m, g, k = fl.table.shape[0], fl.screws.shape[0], fl.gauges.size, fl.n_step
    return Work(
        np.zeros((r, 2, 3, 3)),
        np.zeros((m, 2, 3)),
        np.full((r, 3, 20), np.nan),
        np.zeros((6 + g, k)),
        np.zeros((g, m)),
        np.zeros((g, 3)),
        np.zeros((3, 3)),
        np.zeros(3),
        np.zeros(max(6 + g, k)),
        np.zeros((k, k)),
        np.zeros(k),
        np.zeros(k),
        np.zeros(s),
        np.zeros(s),
        np.zeros(s),
        np.zeros((3, s)),
        np.zeros(s),
        np.zeros((18 + g, k)),
        np.zeros(18),
        np.zeros((4, k)),
        np.zeros((k, k)),
        np.zeros(k),
        np.zeros(k),
        np.zeros((2, m)),
        np.zeros((m, 2, 3)),
        np.zeros((m + 1, 2, 3)),
        np.zeros((r, 2, 3)),
        np.zeros((r, 2, 3)),
        np.zeros((3, k, k)),
        np.zeros(k, dtype=np.int64),
    )


@njit(**INLINE)
def residual_at(fl: FlatLoop, vals: np.ndarray, x: np.ndarray, w: "Work") -> float:
    """Evaluate the loop at ``x`` (into ``w.frames``, ``w.lines``) and return its closure residual."""
    evaluate(fl, vals, x, w.frames, w.lines, w.turns)
    return closure_residual(w.frames, length_scale(fl, vals))


@njit(**JIT)
def retract(n_scalar: int, x: np.ndarray, step: np.ndarray, scale: float, out: np.ndarray) -> None:
    """``out`` = ``x`` moved by ``scale * step``: scalars add, rotations turn by Rodrigues
    (:meth:`dualmech.core.loop.LoopState.retract`); ``out`` may be ``x``."""
    for i in range(n_scalar):
        out[i] = x[i] + scale * step[i]
    for b in range((x.size - n_scalar) // 9):
        o, k = n_scalar + 9 * b, n_scalar + 3 * b
        r = trodrigues(scale * step[k], scale * step[k + 1], scale * step[k + 2])
        old = (x[o], x[o + 1], x[o + 2], x[o + 3], x[o + 4], x[o + 5], x[o + 6], x[o + 7], x[o + 8])
        new = tmul(r, old)
        for i in range(9):
            out[o + i] = new[i]


@njit(**INLINE)
def second_order_step(n_scalar: int, x: np.ndarray, q_dot: np.ndarray, q_ddot: np.ndarray, step: float,
                      bend: float, change: np.ndarray, out: np.ndarray) -> None:
    """``out`` = ``x`` moved ``step`` ahead in time to second order along a one-parameter motion: the change
    ``step (q_dot + step (q_ddot - q_dot bend) / 2)`` in tangent coordinates (``bend`` the drive's
    acceleration over its speed: the motion parameterized by the drive's value, ``x' = q_dot / d_dot``,
    ``x'' = (q_ddot - x' d_ddot) / d_dot^2``), applied by :func:`retract` (a ball's turn by the exponential
    map, second order too).  ``change`` ``(K,)``: scratch; ``out`` may be ``x``."""
    for k in range(change.size):
        change[k] = step * (q_dot[k] + 0.5 * step * (q_ddot[k] - q_dot[k] * bend))
    retract(n_scalar, x, change, 1.0, out)


@njit(**INLINE)
def newton_step(
    fl: FlatLoop,
    vals: np.ndarray,
    frames: np.ndarray,
    lines: np.ndarray,
    mat: np.ndarray,
    gauge: np.ndarray,
    axes: np.ndarray,
    err: np.ndarray,
    sq: np.ndarray,
    rhs: np.ndarray,
    svd: np.ndarray,
    piv: np.ndarray,
    step: np.ndarray,
) -> bool:
    """``step``: screws times step = minus the closure error, with the spin gauge (eq. 11, 23a); whether
    ``sq``, ``piv`` then hold the LU factors of the screw matrix ``mat`` (:func:`~dualmech.core.kernel.
    linalg_nb.least_squares`).

    The loop must have been evaluated at the current point (into ``frames``, ``lines``); the
    other arrays are the scratch of a :class:`Work` of the same names.
    The closure error is the skew part of :math:`\\hat B`, the dual part over the length
    scale (:func:`dualmech.core.loop.closure_error`).
    """
    scale = length_scale(fl, vals)
    screw_matrix(fl, frames, lines, scale, mat, gauge, axes)
    last = frames.shape[0] - 1
    for p in range(2):
        b = frames[last, p]
        div = -1.0 if p == 0 else -scale
        err[3 * p], err[3 * p + 1], err[3 * p + 2] = (
            0.5 * (b[2, 1] - b[1, 2]) / div,
            0.5 * (b[0, 2] - b[2, 0]) / div,
            0.5 * (b[1, 0] - b[0, 1]) / div,
        )
    rows = 6 + fl.gauges.size
    err[6:rows] = 0.0
    return least_squares(mat, err[:rows], step, sq, rhs, svd, piv)


@njit(**INLINE)
def newton(fl: FlatLoop, vals: np.ndarray, x: np.ndarray, tols: ClosureTols, w: Work) -> tuple[int, float]:
    """Newton with step halving from ``x`` (updated in place); returns (iterations, residual)
    (:func:`newton_held`, the loop not yet evaluated at ``x``)."""
    iters, residual, _, _ = newton_held(fl, vals, x, tols, w, False)
    return iters, residual


@njit(**INLINE)
def _same_point(x: np.ndarray, y: np.ndarray) -> bool:
    """``x`` and ``y`` are the same state to the bit (signed zeros apart; never where a NaN is)."""
    for i in range(x.size):
        if not _same(x[i], y[i]):
            return False
    return True


@njit(**INLINE)
def newton_held(fl: FlatLoop, vals: np.ndarray, x: np.ndarray, tols: ClosureTols, w: Work,
                held: bool) -> tuple[int, float, bool, float]:
    """Newton with step halving from ``x`` (updated in place); returns (iterations, residual, whether the
    loop is left evaluated at ``x``, the residual where the LU factors in ``w.sq``, ``w.piv`` were taken
    if ``x`` is that point moved by their full Newton step, else inf).  ``held``: the loop is already
    evaluated at ``x`` (``w.frames``, ``w.lines``, for these ``vals``), as after a Newton that stopped there.

    The per-position form of :func:`dualmech.core.closure._newton`: a step that increases
    the residual is halved (up to 6 times); Newton stops when closed, when a
    residual below the rounding level no longer halves, or after 3 stalls; a point
    left unevaluated by the iteration limit is stepped back to the last accepted one.

    A point the same to the bit as the last one evaluated (``w.seen``) is not evaluated again: the
    frames hold it, and the evaluation would write the same numbers.  At the rounding level a halved step
    rounds back to the accepted point: the refine's halvings, most of them, cost a comparison.
    """
    base, step, frames, lines, k0, seen = w.base, w.step, w.frames, w.lines, fl.n_scalar, w.seen
    mat, gauge, axes, err, sq, rhs = w.mat, w.gauge, w.axes, w.err, w.sq, w.rhs
    copy(x, base)
    if held:
        copy(x, seen)
    step[:] = 0.0
    base_res, stalls, halvings, iters, residual, active = math.inf, 0, 0, 0, math.inf, True
    factored = False  # the factors in w.sq, w.piv are the screw matrix's at base (LU served)
    for _ in range(tols.max_newton + 1):
        if held and _same_point(x, seen):
            res = closure_residual(frames, length_scale(fl, vals))
        else:
            res = residual_at(fl, vals, x, w)
            copy(x, seen)
            held = True
        residual = res
        done = res <= tols.closure
        if res > base_res and halvings < 6 and not done:
            halvings += 1
            retract(k0, base, step, 0.5**halvings, x)
            continue
        if done:
            active = False
            break
        improved = res < 0.5 * base_res
        stalls = 0 if improved else stalls + 1
        if (not improved and res <= tols.rounding) or stalls >= 3:
            active = False
            break
        factored = newton_step(fl, vals, frames, lines, mat, gauge, axes, err, sq, rhs, w.svd, w.piv, step)
        copy(x, base)
        base_res, halvings = res, 0
        retract(k0, x, step, 1.0, x)
        iters += 1
    if active and math.isfinite(base_res):
        copy(base, x)
        residual = base_res
    stepped = factored and not active and halvings == 0  # x is base moved by the factors' full step
    return iters, residual, held and _same_point(x, seen), base_res if stepped else math.inf
