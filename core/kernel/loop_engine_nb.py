"""Any single loop at a block of positions, compiled: closure, rates and every joint's wrench per position.

Per position of :func:`analyze_block` (one thread runs one block; the positions of a block share nothing
but the good stations they start from): the estimate interpolated between the stations around it, the
closure refined to the rounding level and its branch sign
(:mod:`~dualmech.core.kernel.continuation_nb`), rates and accelerations
(:func:`~dualmech.core.kernel.rates_nb.solve_rates`) and the joint wrenches
(:func:`~dualmech.core.kernel.wrenches_nb.joint_wrenches`), written to the position's rows of the
outputs.  :mod:`dualmech.core.kernel.loop_engine` closes the stations, drives the blocks and reads the
outputs back as the numpy solver's results.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from dualmech.core.kernel.closure_nb import ClosureTols, Work, residual_at
from dualmech.core.kernel.continuation_nb import close_position, interpolated_guess
from dualmech.core.kernel.dual_nb import INLINE, JIT
from dualmech.core.kernel.loop_nb import FlatLoop
from dualmech.core.kernel.rates_nb import solve_rates
from dualmech.core.kernel.wrenches_nb import WrenchSpec, WrenchWork, joint_wrenches

#: Columns of the integer output: the closure's status code, its iterations, the branch sign.
CODE, ITERATIONS, SIGN = 0, 1, 2
#: Columns of the real output: the closure residual, the Newton-Euler residual, the transmission.
RESIDUAL, DYNAMICS_RESIDUAL, TRANSMISSION = 0, 1, 2


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
    out: tuple,
    w: Work,
    ww: WrenchWork,
) -> None:
    """Positions ``lo`` to ``hi`` (module docstring).

    ``values``: ``vals``, their rates and accelerations ``(n, V)`` each (indexed as
    :func:`~dualmech.core.kernel.loop_nb.value_names`, parameters' rates 0) and the given efforts ``(n, g)``;
    ``good_pos`` ``(m,)``, ``good_x`` ``(m, S)``: the good stations' positions (sorted) and states.
    ``out``: the states ``(n, S)``; rates and accelerations ``(n, 2, K)``; link twists and accelerations
    ``(n, 2, R, 2, 3)``; joint forces, moments and points ``(n, 3, R, 3)``; the wrench unknowns ``(n, k)``;
    the integers ``(n, 3)`` (:data:`CODE` ...) and reals ``(n, 3)`` (:data:`RESIDUAL` ...).
    """
    vals = values[0]
    xs, ints, reals = out[0], out[5], out[6]
    for i in range(lo, hi):
        x = xs[i]
        interpolated_guess(fl.n_scalar, i, good_pos, good_x, x)
        code, iters, res, sign = close_position(fl, tols, refine_tols, vals[i], x, w)
        ints[i, CODE], ints[i, ITERATIONS], ints[i, SIGN] = code, iters, sign
        reals[i, RESIDUAL] = res
        _outputs(i, fl, spec, values, out, w, ww)


@njit(**JIT)
def outputs_at(rows: np.ndarray, fl: FlatLoop, spec: WrenchSpec, values: tuple, out: tuple, w: Work,
               ww: WrenchWork) -> None:
    """Rates and wrenches of the positions ``rows`` at their states in ``out[0]`` (closed again after the
    block pass: the numpy solver's repairs)."""
    for k in range(rows.size):
        i = rows[k]
        residual_at(fl, values[0][i], out[0][i], w)
        _outputs(i, fl, spec, values, out, w, ww)


@njit(**INLINE)
def _outputs(i: int, fl: FlatLoop, spec: WrenchSpec, values: tuple, out: tuple, w: Work,
             ww: WrenchWork) -> None:
    """Position ``i``'s rates and joint wrenches into ``out`` (:func:`analyze_block`), the loop evaluated at
    its state in ``w``."""
    vals, vdot, vddot, given = values
    xs, q, motion, wrench, unknowns, ints, reals = out
    solve_rates(fl, vdot[i], vddot[i], w)
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
