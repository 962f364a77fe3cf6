"""Small dense linear algebra at one position, compiled, in caller-owned scratch (no allocation).

The kernel runs without numba's reference-counted runtime (``_nrt=False`` in
:data:`~dualmech.core.kernel.dual_nb.JIT`): every array a compiled function receives
would otherwise cost two atomic reference-count updates per call, which measured 63 % of
the kernel's time (``perf``, 4·10⁵ positions).  Without the runtime nothing may allocate,
so the pseudo-inverse that numpy's ``np.linalg.pinv`` (LAPACK, allocating) gave is computed
here by one-sided Jacobi rotations (Hestenes 1958; Demmel & Veselić 1992) into given arrays.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from dualmech.core.kernel.dual_nb import INLINE, JIT

#: Relative cutoff of singular values in :func:`pseudo_inverse`: ``np.linalg.pinv``'s default ``rcond``,
#: so that the kernel and the numpy solver (:func:`dualmech.core.closure.least_squares`) drop the same ones.
PINV_RCOND = 1e-15
#: Two columns count as orthogonal when ``|u_p·u_q| <= EPS |u_p||u_q|`` (double precision's unit roundoff).
EPS = 2.220446049250313e-16
#: Jacobi sweeps at most (one-sided Jacobi converges quadratically: 6 to 10 suffice for a 7x7 matrix).
MAX_SWEEPS = 60


@njit(**JIT)
def pseudo_inverse(a: np.ndarray, out: np.ndarray, u: np.ndarray, v: np.ndarray) -> None:
    """``out`` = the Moore-Penrose pseudo-inverse of the square matrix ``a`` ``(k, k)``.

    One-sided Jacobi: plane rotations ``V`` make the columns of ``U = A V`` mutually
    orthogonal, so that ``A = (U Σ⁻¹) Σ Vᵀ`` is a singular value decomposition with
    ``σ_j = |u_j|``; then :math:`A^+ = \\sum_{\\sigma_j > r \\sigma_{max}} v_j u_j^T / \\sigma_j^2`
    with ``r`` = :data:`PINV_RCOND`.  ``u``, ``v`` ``(k, k)``: scratch.
    """
    k = a.shape[0]
    for i in range(k):
        for j in range(k):
            u[i, j] = a[i, j]
            v[i, j] = 1.0 if i == j else 0.0
    for _ in range(MAX_SWEEPS):
        if not _sweep(u, v):
            break
    s_max = 0.0
    for j in range(k):
        s_max = max(s_max, _column_norm2(u, j))
    out[:] = 0.0
    for j in range(k):
        s2 = _column_norm2(u, j)
        if s2 > 0.0 and math.sqrt(s2) > PINV_RCOND * math.sqrt(s_max):
            for r in range(k):
                for c in range(k):
                    out[r, c] += v[r, j] * u[c, j] / s2


@njit(**INLINE)
def _column_norm2(u: np.ndarray, j: int) -> float:
    s = 0.0
    for i in range(u.shape[0]):
        s += u[i, j] * u[i, j]
    return s


@njit(**JIT)
def _sweep(u: np.ndarray, v: np.ndarray) -> bool:
    """One cyclic sweep of rotations over every column pair of ``u`` (carried into ``v``);
    whether any turned."""
    k = u.shape[1]
    turned = False
    for p in range(k - 1):
        for q in range(p + 1, k):
            alpha, beta, gamma = 0.0, 0.0, 0.0
            for i in range(u.shape[0]):
                alpha += u[i, p] * u[i, p]
                beta += u[i, q] * u[i, q]
                gamma += u[i, p] * u[i, q]
            if abs(gamma) <= EPS * math.sqrt(alpha * beta):
                continue
            turned = True
            zeta = (beta - alpha) / (2.0 * gamma)
            t = math.copysign(1.0, zeta) / (abs(zeta) + math.sqrt(1.0 + zeta * zeta))
            c = 1.0 / math.sqrt(1.0 + t * t)
            s = c * t
            for m in (u, v):
                for i in range(m.shape[0]):
                    mp, mq = m[i, p], m[i, q]
                    m[i, p], m[i, q] = c * mp - s * mq, s * mp + c * mq
    return turned


@njit(**JIT)
def _normal_system(a: np.ndarray, b: np.ndarray, sq: np.ndarray, rhs: np.ndarray) -> None:
    """``sq``, ``rhs`` = ``a``, ``b`` for a square ``a``, else the normal equations ``aᵀa``, ``aᵀb``."""
    m, k = a.shape
    for i in range(k):
        for j in range(k):
            if m == k:
                sq[i, j] = a[i, j]
            else:
                sq[i, j] = 0.0
                for r in range(m):
                    sq[i, j] += a[r, i] * a[r, j]
        if m == k:
            rhs[i] = b[i]
        else:
            rhs[i] = 0.0
            for r in range(m):
                rhs[i] += a[r, i] * b[r]


@njit(**JIT)
def least_squares(
    a: np.ndarray, b: np.ndarray, out: np.ndarray, sq: np.ndarray, rhs: np.ndarray, svd: np.ndarray
) -> None:
    """``a x = b`` in the least-squares sense (thesis eq. 23a, :func:`dualmech.core.closure.least_squares`).

    ``a`` ``(m, k)``, ``m >= k``: square systems directly, otherwise the normal equations;
    LU with partial pivoting, the pseudo-inverse where a pivot is exactly zero.
    ``sq`` ``(k, k)``, ``rhs`` ``(k,)``, ``svd`` ``(3, k, k)``: scratch.
    """
    _normal_system(a, b, sq, rhs)
    if _lu_solve(sq, rhs, out):
        return
    _normal_system(a, b, sq, rhs)  # the elimination overwrote them
    pinv = svd[0]
    pseudo_inverse(sq, pinv, svd[1], svd[2])
    k = out.size
    for i in range(k):
        out[i] = 0.0
        for j in range(k):
            out[i] += pinv[i, j] * rhs[j]


@njit(**INLINE)
def _lu_solve(a: np.ndarray, b: np.ndarray, out: np.ndarray) -> bool:
    """Gaussian elimination with partial pivoting, in place on ``a`` and ``b``; False at a zero pivot."""
    k = a.shape[0]
    for c in range(k):
        p = c
        for r in range(c + 1, k):
            if abs(a[r, c]) > abs(a[p, c]):
                p = r
        if a[p, c] == 0.0:
            return False
        if p != c:
            for j in range(k):
                a[c, j], a[p, j] = a[p, j], a[c, j]
            b[c], b[p] = b[p], b[c]
        for r in range(c + 1, k):
            f = a[r, c] / a[c, c]
            for j in range(c + 1, k):
                a[r, j] -= f * a[c, j]
            b[r] -= f * b[c]
    for c in range(k - 1, -1, -1):
        s = b[c]
        for j in range(c + 1, k):
            s -= a[c, j] * out[j]
        out[c] = s / a[c, c]
    return True
