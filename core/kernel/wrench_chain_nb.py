"""Every joint's wrench of a loop whose Newton-Euler system is square, along the chain, compiled.

The per-position Newton-Euler system of :mod:`~dualmech.core.kernel.wrenches_nb` (its weighted ``a``, ``b``:
link ``l``'s six equations say that the wrench of joint ``l`` less that of joint ``l + 1`` is ``b_l``) is
block-bidiagonal: every joint's wrench follows from the first joint's by the links' equations in turn,
:math:`V_r = V_0 - \\sum_{l<r} b_l`.  What is left are the joints' freedoms: a joint's wrench does no work
on its own screws but through its solved efforts, :math:`\\langle V_r, \\hat s_j\\rangle = x_e` for the screw
``j`` of a solved effort ``e``, 0 for every other.  Where the system is square (as many unknowns as
equations: no idle freedom, such as the spin of an S-S link) this is one equation per screw for the six
components of ``V_0`` and the solved efforts: a system ``G`` as small as the closure Jacobian, solved by LU,
in place of the Householder QR of the whole system.  The constraint components are then each joint's
wrench read along its axes (the unit wrenches of a joint are orthonormal: forces along its axes at its
point, moments about them, each effort along its own screw).

The transmission ``|R_kk| / |a_k|`` of the QR (:mod:`~dualmech.core.kernel.wrenches_nb`) is read from the
same factors: for a square ``a``, ``1 / |R_kk|`` is the norm of the last row of ``a^-1``, the solution ``z``
of ``a^T z = e_k``.  Its links' parts are a motion of the loop (a twist per link, its moment rows times the
length scale): the one whose solved effort screws are still but the last, at unit rate, which ``G^T`` gives,
its joint rates ``q`` from ``G^T q = -e_k``.

An S-S link's idle spin (a spin gauge, :attr:`~dualmech.core.kernel.loop_nb.FlatLoop.gauges`) makes the
system one equation longer than its unknowns: the link's spin about the line through its ball centres is a
twist :math:`\\hat z` on its six equations that no unknown wrench works on (both balls' forces meet that
line), so ``a^T z = 0`` and the least squares leaves ``b``'s part along ``z`` as its residual.  So ``b``
loses that part first (:func:`_consistent`), which makes the system consistent with the same least-squares
solution; in ``G`` the same spin is a combination of the two balls' screws (``u . s_j`` on the first ball's,
``-u . s_j`` on the second's, ``u`` the link's axis), one column more per spin (its answer 0) makes ``G``
square.  The transmission's motion is then one of a family (plus any spin): the one that ``a``'s range
holds, the least, is its links' twists less their part along ``z``.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from dualmech.core.kernel.dual_nb import INLINE
from dualmech.core.kernel.linalg_nb import factorize, solve_factored, solve_transposed
from dualmech.core.kernel.loop_nb import ROW, SPHERICAL, FlatLoop
from dualmech.core.kernel.wrench_system_nb import FORCE


class ChainWork(NamedTuple):
    """Scratch of one thread (``M`` screws)."""

    g: np.ndarray  # (M, M): the screws' equations
    sq: np.ndarray  # (M, M): their LU factors
    svd: np.ndarray  # (3, M, M): linalg_nb.factorize's scratch
    piv: np.ndarray  # (M,) int
    h: np.ndarray  # (M,): right-hand side
    u: np.ndarray  # (M,): V_0 and the solved efforts; then the unit motion's rates
    rhs: np.ndarray  # (M,)
    v: np.ndarray  # (2, 6): a joint's wrench; a link's motion
    b: np.ndarray  # (m,): the right-hand side less its part along the idle spins


def make_chain_work(screws: int, equations: int) -> ChainWork:
    """Allocate a :class:`ChainWork` for a loop of ``screws`` screws and ``equations`` Newton-Euler
    equations."""
    z = np.zeros
    return ChainWork(z((screws, screws)), z((screws, screws)), z((3, screws, screws)),
                     z(screws, dtype=np.int64), z(screws), z(screws), z(screws), z((2, 6)), z(equations))


@njit(**INLINE)
def _screw(lines: np.ndarray, j: int, length: float, i: int) -> float:
    """Entry ``i`` of screw ``j`` paired with a weighted wrench: its velocity at O, then its turn times the
    length scale (the moment rows are over it)."""
    return lines[j, 1, i] if i < 3 else length * lines[j, 0, i - 3]


@njit(**INLINE)
def _spin(points: np.ndarray, spin_axes: np.ndarray, g: int, r: int, length: float, i: int) -> float:
    """Entry ``i`` of the idle spin ``g`` of link ``r`` (about ``spin_axes[g]`` through its first ball
    centre ``points[r]``) paired with a weighted wrench, as :func:`_screw`."""
    if i >= 3:
        return length * spin_axes[g, i - 3]
    p, u, i1, i2 = points[r], spin_axes[g], (i + 1) % 3, (i + 2) % 3
    return p[i1] * u[i2] - p[i2] * u[i1]


@njit(**INLINE)
def _balls_only(fl: FlatLoop, r: int) -> bool:
    """Whether link ``r`` moves (not the last row's) and rows ``r`` and ``r + 1`` are balls with their three
    screws only."""
    if r + 1 >= fl.table.shape[0] or not (fl.table[r, SPHERICAL] and fl.table[r + 1, SPHERICAL]):
        return False
    count = 0
    for j in range(fl.screws.shape[0]):
        count += fl.screws[j, ROW] == r or fl.screws[j, ROW] == r + 1
    return count == 6


@njit(**INLINE)
def _consistent(fl: FlatLoop, b: np.ndarray, points: np.ndarray, spin_axes: np.ndarray, length: float,
                cw: ChainWork) -> bool:
    """``b`` less its part along each idle spin's twist ``z`` (module docstring) into ``cw.b``; whether every
    spin is an S-S link's (else the QR solves)."""
    for i in range(b.size):
        cw.b[i] = b[i]
    for g in range(fl.gauges.size):
        r = fl.gauges[g]
        if not _balls_only(fl, r):
            return False
        zb, zz = 0.0, 0.0
        for i in range(6):
            z = _spin(points, spin_axes, g, r, length, i)
            zb += z * b[6 * r + i]
            zz += z * z
        for i in range(6):
            cw.b[6 * r + i] -= _spin(points, spin_axes, g, r, length, i) * (zb / zz)
    return True


@njit(**INLINE)
def _system(fl: FlatLoop, columns: np.ndarray, efforts: int, lines: np.ndarray, spin_axes: np.ndarray,
            length: float, cw: ChainWork) -> None:
    """``G`` and its right-hand side ``<sum_{l<r} b_l, s_j>`` per screw ``j`` of row ``r`` (``b``:
    ``cw.b``), with a column per idle spin."""
    screws, b, g, h, total = fl.screws, cw.b, cw.g, cw.h, cw.v[0]
    g[:] = 0.0
    total[:] = 0.0
    row = 0
    for j in range(screws.shape[0]):
        while row < screws[j, 0]:
            for i in range(6):
                total[i] += b[6 * row + i]
            row += 1
        h[j] = 0.0
        for i in range(6):
            g[j, i] = _screw(lines, j, length, i)
            h[j] += total[i] * g[j, i]
    for c in range(efforts, columns.shape[0]):
        g[columns[c, 2], 6 + c - efforts] = -1.0
    for spin in range(fl.gauges.size):  # u . s_j on the first ball's screws, -u . s_j on the second's
        r, u = fl.gauges[spin], spin_axes[spin]
        for j in range(screws.shape[0]):
            if screws[j, ROW] == r or screws[j, ROW] == r + 1:
                d = u[0] * lines[j, 0, 0] + u[1] * lines[j, 0, 1] + u[2] * lines[j, 0, 2]
                g[j, 6 + columns.shape[0] - efforts + spin] = d if screws[j, ROW] == r else -d


@njit(**INLINE)
def _components(columns: np.ndarray, efforts: int, b: np.ndarray, points: np.ndarray, axes: np.ndarray,
                length: float, cw: ChainWork, x: np.ndarray) -> None:
    """The constraint components into ``x[:efforts]`` from ``V_0`` (``cw.u[:6]``), joint by joint, and the
    solved efforts into ``x[efforts:]``."""
    wrench = cw.v[0]
    for i in range(6):
        wrench[i] = cw.u[i]
    row = 0
    for c in range(efforts):
        while row < columns[c, 0]:
            for i in range(6):
                wrench[i] -= b[6 * row + i]
            row += 1
        p, a = points[row], columns[c, 2]
        f0, f1, f2 = wrench[0], wrench[1], wrench[2]
        if columns[c, 1] == FORCE:
            x[c] = f0 * axes[row, 0, a] + f1 * axes[row, 1, a] + f2 * axes[row, 2, a]
        else:  # the moment about the joint's point
            m0 = length * wrench[3] - (p[1] * f2 - p[2] * f1)
            m1 = length * wrench[4] - (p[2] * f0 - p[0] * f2)
            m2 = length * wrench[5] - (p[0] * f1 - p[1] * f0)
            x[c] = m0 * axes[row, 0, a] + m1 * axes[row, 1, a] + m2 * axes[row, 2, a]
    for c in range(efforts, columns.shape[0]):
        x[c] = cw.u[6 + c - efforts]


@njit(**INLINE)
def _link_norm2(fl: FlatLoop, twist: np.ndarray, r: int, points: np.ndarray, spin_axes: np.ndarray,
                length: float) -> float:
    """Squared norm of link ``r``'s ``twist`` less its part along the link's idle spin, if it has one."""
    spin, zt, zz = -1, 0.0, 0.0
    for g in range(fl.gauges.size):
        if fl.gauges[g] == r:
            spin = g
    if spin >= 0:
        for i in range(6):
            z = _spin(points, spin_axes, spin, r, length, i)
            zt += z * twist[i]
            zz += z * z
    total = 0.0
    for i in range(6):
        d = twist[i] - (_spin(points, spin_axes, spin, r, length, i) * (zt / zz) if spin >= 0 else 0.0)
        total += d * d
    return total


@njit(**INLINE)
def _motion_norm(fl: FlatLoop, lines: np.ndarray, links: int, points: np.ndarray, spin_axes: np.ndarray,
                 length: float, cw: ChainWork) -> float:
    """``|z|``: the norm of the links' twists (moment rows times ``length``) of the joint rates ``cw.u``,
    each less its part along its idle spin."""
    screws, twist, total, row = fl.screws, cw.v[1], 0.0, 0
    twist[:] = 0.0
    for j in range(screws.shape[0]):
        while row < screws[j, 0]:
            if row < links:
                total += _link_norm2(fl, twist, row, points, spin_axes, length)
            row += 1
        for i in range(6):
            twist[i] += cw.u[j] * _screw(lines, j, length, i)
    while row < links:
        total += _link_norm2(fl, twist, row, points, spin_axes, length)
        row += 1
    return math.sqrt(total)


@njit(**INLINE)
def chain_solve(fl: FlatLoop, columns: np.ndarray, efforts: int, lines: np.ndarray, spin_axes: np.ndarray,
                a: np.ndarray, b: np.ndarray, points: np.ndarray, axes: np.ndarray, length: float,
                cw: ChainWork, x: np.ndarray) -> float:
    """The unknowns of the weighted system ``a x = b`` (square, or one equation longer per S-S link's idle
    spin) into ``x`` (module docstring) and the transmission ``|R_kk| / |a_k|``; NaN where ``G`` has a zero
    pivot, an answer is not finite or a spin is not an S-S link's (the caller then solves by QR).
    ``fl``'s screws and gauges, ``lines`` ``(M, 2, 3)`` and ``spin_axes`` ``(G, 3)`` (the gauges' axes) at
    this position, ``columns`` ``(k, 3)`` and ``efforts`` (the first solved effort's column) as in
    :mod:`~dualmech.core.kernel.wrenches_nb`, ``points`` ``(R, 3)``, ``axes`` ``(R, 3, 3)`` the joints'."""
    m, k = a.shape
    last = 6 + k - efforts - 1  # the last solved effort's unknown in G's
    if last + 1 + fl.gauges.size != fl.screws.shape[0] or not _consistent(fl, b, points, spin_axes, length,
                                                                           cw):
        return math.nan
    _system(fl, columns, efforts, lines, spin_axes, length, cw)
    if not factorize(cw.g, cw.sq, cw.svd, cw.piv):
        return math.nan
    solve_factored(cw.g, cw.h, cw.u, cw.sq, cw.rhs, cw.svd, cw.piv, True)
    _components(columns, efforts, cw.b, points, axes, length, cw, x)
    cw.rhs[:] = 0.0
    cw.rhs[last] = -1.0  # the last solved effort's screw at unit rate, the others' still
    solve_transposed(cw.sq, cw.piv, cw.rhs, cw.u)
    column = 0.0
    for i in range(m):
        column += a[i, k - 1] * a[i, k - 1]
    transmission = 1.0 / (_motion_norm(fl, lines, m // 6, points, spin_axes, length, cw) * math.sqrt(column))
    finite = math.isfinite(transmission)
    for c in range(k):
        finite = finite and math.isfinite(x[c])
    return transmission if finite else math.nan
