"""Any single loop at a block of positions, compiled: closure, rates and every joint's wrench per position.

Per position of :func:`analyze_block` (one thread runs one block of whole segments): the estimate, the
closure refined to the rounding level and its branch sign (:mod:`~dualmech.core.kernel.continuation_nb`),
rates and accelerations
(:func:`~dualmech.core.kernel.rates_nb.solve_rates`) and the joint wrenches
(:func:`~dualmech.core.kernel.wrenches_nb.joint_wrenches`), written to the position's rows of the
outputs; the branch sign's LU factors serve the rates (one factorization of the closure Jacobian at the
closed state).  The estimate (:func:`_estimate`): on a fine, even grid of the drive, the state of the
position before it moved by its rates and accelerations, to second order in the drive
(:func:`_second_order`), where the two positions before it in its :data:`SEGMENT` closed on the branch (a
neighbour a step away is far nearer than a station: on a fine grid closed to the rounding already, where a
station's interpolation takes three Newton steps; an S-S link's spin, which the gauge leaves as
estimated, follows the positions before); else, as the numpy solver's, the
state interpolated between the good stations around it, which is also tried where an extrapolated estimate
does not close on the branch.  A segment's answers depend on its first position and the stations only, so
every position's answer is the same whatever the blocks.  :mod:`dualmech.core.kernel.loop_engine` closes
the stations, drives the blocks and reads the outputs back as the numpy solver's results.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from dualmech.core.kernel.closure_nb import OK, ClosureTols, Work, residual_at, second_order_step
from dualmech.core.kernel.continuation_nb import close_position, interpolate, interpolated_guess
from dualmech.core.kernel.dual_nb import INLINE, JIT
from dualmech.core.kernel.loop_nb import COLUMN, VALUE_INDEX, FlatLoop, length_scale
from dualmech.core.kernel.rates_nb import solve_rates
from dualmech.core.kernel.wrenches_nb import WrenchSpec, WrenchWork, joint_wrenches

#: Columns of the integer output: the closure's status code, its iterations, the branch sign.
CODE, ITERATIONS, SIGN = 0, 1, 2
#: Columns of the real output: the closure residual, the Newton-Euler residual, the transmission.
RESIDUAL, DYNAMICS_RESIDUAL, TRANSMISSION = 0, 1, 2
#: Positions of a segment: a segment's third position on is estimated from the one before it
#: (:func:`_estimate`); blocks are whole segments.  Long enough that the interpolated estimates of its first
#: two positions cost little, short enough to spread a 360-position turn over two threads.
SEGMENT = 60
#: Largest change of a value's step from one position to the next, relative to the step, where a position is
#: extrapolated from the two before it (:func:`_steady`): an evenly spaced or smoothly moving drive.
STEADY = 0.1
#: Fewest positions between the good stations around a position where it is extrapolated: the line through
#: two neighbours a step ``h`` apart misses by about ``h^2 |x''|``, the interpolation between stations ``H``
#: apart by ``H^2 |x''| / 8``: the line is nearer from ``H / h`` = 3 on.
STATION_GAP = 3


@njit(**JIT)
def analyze_block(
    lo: int,
    hi: int,
    fl: FlatLoop,
    tols: ClosureTols,
    refine_tols: ClosureTols,
    spec: WrenchSpec,
    values: tuple,
    good_pos: np.ndarray,
    good_x: np.ndarray,
    branch: int,
    out: tuple,
    w: Work,
    ww: WrenchWork,
) -> None:
    """Positions ``lo`` to ``hi`` (module docstring; ``lo`` the first of a :data:`SEGMENT`).

    ``values``: ``vals``, their rates and accelerations ``(n, V)`` each (indexed as
    :func:`~dualmech.core.kernel.loop_nb.value_names`, parameters' rates 0) and the given efforts ``(n, g)``;
    ``good_pos`` ``(m,)``, ``good_x`` ``(m, S)``: the good stations' positions (sorted) and states; ``branch``
    the start's branch sign.
    ``out``: the states ``(n, S)``; rates and accelerations ``(n, 2, K)``; link twists and accelerations
    ``(n, 2, R, 2, 3)``; joint forces, moments and points ``(n, 3, R, 3)``; the wrench unknowns ``(n, k)``;
    the integers ``(n, 3)`` (:data:`CODE` ...) and reals ``(n, 3)`` (:data:`RESIDUAL` ...).
    """
    vals = values[0]
    xs, ints, reals = out[0], out[5], out[6]
    drive = _drive_value(fl)
    for i in range(lo, hi):
        x = xs[i]
        extrapolated = _estimate(i, lo, fl, drive, values, good_pos, good_x, branch, out, w.step, x)
        code, iters, res, sign = close_position(fl, tols, refine_tols, vals[i], x, w)
        if extrapolated and (code != OK or sign != branch):  # as the numpy solver, from the stations
            interpolated_guess(fl.n_scalar, i, good_pos, good_x, x)
            code, more, res, sign = close_position(fl, tols, refine_tols, vals[i], x, w)
            iters += more
        ints[i, CODE], ints[i, ITERATIONS], ints[i, SIGN] = code, iters, sign
        reals[i, RESIDUAL] = res
        # the branch sign's LU factors (none at a zero pivot) serve the rates
        _outputs(i, fl, spec, values, out, w, ww, length_scale(fl, vals[i]) if sign != 0 else 0.0)


@njit(**INLINE)
def _on_branch(ints: np.ndarray, i: int, branch: int) -> bool:
    """Whether position ``i`` closed on the ``branch``."""
    return ints[i, CODE] == OK and ints[i, SIGN] == branch


@njit(**INLINE)
def _steady(vals: np.ndarray, i: int) -> bool:
    """Whether every value (input or parameter) moves evenly through positions ``i - 2``, ``i - 1``,
    ``i``: its step changes by at most :data:`STEADY` of itself (a grid of the drive, not a jump or a turn
    back)."""
    for k in range(vals.shape[1]):
        step = vals[i - 1, k] - vals[i - 2, k]
        if abs(vals[i, k] - vals[i - 1, k] - step) > STEADY * abs(step):
            return False
    return True


@njit(**INLINE)
def _drive_value(fl: FlatLoop) -> int:
    """The index in ``vals`` of the drive: the first input's (a C joint driven by its angle: the angle)."""
    for j in range(fl.screws.shape[0]):
        if fl.screws[j, COLUMN] < 0:
            return fl.screws[j, VALUE_INDEX]
    return -1


@njit(**INLINE)
def _estimate(i: int, lo: int, fl: FlatLoop, drive: int, values: tuple, good_pos: np.ndarray,
              good_x: np.ndarray, branch: int, out: tuple, change: np.ndarray, x: np.ndarray) -> bool:
    """Position ``i``'s start estimate into ``x`` (module docstring): from position ``i - 1``
    (:func:`_second_order`) where positions ``i - 2`` and ``i - 1`` are in ``i``'s segment, at or after the
    block's first position ``lo``, closed on the ``branch``, the values move evenly (:func:`_steady`), and
    ``i`` lies between good stations at least :data:`STATION_GAP` positions apart (nearer stations
    interpolate as well; a station is its own estimate); else
    :func:`~dualmech.core.kernel.continuation_nb.interpolated_guess`.  Whether extrapolated.  ``change``
    ``(K,)``: scratch."""
    vals, ints = values[0], out[5]
    right = min(np.searchsorted(good_pos, i), good_pos.size - 1)
    gap = good_pos[right] - good_pos[max(right - 1, 0)]
    if (i % SEGMENT >= 2 and i - 2 >= lo and good_pos[right] != i and gap >= STATION_GAP
            and _on_branch(ints, i - 1, branch) and _on_branch(ints, i - 2, branch) and _steady(vals, i)):
        _second_order(i, fl, drive, values, out, change, x)
        return True
    interpolated_guess(fl.n_scalar, i, good_pos, good_x, x)
    return False


@njit(**INLINE)
def _second_order(i: int, fl: FlatLoop, drive: int, values: tuple, out: tuple, change: np.ndarray,
                  x: np.ndarray) -> None:
    """The state at position ``i`` from position ``i - 1``'s, its rates and accelerations, to second order
    in the drive's value (the pose is a function of it alone;
    :func:`~dualmech.core.kernel.closure_nb.second_order_step`, over the time the drive takes at its speed).
    The error is of third order in the step: on a fine grid below the closure's rounding, so that Newton
    takes no step.  Where the drive stands still
    (``d_dot`` 0), the line through the states of positions ``i - 2`` and ``i - 1``
    (:func:`~dualmech.core.kernel.continuation_nb.interpolate` at ``t`` = 2)."""
    vals, vdot, vddot = values[0], values[1], values[2]
    xs, q = out[0], out[1]
    speed = vdot[i - 1, drive] if drive >= 0 else 0.0
    if not (speed != 0.0 and math.isfinite(speed)):
        interpolate(fl.n_scalar, xs[i - 2], xs[i - 1], 2.0, x)
        return
    h = (vals[i, drive] - vals[i - 1, drive]) / speed  # the time step at the drive's speed
    bend = vddot[i - 1, drive] / speed
    second_order_step(fl.n_scalar, xs[i - 1], q[i - 1, 0], q[i - 1, 1], h, bend, change, x)


@njit(**JIT)
def outputs_at(rows: np.ndarray, fl: FlatLoop, spec: WrenchSpec, values: tuple, out: tuple, w: Work,
               ww: WrenchWork) -> None:
    """Rates and wrenches of the positions ``rows`` at their states in ``out[0]`` (closed again after the
    block pass: the numpy solver's repairs)."""
    for k in range(rows.size):
        i = rows[k]
        residual_at(fl, values[0][i], out[0][i], w)
        _outputs(i, fl, spec, values, out, w, ww, 0.0)


@njit(**INLINE)
def _outputs(i: int, fl: FlatLoop, spec: WrenchSpec, values: tuple, out: tuple, w: Work,
             ww: WrenchWork, factored: float) -> None:
    """Position ``i``'s rates and joint wrenches into ``out`` (:func:`analyze_block`), the loop evaluated at
    its state in ``w`` (``factored``: as :func:`~dualmech.core.kernel.rates_nb.solve_rates`')."""
    vals, vdot, vddot, given = values
    xs, q, motion, wrench, unknowns, ints, reals = out
    solve_rates(fl, vdot[i], vddot[i], w, factored)
    dyn, transmission = joint_wrenches(fl, spec, vals[i], xs[i], given[i], w, ww)
    reals[i, DYNAMICS_RESIDUAL], reals[i, TRANSMISSION] = dyn, transmission
    for k in range(fl.n_step):
        q[i, 0, k], q[i, 1, k] = w.q_dot[k], w.q_ddot[k]
    for r in range(w.twists.shape[0]):
        for p in range(2):
            for c in range(3):
                motion[i, 0, r, p, c] = w.twists[r, p, c]
                motion[i, 1, r, p, c] = w.accels[r, p, c]
        for c in range(3):
            wrench[i, 0, r, c] = ww.force[r, c]
            wrench[i, 1, r, c] = ww.moment[r, c]
            wrench[i, 2, r, c] = ww.points[r, c]
    for c in range(ww.x.size):
        unknowns[i, c] = ww.x[c]
