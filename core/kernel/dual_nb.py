"""Dual 3-vectors and 3x3 dual matrices for the compiled kernel, one position at a time.

A dual matrix :math:`\\hat M = M + \\varepsilon M^\\circ` is a ``(2, 3, 3)`` array
(``[0]`` primary, ``[1]`` dual part), a dual vector a ``(2, 3)`` array; conventions as
in :mod:`dualmech.core.dual` (``docs/conventions.md``).  Results go into arrays the
caller owns (no allocation): the loops have constant trip counts, which the compiler
unrolls, so the arithmetic stays in registers and the first-level cache.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

#: Compile options of the functions that allocate (the per-thread scratch, made once, from Python):
#: cached on disk, no fastmath (NaN and inf must propagate as in numpy, so that ``not_finite`` rows
#: are seen), the GIL released.
ALLOC = {"cache": True, "nogil": True, "error_model": "numpy"}
#: Compile options of every other kernel function: as :data:`ALLOC`, without numba's reference-counted
#: runtime.  Each array passed to a compiled call otherwise costs two atomic reference-count updates:
#: 63 % of the kernel's time was in them (``perf``, 4·10⁵ positions, 6.6 µs a position without a
#: single Newton step).  Without the runtime nothing can allocate: all scratch arrives from the caller.
#: Two of LLVM's fast-math flags only: ``contract`` (a product and a sum fused into one FMA, rounded
#: once) and ``arcp`` (a quotient as a product with the reciprocal); both change results by an ulp,
#: neither touches NaN, inf or signed zeros (no ``nnan``/``ninf``/``nsz``), so ``not_finite`` rows stay
#: seen.  7 % of a position (1.52 -> 1.42 µs, one thread, 2·10⁵ positions of a fine grid).
JIT = {**ALLOC, "_nrt": False, "fastmath": {"contract", "arcp"}}
#: Inlined into their callers (numba IR): no call at all.  For small helpers, and for the per-position
#: chain (position, closure, warm start, Newton, rates, dynamics): a compiled call passes a scratch
#: tuple's every array by value (about 480 words pushed for the position's call, 290 for Newton's;
#: ``perf`` put 20 % of a position there).
INLINE = {**JIT, "inline": "always"}


@njit(**INLINE)
def copy(src: np.ndarray, dst: np.ndarray) -> None:
    """``dst[:] = src`` for 1-d arrays of one size, element by element (numba's slice assignment
    would allocate a temporary in case the two overlap)."""
    for i in range(dst.size):
        dst[i] = src[i]


@njit(**INLINE)
def matmul(a: np.ndarray, b: np.ndarray, out: np.ndarray) -> None:
    """``out = a @ b`` for 3x3 ``a``, ``b`` (``out`` must not alias either)."""
    for i in range(3):
        for j in range(3):
            out[i, j] = a[i, 0] * b[0, j] + a[i, 1] * b[1, j] + a[i, 2] * b[2, j]


@njit(**INLINE)
def matmul_add(a: np.ndarray, b: np.ndarray, out: np.ndarray) -> None:
    """``out += a @ b`` for 3x3 arrays (``out`` must not alias ``a`` or ``b``)."""
    for i in range(3):
        for j in range(3):
            out[i, j] += a[i, 0] * b[0, j] + a[i, 1] * b[1, j] + a[i, 2] * b[2, j]


@njit(**INLINE)
def matvec(a: np.ndarray, v: np.ndarray, out: np.ndarray) -> None:
    """``out = a @ v`` for a 3x3 ``a`` and a 3-vector ``v``."""
    for i in range(3):
        out[i] = a[i, 0] * v[0] + a[i, 1] * v[1] + a[i, 2] * v[2]


@njit(**INLINE)
def cross(a: np.ndarray, b: np.ndarray, out: np.ndarray) -> None:
    """``out = a x b`` for 3-vectors (``out`` must not alias either)."""
    out[0] = a[1] * b[2] - a[2] * b[1]
    out[1] = a[2] * b[0] - a[0] * b[2]
    out[2] = a[0] * b[1] - a[1] * b[0]


@njit(**INLINE)
def dot(a: np.ndarray, b: np.ndarray) -> float:
    """``a . b`` of 3-vectors."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(**INLINE)
def skew(v: np.ndarray, out: np.ndarray) -> None:
    """``out = [v]x``, the cross-product matrix of the 3-vector ``v``."""
    out[0, 0], out[0, 1], out[0, 2] = 0.0, -v[2], v[1]
    out[1, 0], out[1, 1], out[1, 2] = v[2], 0.0, -v[0]
    out[2, 0], out[2, 1], out[2, 2] = -v[1], v[0], 0.0


@njit(**INLINE)
def vee(m: np.ndarray, out: np.ndarray) -> None:
    """Axial vector of the skew part of the 3x3 ``m`` (:func:`dualmech.core.dual.vee`)."""
    out[0] = 0.5 * (m[2, 1] - m[1, 2])
    out[1] = 0.5 * (m[0, 2] - m[2, 0])
    out[2] = 0.5 * (m[1, 0] - m[0, 1])


@njit(**INLINE)
def origin(m: np.ndarray, tmp: np.ndarray, out: np.ndarray) -> None:
    """Origin ``p`` of the frame of the dual matrix ``m`` ``(2, 3, 3)``: ``vee(m.du @ m.re^T)``."""
    for i in range(3):
        for j in range(3):
            tmp[i, j] = m[1, i, 0] * m[0, j, 0] + m[1, i, 1] * m[0, j, 1] + m[1, i, 2] * m[0, j, 2]
    vee(tmp, out)


@njit(**INLINE)
def rotation(axis: int, angle: float, slide: float, out: np.ndarray) -> None:
    """``out`` ``(2, 3, 3)`` = :math:`X, Y` or :math:`Z(\\theta + \\varepsilon s)` for ``axis`` 0, 1, 2
    (thesis section 2.4)."""
    c, s = math.cos(angle), math.sin(angle)
    cd, sd = -slide * s, slide * c
    out[:] = 0.0
    i, j = (1, 2) if axis == 0 else ((2, 0) if axis == 1 else (0, 1))
    out[0, axis, axis] = 1.0
    out[0, i, i], out[0, j, j], out[0, i, j], out[0, j, i] = c, c, -s, s
    out[1, i, i], out[1, j, j], out[1, i, j], out[1, j, i] = cd, cd, -sd, sd


@njit(**INLINE)
def rodrigues(w: np.ndarray, out: np.ndarray) -> None:
    """``out = exp([w]x)`` for a rotation vector ``w`` (:func:`dualmech.core.loop.rodrigues`)."""
    angle = math.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
    if angle < 1e-8:
        a, b = 1.0 - angle**2 / 6.0, 0.5 - angle**2 / 24.0
    else:
        a, b = math.sin(angle) / angle, (1.0 - math.cos(angle)) / angle**2
    for i in range(3):
        for j in range(3):
            out[i, j] = b * w[i] * w[j]
        out[i, i] += 1.0 - b * angle**2
    out[0, 1] -= a * w[2]
    out[1, 0] += a * w[2]
    out[0, 2] += a * w[1]
    out[2, 0] -= a * w[1]
    out[1, 2] -= a * w[0]
    out[2, 1] += a * w[0]


# -- 3x3 matrices as 9-tuples (row-major): values in registers, no memory traffic ---------


@njit(**INLINE)
def tmul(a: tuple, b: tuple) -> tuple:
    """Product of 3x3 matrices given as row-major 9-tuples."""
    return (
        a[0] * b[0] + a[1] * b[3] + a[2] * b[6],
        a[0] * b[1] + a[1] * b[4] + a[2] * b[7],
        a[0] * b[2] + a[1] * b[5] + a[2] * b[8],
        a[3] * b[0] + a[4] * b[3] + a[5] * b[6],
        a[3] * b[1] + a[4] * b[4] + a[5] * b[7],
        a[3] * b[2] + a[4] * b[5] + a[5] * b[8],
        a[6] * b[0] + a[7] * b[3] + a[8] * b[6],
        a[6] * b[1] + a[7] * b[4] + a[8] * b[7],
        a[6] * b[2] + a[7] * b[5] + a[8] * b[8],
    )


@njit(**INLINE)
def tadd(a: tuple, b: tuple) -> tuple:
    """Sum of two 9-tuples."""
    return (
        a[0] + b[0],
        a[1] + b[1],
        a[2] + b[2],
        a[3] + b[3],
        a[4] + b[4],
        a[5] + b[5],
        a[6] + b[6],
        a[7] + b[7],
        a[8] + b[8],
    )


@njit(**INLINE)
def trotation(axis: int, angle: float, slide: float) -> tuple:
    """Primary and dual parts of :math:`X, Y` or :math:`Z(\\theta + \\varepsilon s)` (``axis`` 0, 1, 2),
    as 9-tuples."""
    return trotation_cs(axis, math.cos(angle), math.sin(angle), slide)


@njit(**INLINE)
def trotation_cs(axis: int, c: float, s: float, slide: float) -> tuple:
    """:func:`trotation` from the cosine ``c`` and sine ``s`` of the angle (``1, 0`` for a zero angle: no
    trigonometry, and the same bits, since ``cos 0`` and ``sin 0`` are exact)."""
    cd, sd = -slide * s, slide * c
    if axis == 0:
        return (1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c), (0.0, 0.0, 0.0, 0.0, cd, -sd, 0.0, sd, cd)
    if axis == 1:
        return (c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c), (cd, 0.0, sd, 0.0, 0.0, 0.0, -sd, 0.0, cd)
    return (c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0), (cd, -sd, 0.0, sd, cd, 0.0, 0.0, 0.0, 0.0)


@njit(**INLINE)
def trodrigues(w0: float, w1: float, w2: float) -> tuple:
    """:math:`\\exp([w]_\\times)` as a 9-tuple (:func:`dualmech.core.loop.rodrigues`)."""
    angle = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
    if angle < 1e-8:
        a, b = 1.0 - angle**2 / 6.0, 0.5 - angle**2 / 24.0
    else:
        a, b = math.sin(angle) / angle, (1.0 - math.cos(angle)) / angle**2
    d = 1.0 - b * angle**2
    return (
        d + b * w0 * w0,
        b * w0 * w1 - a * w2,
        b * w0 * w2 + a * w1,
        b * w1 * w0 + a * w2,
        d + b * w1 * w1,
        b * w1 * w2 - a * w0,
        b * w2 * w0 - a * w1,
        b * w2 * w1 + a * w0,
        d + b * w2 * w2,
    )
