"""Continuation along the input sequence at one position at a time, compiled: the branch, the stations, the
start estimate of every other position.

The per-position form of :func:`dualmech.core.continuation.continue_closure`: the start pose closed at its
position and its branch taken (the sign of the square closure Jacobian's determinant), the stations closed
one after the other from the last good one (:func:`close_one`, driven by
:mod:`~dualmech.core.kernel.loop_engine` with the numpy solver's walks and repairs), then every position from
the estimate interpolated between the two good stations around it (:func:`interpolated_guess`; each
position on its own, so the positions may be closed in parallel), closed, refined to the rounding level
and its branch read (:func:`close_position`).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from dualmech.core.kernel.closure_nb import OK, ClosureTols, Work, newton, newton_held, residual_at
from dualmech.core.kernel.dfp_nb import solve_closure_held
from dualmech.core.kernel.dual_nb import INLINE, JIT, copy, tmul, trodrigues
from dualmech.core.kernel.linalg_nb import determinant_sign, lu_sign
from dualmech.core.kernel.loop_nb import FlatLoop, length_scale, screw_matrix

#: The rounding level of the closure residual (relative, as
#: :func:`~dualmech.core.kernel.loop_nb.closure_residual`): four units of roundoff.  A Newton step from a
#: point closed within it is of the rounding's size: such a point is not refined, and the LU factors of
#: such a step serve the point it steps to, whose screw matrix differs from the factored one by rounding
#: (times ``1/c`` near an assembly limit, as the pose itself does) (:func:`close_position`).
ROUNDING_RESIDUAL = 4 * 2.220446049250313e-16


@njit(**JIT)
def branch_sign(fl: FlatLoop, vals: np.ndarray, x: np.ndarray, w: Work) -> int:
    """Sign of the closure Jacobian's determinant at ``x`` (:func:`dualmech.core.continuation.branch_sign`);
    leaves the loop evaluated at ``x`` in ``w.frames``, ``w.lines``."""
    residual_at(fl, vals, x, w)
    return _sign_held(fl, vals, w)


@njit(**INLINE)
def _sign_held(fl: FlatLoop, vals: np.ndarray, w: Work) -> int:
    """:func:`branch_sign` of the point the loop is evaluated at (``w.frames``, ``w.lines``)."""
    screw_matrix(fl, w.frames, w.lines, length_scale(fl, vals), w.mat, w.gauge, w.axes)
    return determinant_sign(w.mat, w.sq, w.piv)


@njit(**INLINE)
def _log(m: tuple) -> tuple:
    """Rotation vector of the rotation ``m`` (a 9-tuple) by less than pi
    (:func:`dualmech.core.continuation._log`)."""
    cos = min(max((m[0] + m[4] + m[8] - 1.0) / 2.0, -1.0), 1.0)
    angle = math.acos(cos)
    factor = 0.5 if angle < 1e-8 else angle / (2.0 * math.sin(max(angle, 1e-8)))
    return (
        0.5 * ((m[7] - m[5]) - (m[5] - m[7])) * factor,
        0.5 * ((m[2] - m[6]) - (m[6] - m[2])) * factor,
        0.5 * ((m[3] - m[1]) - (m[1] - m[3])) * factor,
    )


@njit(**JIT)
def interpolate(n_scalar: int, a: np.ndarray, b: np.ndarray, t: float, out: np.ndarray) -> None:
    """The state ``t`` of the way from ``a`` to ``b`` into ``out`` (:func:`dualmech.core.continuation.
    interpolate`): scalars linearly, rotations along the shortest turn from ``a``'s to ``b``'s."""
    for i in range(n_scalar):
        out[i] = a[i] + t * (b[i] - a[i])
    for ball in range((a.size - n_scalar) // 9):
        o = n_scalar + 9 * ball
        ra = (a[o], a[o + 1], a[o + 2], a[o + 3], a[o + 4], a[o + 5], a[o + 6], a[o + 7], a[o + 8])
        rb = (b[o], b[o + 1], b[o + 2], b[o + 3], b[o + 4], b[o + 5], b[o + 6], b[o + 7], b[o + 8])
        ra_t = (ra[0], ra[3], ra[6], ra[1], ra[4], ra[7], ra[2], ra[5], ra[8])
        turn = _log(tmul(rb, ra_t))
        new = tmul(trodrigues(turn[0] * t, turn[1] * t, turn[2] * t), ra)
        for k in range(9):
            out[o + k] = new[k]


@njit(**INLINE)
def interpolated_guess(
    n_scalar: int, i: int, good_pos: np.ndarray, good_x: np.ndarray, out: np.ndarray
) -> None:
    """Position ``i``'s start estimate into ``out``: between the good stations around it (``good_pos``
    ``(m,)`` sorted positions, ``good_x`` ``(m, S)`` their states), before the first or after the last that
    station's state (interpolated at ``t`` 0 or 1, as the numpy solver does)."""
    m = good_pos.size
    right = np.searchsorted(good_pos, i)
    right = min(max(right, 0), m - 1)
    left = min(max(right - 1, 0), m - 1)
    lo, hi = good_pos[left], good_pos[right]
    t = (i - lo) / max(hi - lo, 1) if hi > lo else 0.0
    t = min(max(t, 0.0), 1.0)
    interpolate(n_scalar, good_x[left], good_x[right], t, out)


@njit(**JIT)
def close_one(fl: FlatLoop, tols: ClosureTols, vals: np.ndarray, x: np.ndarray, branch: int,
              w: Work) -> tuple[bool, int, float]:
    """Close one position from ``x`` (in place): whether it closed on the start's ``branch``, the iterations
    and the residual (``_close_one`` of :func:`dualmech.core.continuation.continue_closure`)."""
    code, iters, res, held = solve_closure_held(fl, vals, x, tols, w)
    if code != OK:
        return False, iters, res
    return (_sign_held(fl, vals, w) if held else branch_sign(fl, vals, x, w)) == branch, iters, res


@njit(**INLINE)
def _close_from(fl: FlatLoop, tols: ClosureTols, vals: np.ndarray, branch: int, src: int, dst: int,
                states: np.ndarray, w: Work) -> bool:
    """Position ``dst`` closed on the ``branch`` from position ``src``'s state (:func:`close_one`), into
    ``states[dst]``: whether it closed."""
    copy(states[src], states[dst])
    return close_one(fl, tols, vals[dst], states[dst], branch, w)[0]


@njit(**JIT)
def close_stations(fl: FlatLoop, tols: ClosureTols, vals: np.ndarray, branch: int, at: int, way: np.ndarray,
                   states: np.ndarray, good: np.ndarray, w: Work) -> None:
    """The stations ``way`` (positions, in the order closed: away from the closed start ``at``) closed in turn
    from the last good position; where Newton cannot reach a station from there, the positions between walked
    one after the other, and the station tried again from the last of them if they all closed
    (``_stations`` of :func:`dualmech.core.continuation.continue_closure`, step for step).  ``states``
    ``(n, S)``: the states, closed where ``good`` ``(n,)`` (``states[at]`` the start's, ``good[at]``)."""
    last = at
    for k in range(way.size):
        i = way[k]
        closed = _close_from(fl, tols, vals, branch, last, i, states, w)
        if not closed:  # too far for Newton from the last good pose: walk the positions between
            sign = 1 if i > last else -1
            for j in range(last + sign, i, sign):
                if not _close_from(fl, tols, vals, branch, last, j, states, w):
                    break
                good[j], last = True, j
            closed = last == i - sign and _close_from(fl, tols, vals, branch, last, i, states, w)
        if closed:
            good[i], last = True, i


@njit(**JIT)
def refine_one(fl: FlatLoop, refine_tols: ClosureTols, vals: np.ndarray, x: np.ndarray,
               w: Work) -> tuple[int, float]:
    """A closed ``x`` refined to the rounding level (:func:`dualmech.core.closure.refine`): the iterations and
    the residual."""
    return newton(fl, vals, x, refine_tols, w)


@njit(**INLINE)
def close_position(
    fl: FlatLoop, tols: ClosureTols, refine_tols: ClosureTols, vals: np.ndarray, x: np.ndarray, w: Work
) -> tuple[int, int, float, int]:
    """Close one position from its estimate ``x`` (in place), refine a closed one to the rounding level
    (:func:`dualmech.core.closure.refine`: ``refine_tols`` close at 0) and read its branch sign: (status
    code, iterations, residual, sign); the loop is left evaluated at ``x``, and where the sign is not 0 the
    LU factors of its screw matrix (dual rows over the length scale) are left in ``w.sq``, ``w.piv``.

    A point closed within :data:`ROUNDING_RESIDUAL` (an estimate from a close neighbour on a fine grid,
    often) is at the rounding level already and is not refined.  Where the refine's last step began within
    it, its factors are this point's to rounding (the step moved it by rounding): the sign is read from
    them, not from a factorization of its own (:func:`_sign_held`), which would give the same sign but at
    a singular pose, where the sign is rounding either way."""
    code, iters, res, held = solve_closure_held(fl, vals, x, tols, w)
    factored_at = math.inf
    if code == OK and not (held and res <= ROUNDING_RESIDUAL):
        more, res, held, factored_at = newton_held(fl, vals, x, refine_tols, w, held)
        iters += more
    if held and factored_at <= ROUNDING_RESIDUAL and w.mat.shape[0] == w.mat.shape[1]:
        return code, iters, res, lu_sign(w.sq, w.piv)
    return code, iters, res, _sign_held(fl, vals, w) if held else branch_sign(fl, vals, x, w)
