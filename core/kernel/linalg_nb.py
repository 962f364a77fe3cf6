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


@njit(**INLINE)
def _normal_matrix(a: np.ndarray, sq: np.ndarray) -> None:
    """``sq`` = ``a`` for a square ``a``, else the normal matrix ``aᵀa``."""
    m, k = a.shape
    for i in range(k):
        for j in range(k):
            if m == k:
                sq[i, j] = a[i, j]
            else:
                sq[i, j] = 0.0
                for r in range(m):
                    sq[i, j] += a[r, i] * a[r, j]


@njit(**INLINE)
def _normal_rhs(a: np.ndarray, b: np.ndarray, rhs: np.ndarray) -> None:
    """``rhs`` = ``b`` for a square ``a``, else ``aᵀb``."""
    m, k = a.shape
    for i in range(k):
        if m == k:
            rhs[i] = b[i]
        else:
            rhs[i] = 0.0
            for r in range(m):
                rhs[i] += a[r, i] * b[r]


@njit(**INLINE)
def factorize(a: np.ndarray, sq: np.ndarray, svd: np.ndarray, piv: np.ndarray) -> bool:
    """Factor ``a`` ``(m, k)``, ``m >= k``, for :func:`solve_factored` (thesis eq. 23a): the system itself if
    square, else its normal matrix, by LU with partial pivoting into ``sq`` and ``piv`` ``(k,)``; where a
    pivot is exactly zero, the pseudo-inverse into ``svd[0]`` instead.  Returns whether LU succeeded.

    One factorization serves any number of right-hand sides (the rates and the accelerations share
    their matrix).  ``svd`` ``(3, k, k)``: scratch.
    """
    _normal_matrix(a, sq)
    if _lu_factor(sq, piv):
        return True
    _normal_matrix(a, sq)  # the elimination overwrote it
    pseudo_inverse(sq, svd[0], svd[1], svd[2])
    return False


@njit(**INLINE)
def solve_factored(
    a: np.ndarray,
    b: np.ndarray,
    out: np.ndarray,
    sq: np.ndarray,
    rhs: np.ndarray,
    svd: np.ndarray,
    piv: np.ndarray,
    lu: bool,
) -> None:
    """``a x = b`` in the least-squares sense into ``out``, with the factors of :func:`factorize` (``lu``:
    what it returned); ``rhs`` ``(k,)``: scratch."""
    _normal_rhs(a, b, rhs)
    if lu:
        _lu_apply(sq, piv, rhs, out)
        return
    pinv, k = svd[0], out.size
    for i in range(k):
        out[i] = 0.0
        for j in range(k):
            out[i] += pinv[i, j] * rhs[j]


@njit(**JIT)
def least_squares(
    a: np.ndarray,
    b: np.ndarray,
    out: np.ndarray,
    sq: np.ndarray,
    rhs: np.ndarray,
    svd: np.ndarray,
    piv: np.ndarray,
) -> bool:
    """``a x = b`` in the least-squares sense (thesis eq. 23a, :func:`dualmech.core.closure.least_squares`).

    ``a`` ``(m, k)``, ``m >= k``: square systems directly, otherwise the normal equations;
    LU with partial pivoting, the pseudo-inverse where a pivot is exactly zero
    (:func:`factorize`, :func:`solve_factored`).  ``sq`` ``(k, k)``, ``rhs`` ``(k,)``,
    ``svd`` ``(3, k, k)``, ``piv`` ``(k,)`` int: scratch.  Returns whether LU served (:func:`factorize`): then
    ``sq``, ``piv`` hold the LU factors of ``a`` (square) or of its normal matrix.
    """
    lu = factorize(a, sq, svd, piv)
    solve_factored(a, b, out, sq, rhs, svd, piv, lu)
    return lu


@njit(**INLINE)
def _lu_factor(a: np.ndarray, piv: np.ndarray) -> bool:
    """Gaussian elimination with partial pivoting, in place: ``U`` on and above the diagonal, each step's
    multipliers below it, the pivot rows in ``piv``; False at a zero pivot.  Rows swap from the pivot
    column on: the multipliers stay where their step wrote them, so that :func:`_lu_apply` repeats the
    elimination of a right-hand side operation for operation."""
    k = a.shape[0]
    for c in range(k):
        p = c
        for r in range(c + 1, k):
            if abs(a[r, c]) > abs(a[p, c]):
                p = r
        piv[c] = p
        if a[p, c] == 0.0:
            return False
        if p != c:
            for j in range(c, k):
                a[c, j], a[p, j] = a[p, j], a[c, j]
        for r in range(c + 1, k):
            f = a[r, c] / a[c, c]
            a[r, c] = f
            for j in range(c + 1, k):
                a[r, j] -= f * a[c, j]
    return True


@njit(**INLINE)
def _lu_apply(a: np.ndarray, piv: np.ndarray, b: np.ndarray, out: np.ndarray) -> None:
    """Solve with the factors of :func:`_lu_factor`: ``b`` (overwritten) through the row swaps and
    multipliers, then back substitution into ``out``."""
    k = a.shape[0]
    for c in range(k):
        p = piv[c]
        if p != c:
            b[c], b[p] = b[p], b[c]
        for r in range(c + 1, k):
            b[r] -= a[r, c] * b[c]
    for c in range(k - 1, -1, -1):
        s = b[c]
        for j in range(c + 1, k):
            s -= a[c, j] * out[j]
        out[c] = s / a[c, c]


@njit(**JIT)
def determinant_sign(a: np.ndarray, sq: np.ndarray, piv: np.ndarray) -> int:
    """Sign of the determinant of the square ``a`` ``(k, k)``: -1, 0 or 1 (``np.sign(np.linalg.det(a))``),
    from its LU factors with partial pivoting (the diagonal's signs and the row swaps); ``sq`` ``(k, k)``
    and ``piv`` ``(k,)`` int: scratch."""
    k = a.shape[0]
    for i in range(k):
        for j in range(k):
            sq[i, j] = a[i, j]
    if not _lu_factor(sq, piv):
        return 0
    return lu_sign(sq, piv)


@njit(**INLINE)
def lu_sign(lu: np.ndarray, piv: np.ndarray) -> int:
    """Sign of the determinant of a square matrix from its LU factors with partial pivoting (``lu``, ``piv``
    of :func:`_lu_factor`, every pivot non-zero): the diagonal's signs and the row swaps."""
    sign = 1
    for c in range(lu.shape[0]):
        if piv[c] != c:
            sign = -sign
        if lu[c, c] < 0.0:
            sign = -sign
    return sign


@njit(**INLINE)
def solve_transposed(lu: np.ndarray, piv: np.ndarray, b: np.ndarray, out: np.ndarray) -> None:
    """``a^T out = b`` with the factors of :func:`_lu_factor` of a square ``a`` (``lu``, ``piv``): the
    elimination left ``T a = U``, ``T`` its row swaps and multipliers in turn, so ``U^T y = b`` forward, then
    ``out = T^T y``, the steps' transposes in reverse order.  ``b`` is left as it was."""
    k = lu.shape[0]
    for c in range(k):
        s = b[c]
        for j in range(c):
            s -= lu[j, c] * out[j]
        out[c] = s / lu[c, c]
    for c in range(k - 1, -1, -1):
        s = out[c]
        for r in range(c + 1, k):
            s -= lu[r, c] * out[r]
        out[c] = s
        p = piv[c]
        if p != c:
            out[c], out[p] = out[p], out[c]
