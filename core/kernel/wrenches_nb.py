"""Every joint's reaction wrench of any single loop at one position, compiled (thesis section 2.8).

The per-position form of :func:`dualmech.core.loop_reactions.solve_joint_wrenches` (its module docstring
has the equations): the unknown wrench columns of every joint (constraint components in the joint's frame,
then the solved efforts, the transmission's last), D'Alembert's equation of every moving link (the dual
momentum rate of :func:`~dualmech.core.kernel.dynamics_nb.required_wrench` less the given efforts), the
moment rows over the length scale, and one Householder QR factorization (as LAPACK's ``geqrf`` that numpy
calls) for the least-squares solution, the relative residual and the transmission
``|R_kk| / |a_k|``; a system square but for the S-S links' idle spins is solved along the chain instead, by an
LU as small as the closure Jacobian's (:mod:`~dualmech.core.kernel.wrench_chain_nb`: the same solution and
transmission, by other rounding), the QR where that one is singular or another idle freedom makes it longer.
The structure of the columns is data (:class:`WrenchSpec`), built from the table by
:mod:`dualmech.core.kernel.loop_engine`.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from dualmech.core.kernel.closure_nb import Work
from dualmech.core.kernel.dual_nb import INLINE, trotation
from dualmech.core.kernel.dynamics_nb import required_wrench
from dualmech.core.kernel.loop_nb import FlatLoop, entry, frame_origin
from dualmech.core.kernel.wrench_chain_nb import ChainWork, chain_solve, make_chain_work
from dualmech.core.kernel.wrench_system_nb import FORCE, MOMENT, SLIDE, TINY, TURN, first_effort, residual_of


class WrenchSpec(NamedTuple):
    """The columns of a table's Newton-Euler system (``R`` rows, ``k`` unknowns, ``g`` given efforts, ``B``
    moving links = ``R - 1``).

    ``columns`` ``(k, 3)`` int: per unknown its row, its kind (:data:`FORCE` ...) and its joint axis (0, 1,
    2) or screw (the index of :attr:`~dualmech.core.kernel.loop_nb.FlatLoop.screws`); ``given`` ``(g, 3)``
    the same for the given efforts (kinds :data:`TURN`, :data:`SLIDE`); ``eta_screw`` ``(R,)`` the screw of
    each row's moving ``eta`` (a U joint), -1 for none; ``mass`` ``(B,)``, ``com`` ``(B, 3)``, ``inertia``
    ``(B, 3, 3)`` of the moving links in their link frames; ``gravity`` ``(3,)``.
    """

    columns: np.ndarray
    given: np.ndarray
    eta_screw: np.ndarray
    mass: np.ndarray
    com: np.ndarray
    inertia: np.ndarray
    gravity: np.ndarray


class WrenchWork(NamedTuple):
    """Scratch of one thread (``m = 6 B`` equations)."""

    axes: np.ndarray  # (R, 3, 3): each joint's axes as columns
    points: np.ndarray  # (R, 3): each joint's point
    units: np.ndarray  # (k, 2, 3): each unknown's unit wrench
    known: np.ndarray  # (R, 2, 3): each row's given wrench
    a: np.ndarray  # (m, k): the weighted system
    qr: np.ndarray  # (m, k): its Householder factors
    b: np.ndarray  # (m,): the weighted right-hand side
    qb: np.ndarray  # (m,): Q^T b
    x: np.ndarray  # (k,): the solution
    force: np.ndarray  # (R, 3): each joint's force
    moment: np.ndarray  # (R, 3): its moment about the joint's point
    need: np.ndarray  # (2, 3): a link's required wrench
    scratch: np.ndarray  # (8, 3)
    rot: np.ndarray  # (3, 3): a link frame's rotation
    org: np.ndarray  # (3,): its origin
    chain: ChainWork  # a square system's solve along the chain


def make_wrench_work(rows: int, unknowns: int, screws: int) -> WrenchWork:
    """Allocate a :class:`WrenchWork` for ``rows`` table rows, ``unknowns`` wrench columns and ``screws``
    screws."""
    m = 6 * (rows - 1)
    z = np.zeros
    return WrenchWork(z((rows, 3, 3)), z((rows, 3)), z((unknowns, 2, 3)), z((rows, 2, 3)), z((m, unknowns)),
                      z((m, unknowns)), z(m), z(m), z(unknowns), z((rows, 3)), z((rows, 3)), z((2, 3)),
                      z((8, 3)), z((3, 3)), z(3), make_chain_work(screws, m))


@njit(**INLINE)
def _joints(fl: FlatLoop, spec: WrenchSpec, vals: np.ndarray, x: np.ndarray, w: Work, ww: WrenchWork) -> None:
    """Each row's joint axes and point (:func:`~dualmech.core.loop_reactions.joint_points`,
    ``_joint_axes``): the frame before the row, for a U joint ``x' = y' x z``, ``y'`` its eta screw, and
    its point moved by the row's offset along ``z``."""
    for r in range(fl.table.shape[0]):
        o = frame_origin(w.frames, r - 1)
        for i in range(3):
            ww.points[r, i] = o[i]
            for j in range(3):
                ww.axes[r, i, j] = w.frames[r - 1, 0, i, j] if r else (1.0 if i == j else 0.0)
        e = spec.eta_screw[r]
        if e < 0:
            continue
        s = entry(fl.table, fl.const, vals, x, r, 1)
        y = w.lines[e, 0]
        for i in range(3):
            ww.points[r, i] += s * ww.axes[r, i, 2]
        z0, z1, z2 = ww.axes[r, 0, 2], ww.axes[r, 1, 2], ww.axes[r, 2, 2]
        ww.axes[r, 0, 0], ww.axes[r, 1, 0], ww.axes[r, 2, 0] = y[1] * z2 - y[2] * z1, y[2] * z0 - y[0] * z2, \
            y[0] * z1 - y[1] * z0
        for i in range(3):
            ww.axes[r, i, 1] = y[i]


@njit(**INLINE)
def _unit(kind: int, ref: int, r: int, w: Work, ww: WrenchWork, out: np.ndarray) -> None:
    """``out`` ``(2, 3)``: the unit wrench of a column (:data:`FORCE` ...) of row ``r``, moments about O."""
    p = ww.points[r]
    if kind == FORCE or kind == MOMENT:
        d0, d1, d2 = ww.axes[r, 0, ref], ww.axes[r, 1, ref], ww.axes[r, 2, ref]
    elif kind == TURN:
        d0, d1, d2 = w.lines[ref, 0, 0], w.lines[ref, 0, 1], w.lines[ref, 0, 2]
    else:
        d0, d1, d2 = w.lines[ref, 1, 0], w.lines[ref, 1, 1], w.lines[ref, 1, 2]
    if kind == MOMENT or kind == TURN:
        out[0, 0], out[0, 1], out[0, 2] = 0.0, 0.0, 0.0
        out[1, 0], out[1, 1], out[1, 2] = d0, d1, d2
    else:
        out[0, 0], out[0, 1], out[0, 2] = d0, d1, d2
        out[1, 0], out[1, 1], out[1, 2] = p[1] * d2 - p[2] * d1, p[2] * d0 - p[0] * d2, p[0] * d1 - p[1] * d0


@njit(**INLINE)
def _equations(fl: FlatLoop, spec: WrenchSpec, vals: np.ndarray, x: np.ndarray, given: np.ndarray,
               length: float, w: Work, ww: WrenchWork) -> None:
    """The weighted system ``ww.a``, ``ww.b`` (``_equations`` and the weights of
    :func:`~dualmech.core.loop_reactions.solve_joint_wrenches`)."""
    n_rows, a, b, known = fl.table.shape[0], ww.a, ww.b, ww.known
    known[:] = 0.0
    for g in range(spec.given.shape[0]):
        r = spec.given[g, 0]
        _unit(spec.given[g, 1], spec.given[g, 2], r, w, ww, ww.need)
        for p in range(2):
            for i in range(3):
                known[r, p, i] += ww.need[p, i] * given[g]
    a[:] = 0.0
    for c in range(spec.columns.shape[0]):
        r = spec.columns[c, 0]
        unit = ww.units[c]
        _unit(spec.columns[c, 1], spec.columns[c, 2], r, w, ww, unit)
        for target, sign in ((r, 1.0), (r - 1, -1.0)):
            if 0 <= target < n_rows - 1:
                for p in range(2):
                    for i in range(3):
                        a[6 * target + 3 * p + i, c] += sign * unit[p, i]
    for r in range(n_rows - 1):
        alpha, slide = entry(fl.table, fl.const, vals, x, r, 3), entry(fl.table, fl.const, vals, x, r, 4)
        rx = trotation(0, alpha, 0.0)[0]
        o = frame_origin(w.frames, r)
        for i in range(3):
            for j in range(3):  # frame.re @ Rx(alpha)^T
                ww.rot[i, j] = w.frames[r, 0, i, 0] * rx[3 * j] + w.frames[r, 0, i, 1] * rx[3 * j + 1] + \
                    w.frames[r, 0, i, 2] * rx[3 * j + 2]
            ww.org[i] = o[i] - slide * w.frames[r, 0, i, 0]
        required_wrench(spec.mass[r], spec.com[r], spec.inertia[r], ww.rot, ww.org, w.twists[r], w.accels[r],
                        spec.gravity, ww.scratch, ww.need)
        for p in range(2):
            for i in range(3):
                b[6 * r + 3 * p + i] = ww.need[p, i] - known[r, p, i] + known[r + 1, p, i]
    weight = 1.0 / length
    for row in range(a.shape[0]):
        if row % 6 >= 3:
            b[row] *= weight
            for c in range(a.shape[1]):
                a[row, c] *= weight


@njit(**INLINE)
def _first_row(columns: np.ndarray, c: int) -> int:
    """The first equation that column ``c`` touches: link ``r - 1``'s for a joint of row ``r``."""
    return max(6 * columns[c, 0] - 6, 0)


@njit(**INLINE)
def _reflect(qr: np.ndarray, j: int, end: int, tau: float, c0: int, c1: int) -> None:
    """Columns ``c0`` to ``c1 - 1`` of ``qr`` times ``H = I - tau v v^T``, ``v = (1, qr[j+1:end, j])`` on rows
    ``j`` to ``end - 1``, four columns at a time: each column's sum is taken in the same order as one column
    at a time (the same numbers to the bit), the four chains of dependent additions interleaved."""
    c = c0
    while c + 4 <= c1:
        s0, s1, s2, s3 = qr[j, c], qr[j, c + 1], qr[j, c + 2], qr[j, c + 3]
        for i in range(j + 1, end):
            v = qr[i, j]
            s0 += v * qr[i, c]
            s1 += v * qr[i, c + 1]
            s2 += v * qr[i, c + 2]
            s3 += v * qr[i, c + 3]
        s0 *= tau
        s1 *= tau
        s2 *= tau
        s3 *= tau
        qr[j, c] -= s0
        qr[j, c + 1] -= s1
        qr[j, c + 2] -= s2
        qr[j, c + 3] -= s3
        for i in range(j + 1, end):
            v = qr[i, j]
            qr[i, c] -= s0 * v
            qr[i, c + 1] -= s1 * v
            qr[i, c + 2] -= s2 * v
            qr[i, c + 3] -= s3 * v
        c += 4
    for c in range(c, c1):
        s = qr[j, c]
        for i in range(j + 1, end):
            s += qr[i, j] * qr[i, c]
        s *= tau
        qr[j, c] -= s
        for i in range(j + 1, end):
            qr[i, c] -= s * qr[i, j]


@njit(**INLINE)
def _factor_band(a: np.ndarray, b: np.ndarray, columns: np.ndarray, efforts: int, qr: np.ndarray,
                 qb: np.ndarray) -> None:
    """The Householder factors of ``a`` into ``qr`` and ``Q^T b`` into ``qb``, each reflection on the band
    it reaches (:func:`_householder_solve`); ``efforts`` the first solved effort's column."""
    m, k = a.shape
    for i in range(m):
        qb[i] = b[i]
        for j in range(k):
            qr[i, j] = a[i, j]
    end, touched = 0, 0  # rows j .. end - 1 of the reflection; constraint columns j + 1 .. touched - 1
    for j in range(k):
        end = max(end, min(6 * columns[j, 0] + 6, m))
        touched = max(touched, j + 1)
        while touched < efforts and _first_row(columns, touched) < end:
            touched += 1
        alpha, xnorm = qr[j, j], 0.0
        for i in range(j + 1, end):
            xnorm += qr[i, j] * qr[i, j]
        if xnorm == 0.0:
            continue
        beta = -math.copysign(math.sqrt(alpha * alpha + xnorm), alpha)
        tau, scale = (beta - alpha) / beta, 1.0 / (alpha - beta)
        for i in range(j + 1, end):
            qr[i, j] *= scale
        qr[j, j] = beta
        _reflect(qr, j, end, tau, j + 1, touched)
        _reflect(qr, j, end, tau, max(efforts, touched), k)
        s = qb[j]
        for i in range(j + 1, end):
            s += qr[i, j] * qb[i]
        s *= tau
        qb[j] -= s
        for i in range(j + 1, end):
            qb[i] -= s * qr[i, j]


@njit(**INLINE)
def _back_substitute(columns: np.ndarray, k: int, efforts: int, qr: np.ndarray, qb: np.ndarray,
                     x: np.ndarray) -> bool:
    """``R x = Q^T b`` for the ``k`` unknowns, into ``x``, on ``R``'s band (:func:`_householder_solve`), a
    diagonal at or below :data:`TINY` raised to it; whether every unknown is finite."""
    finite, hi = True, efforts  # hi: the first constraint column two joints below column c's
    for c in range(k - 1, -1, -1):
        s = qb[c]
        if c < efforts and c < 6 * columns[c, 0] + 6 and finite:  # row c of R: its band and the efforts
            while hi > c + 1 and columns[hi - 1, 0] >= columns[c, 0] + 2:
                hi -= 1
            for j in range(c + 1, hi):
                s -= qr[c, j] * x[j]
            for j in range(efforts, k):
                s -= qr[c, j] * x[j]
        else:
            for j in range(c + 1, k):
                s -= qr[c, j] * x[j]
        d = qr[c, c]
        x[c] = s / (d if abs(d) > TINY else TINY)
        finite = finite and math.isfinite(x[c])
    return finite


@njit(**INLINE)
def _householder_solve(a: np.ndarray, b: np.ndarray, columns: np.ndarray, qr: np.ndarray, qb: np.ndarray,
                       x: np.ndarray) -> tuple[float, float]:
    """Least squares of ``a x = b`` by Householder QR (``qr``, ``qb``: the factors and ``Q^T b``), a
    diagonal of ``R`` at or below :data:`TINY` raised to it (the numpy solver's ``_least_squares``): the
    relative residual and the last column's ``|R_kk| / |a_k|``.

    The system is block-bidiagonal: a column of row ``r`` (``columns``) touches the equations of links
    ``r - 1`` and ``r`` only, and the constraint columns come first in row order, the solved efforts after
    them (:func:`~dualmech.core.kernel.loop_engine.wrench_spec`).  So the reflection of column ``j`` works
    on the rows down to the last that any column up to ``j`` touches, and on the columns that touch those
    rows: the constraint columns up to the first whose first equation is below them, and the efforts.  The
    rows and columns left out hold exact zeros, which the dense factorization would add without changing a
    bit; :func:`_reflect` keeps every sum's order, so the factors are the dense factorization's to the bit.
    The back substitution and the residual skip the same zeros (row ``c`` of ``R`` is zero from the first
    constraint column two joints below column ``c``'s, link ``l``'s equations outside the columns of joints
    ``l`` and ``l + 1``), unless an unknown is not finite: a zero times it is NaN, as in the dense sums.
    """
    m, k = a.shape
    efforts = first_effort(columns)
    _factor_band(a, b, columns, efforts, qr, qb)
    finite = _back_substitute(columns, k, efforts, qr, qb, x)
    last = 0.0
    for i in range(m):
        last += a[i, k - 1] * a[i, k - 1]
    return residual_of(a, b, columns, efforts, x, finite), abs(qr[k - 1, k - 1]) / max(math.sqrt(last), TINY)


@njit(**INLINE)
def joint_wrenches(fl: FlatLoop, spec: WrenchSpec, vals: np.ndarray, x: np.ndarray, given: np.ndarray,
                   w: Work, ww: WrenchWork) -> tuple[float, float]:
    """Every joint's wrench at the closed position evaluated in ``w`` (frames, lines, link twists and
    accelerations): the unknowns into ``ww.x``, each joint's force and moment about its point into
    ``ww.force``, ``ww.moment``, its point into ``ww.points``; returns the relative residual and the
    transmission.  ``given`` ``(g,)``: the given efforts."""
    _joints(fl, spec, vals, x, w, ww)
    length = vals[fl.scale] if fl.scale >= 0 else 1.0
    _equations(fl, spec, vals, x, given, length, w, ww)
    efforts, transmission = first_effort(spec.columns), math.nan
    if ww.a.shape[0] == ww.a.shape[1] + fl.gauges.size:  # square but the idle spins: along the chain
        transmission = chain_solve(fl, spec.columns, efforts, w.lines, w.axes, ww.a, ww.b, ww.points, ww.axes,
                                   length, ww.chain, ww.x)
    if math.isnan(transmission):
        residual, transmission = _householder_solve(ww.a, ww.b, spec.columns, ww.qr, ww.qb, ww.x)
    else:
        residual = residual_of(ww.a, ww.b, spec.columns, efforts, ww.x, True)
    for r in range(fl.table.shape[0]):
        for i in range(3):
            ww.force[r, i] = ww.known[r, 0, i]
            ww.moment[r, i] = ww.known[r, 1, i]
    for c in range(spec.columns.shape[0]):
        r = spec.columns[c, 0]
        for i in range(3):
            ww.force[r, i] += ww.units[c, 0, i] * ww.x[c]
            ww.moment[r, i] += ww.units[c, 1, i] * ww.x[c]
    for r in range(fl.table.shape[0]):
        p, f = ww.points[r], ww.force[r]
        ww.moment[r, 0] -= p[1] * f[2] - p[2] * f[1]
        ww.moment[r, 1] -= p[2] * f[0] - p[0] * f[2]
        ww.moment[r, 2] -= p[0] * f[1] - p[1] * f[0]
    return residual, transmission


__all__ = [
    "FORCE", "MOMENT", "TURN", "SLIDE", "WrenchSpec", "WrenchWork", "make_wrench_work", "joint_wrenches",
]
