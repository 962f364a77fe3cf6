"""The layout of a loop's Newton-Euler system at one position, compiled: the kinds of its columns, where the
solved efforts start, the relative residual of a solution (:mod:`~dualmech.core.kernel.wrenches_nb`, whose
least squares and :mod:`~dualmech.core.kernel.wrench_chain_nb`, whose square solve, share them)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from dualmech.core.kernel.dual_nb import INLINE

#: Kinds of a wrench column (:attr:`~dualmech.core.kernel.wrenches_nb.WrenchSpec.columns`): a force along a
#: joint axis, a moment about one, a torque about a turning coordinate's screw, a force along a sliding
#: coordinate's screw.
FORCE, MOMENT, TURN, SLIDE = 0, 1, 2, 3
#: numpy's smallest normal double (``np.finfo(float).tiny``): the floor of a singular ``R``'s diagonal.
TINY = 2.2250738585072014e-308


@njit(**INLINE)
def first_effort(columns: np.ndarray) -> int:
    """The first solved effort's column (the columns' count without one)."""
    efforts = columns.shape[0]
    for c in range(columns.shape[0] - 1, -1, -1):
        if columns[c, 1] == TURN or columns[c, 1] == SLIDE:
            efforts = c
    return efforts


@njit(**INLINE)
def residual_of(a: np.ndarray, b: np.ndarray, columns: np.ndarray, efforts: int, x: np.ndarray,
                finite: bool) -> float:
    """``|a x - b| / |b|``, link by link on the columns of its two joints and the efforts (every column where
    an unknown is not ``finite``: a zero times it is NaN, as in the dense sums)."""
    rr, bb, lo, hi = 0.0, 0.0, 0, 0
    for i in range(0, a.shape[0], 6):  # link i / 6: the columns of its two joints and the efforts
        while lo < efforts and columns[lo, 0] < i // 6:
            lo += 1
        while hi < efforts and columns[hi, 0] < i // 6 + 2:
            hi += 1
        rr = _link_residual(a, b, x, i, lo if finite else 0, hi if finite else efforts, efforts, rr)
    for i in range(a.shape[0]):
        bb += b[i] * b[i]
    return math.sqrt(rr) / max(math.sqrt(bb), TINY)


@njit(**INLINE)
def _six_sums(a: np.ndarray, x: np.ndarray, i: int, lo: int, hi: int, s0: float, s1: float, s2: float,
              s3: float, s4: float, s5: float) -> tuple[float, float, float, float, float, float]:
    """``s0`` to ``s5`` plus ``a[i + k, j] * x[j]`` over the columns ``lo`` to ``hi - 1``, in order, the six
    sums interleaved."""
    for j in range(lo, hi):
        xj = x[j]
        s0 += a[i, j] * xj
        s1 += a[i + 1, j] * xj
        s2 += a[i + 2, j] * xj
        s3 += a[i + 3, j] * xj
        s4 += a[i + 4, j] * xj
        s5 += a[i + 5, j] * xj
    return s0, s1, s2, s3, s4, s5


@njit(**INLINE)
def _link_residual(a: np.ndarray, b: np.ndarray, x: np.ndarray, i: int, lo: int, hi: int, efforts: int,
                   rr: float) -> float:
    """``rr`` plus the squared residuals of a link's equations ``i`` to ``i + 5``, summed over the columns
    ``lo`` to ``hi - 1`` and ``efforts`` on, in order (:func:`_six_sums`)."""
    s0, s1, s2, s3, s4, s5 = _six_sums(a, x, i, lo, hi, -b[i], -b[i + 1], -b[i + 2], -b[i + 3], -b[i + 4],
                                       -b[i + 5])
    s0, s1, s2, s3, s4, s5 = _six_sums(a, x, i, efforts, a.shape[1], s0, s1, s2, s3, s4, s5)
    rr += s0 * s0
    rr += s1 * s1
    rr += s2 * s2
    rr += s3 * s3
    rr += s4 * s4
    rr += s5 * s5
    return rr
