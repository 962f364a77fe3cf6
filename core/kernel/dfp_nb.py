"""The DFP fallback and the whole closure of one position, compiled.

The per-position form of :func:`dualmech.core.closure.davidon_fletcher_powell` and
:func:`dualmech.core.closure.solve_closure`: where Newton stalls, DFP with an Armijo
line search minimizes :math:`\\tfrac12\\|\\hat B - \\hat I\\|^2` (the whole matrix, the dual
part over the length scale: errata E3) from the estimate and from Newton's end point;
the better run wins, Newton polishes near a root, and a non-zero stationary minimum
is the verdict ``no_assembly`` (thesis section 2.6.1, Hall, Root & Sandgren).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from dualmech.core.kernel.closure_nb import (
    NO_ASSEMBLY,
    NOT_CONVERGED,
    OK,
    ClosureTols,
    Work,
    newton,
    newton_held,
    residual_at,
    retract,
)
from dualmech.core.kernel.dual_nb import JIT, copy
from dualmech.core.kernel.linalg_nb import pseudo_inverse
from dualmech.core.kernel.loop_nb import FlatLoop, length_scale, screw_matrix


@njit(**JIT)
def objective(
    fl: FlatLoop, vals: np.ndarray, x: np.ndarray, grad: np.ndarray, w: Work
) -> tuple[float, float, float]:
    """DFP objective at ``x``: returns (f, stationarity cosine, closure residual); ``grad`` ``(K,)``
    gets the gradient and ``w.jac`` the Jacobian with the gauge rows below it
    (:func:`dualmech.core.closure._objective`)."""
    res = residual_at(fl, vals, x, w)
    scale = length_scale(fl, vals)
    b = w.frames[-1]
    r = w.res18
    for i in range(3):
        for j in range(3):
            r[3 * i + j] = b[0, i, j] - (1.0 if i == j else 0.0)
            r[9 + 3 * i + j] = b[1, i, j] / scale
    jac = w.jac
    jac[:] = 0.0
    for s in range(fl.screws.shape[0]):
        col = fl.screws[s, 2]
        if col < 0:
            continue
        re, du = w.lines[s, 0], w.lines[s, 1]
        for c in range(3):  # ([re]x B.re)[:, c] = re x B.re[:, c], and the dual part likewise
            for i in range(3):
                i1, i2 = (i + 1) % 3, (i + 2) % 3
                jac[3 * i + c, col] = re[i1] * b[0, i2, c] - re[i2] * b[0, i1, c]
                jac[9 + 3 * i + c, col] = (
                    re[i1] * b[1, i2, c] - re[i2] * b[1, i1, c] + du[i1] * b[0, i2, c] - du[i2] * b[0, i1, c]
                ) / scale
    f, rr, jj, gg = 0.0, 0.0, 0.0, 0.0
    for m in range(18):
        rr += r[m] * r[m]
    for k in range(fl.n_step):
        grad[k] = 0.0
        for m in range(18):
            grad[k] += jac[m, k] * r[m]
            jj += jac[m, k] * jac[m, k]
        gg += grad[k] * grad[k]
    f = 0.5 * rr
    cosine = math.sqrt(gg) / max(math.sqrt(jj) * math.sqrt(rr), 1e-300)
    if fl.gauges.size:
        screw_matrix(fl, w.frames, w.lines, scale, w.mat, w.gauge, w.axes)
        for g in range(fl.gauges.size):
            for k in range(fl.n_step):
                jac[18 + g, k] = w.mat[6 + g, k]
    return f, cosine, res


@njit(**JIT)
def gauss_newton_inverse(jac: np.ndarray, out: np.ndarray, svd: np.ndarray) -> None:
    """``out``: pseudo-inverse of the Gauss-Newton Hessian ``J^T J`` (plus 1e-12 of its trace)
    (:func:`dualmech.core.closure._gauss_newton_inverse`); ``svd`` ``(3, K, K)`` scratch.

    The numpy solver sums ``v vᵀ / λ`` over the eigenpairs above ``1e-15 max|λ|``; for this
    symmetric positive matrix the eigenvalues are its singular values, so the pseudo-inverse of
    :func:`~dualmech.core.kernel.linalg_nb.pseudo_inverse` (same cutoff) is the same matrix.
    """
    gram = svd[0]
    k = jac.shape[1]
    tr = 0.0
    for i in range(k):
        for j in range(k):
            gram[i, j] = 0.0
            for r in range(jac.shape[0]):
                gram[i, j] += jac[r, i] * jac[r, j]
        tr += gram[i, i]
    for i in range(k):
        gram[i, i] += 1e-12 * tr
    pseudo_inverse(gram, out, svd[1], svd[2])


@njit(**JIT)
def dfp_update(h: np.ndarray, s: np.ndarray, y: np.ndarray, hy: np.ndarray) -> None:
    """DFP update of the inverse Hessian ``h`` in place, skipped where not positive
    (:func:`dualmech.core.closure._dfp_update`); ``hy`` ``(K,)`` is scratch."""
    k = s.size
    sy, yhy = 0.0, 0.0
    for i in range(k):
        sy += s[i] * y[i]
        hy[i] = 0.0
        for j in range(k):
            hy[i] += h[i, j] * y[j]
    for i in range(k):
        yhy += y[i] * hy[i]
    if not (sy > 1e-300 and yhy > 1e-300):
        return
    for i in range(k):
        for j in range(k):
            h[i, j] += s[i] * s[j] / sy - hy[i] * hy[j] / yhy


@njit(**JIT)
def dfp(
    fl: FlatLoop, vals: np.ndarray, x: np.ndarray, tols: ClosureTols, w: Work
) -> tuple[int, float, float]:
    """DFP from ``x`` (updated in place); returns (iterations, residual, stationarity cosine)."""
    grad, g_t, p, y = w.grads[0], w.grads[1], w.grads[2], w.grads[3]
    f, cosine, res = objective(fl, vals, x, grad, w)
    gauss_newton_inverse(w.jac, w.hess, w.svd)
    iters = 0
    active = res > tols.closure and cosine > tols.stationary
    for it in range(tols.max_dfp):
        if not active:
            break
        if it and it % tols.dfp_restart == 0:  # the tangent axes turn with the joints: refresh
            objective(fl, vals, x, g_t, w)
            gauss_newton_inverse(w.jac, w.hess, w.svd)
        slope = 0.0
        for i in range(fl.n_step):
            p[i] = 0.0
            for j in range(fl.n_step):
                p[i] -= w.hess[i, j] * grad[j]
            slope += p[i] * grad[i]
        alpha, pending = 1.0, True
        for _ in range(40):  # Armijo backtracking
            retract(fl.n_scalar, x, p, alpha, w.trial)
            f_t, c_t, r_t = objective(fl, vals, w.trial, g_t, w)
            if f_t <= f + 1e-4 * alpha * slope:
                copy(w.trial, x)
                for i in range(fl.n_step):
                    y[i] = g_t[i] - grad[i]
                    p[i] *= alpha
                dfp_update(w.hess, p, y, w.rhs)
                copy(g_t, grad)
                f, cosine, res, pending = f_t, c_t, r_t, False
                break
            alpha *= 0.5
        iters += 1
        active = not pending and res > tols.closure and cosine > tols.stationary
    return iters, res, cosine


@njit(**JIT)
def _rank(res: float, cosine: float, tols: ClosureTols) -> int:
    return 0 if res <= tols.rounding else (1 if cosine <= tols.stationary else 2)


@njit(**JIT)
def solve_closure(
    fl: FlatLoop, vals: np.ndarray, x: np.ndarray, tols: ClosureTols, w: Work
) -> tuple[int, int, float]:
    """Close the loop from the estimate ``x`` (updated in place): (status code, iterations, residual)
    (:func:`solve_closure_held`)."""
    code, iters, residual, _ = solve_closure_held(fl, vals, x, tols, w)
    return code, iters, residual


@njit(**JIT)
def solve_closure_held(
    fl: FlatLoop, vals: np.ndarray, x: np.ndarray, tols: ClosureTols, w: Work
) -> tuple[int, int, float, bool]:
    """Close the loop from the estimate ``x`` (updated in place): (status code, iterations, residual,
    whether the loop is left evaluated at ``x``: where Newton alone closed it,
    :func:`~dualmech.core.kernel.closure_nb.newton_held`).

    :func:`dualmech.core.closure.solve_closure` for one position: Newton; where it
    did not reach the rounding level, DFP from the estimate and from Newton's end
    point (closed beats stationary beats neither, ties to the lower residual),
    Newton polishing where DFP came near a root, and the verdict: ``NO_ASSEMBLY`` at a
    stationary non-zero minimum, else ``NOT_CONVERGED``.
    """
    copy(x, w.guess)
    iters, residual, held, _ = newton_held(fl, vals, x, tols, w, False)
    if not residual > tols.rounding:  # NaN too, as the batched solver
        return OK, iters, residual, held
    run_a, run_b, polish = w.runs[0], w.runs[1], w.runs[2]
    copy(w.guess, run_a)
    copy(x, run_b)
    it_a, res_a, cos_a = dfp(fl, vals, run_a, tols, w)
    it_b, res_b, cos_b = dfp(fl, vals, run_b, tols, w)
    rank_a, rank_b = _rank(res_a, cos_a, tols), _rank(res_b, cos_b, tols)
    pick_b = rank_b < rank_a or (rank_b == rank_a and res_b < res_a)
    copy(run_b if pick_b else run_a, x)
    res, cosine = (res_b, cos_b) if pick_b else (res_a, cos_a)
    iters += it_a + it_b
    if tols.rounding < res < tols.near_root:
        copy(x, polish)
        it_n, res_n = newton(fl, vals, polish, tols, w)
        if res_n < res:
            copy(polish, x)
            res = res_n
        iters += it_n
    if not res > tols.rounding:
        return OK, iters, res, False
    return (NO_ASSEMBLY if cosine <= tols.stationary else NOT_CONVERGED), iters, res, False
