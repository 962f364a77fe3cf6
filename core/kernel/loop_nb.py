"""The link-joint table as flat arrays, and its evaluation at one position (compiled).

:func:`flatten` turns a :class:`~dualmech.core.loop.Loop` into a :class:`FlatLoop` of
integer and float arrays that the kernel reads; :func:`evaluate` computes the frames,
the loop product (thesis eq. 5, 18) and the elementary screws (eq. 8-17) at one
position, exactly as :func:`dualmech.core.loop.evaluate` does for a batch.

Values of a position: ``vals`` ``(n_values,)`` holds the inputs then the parameters,
in the order of :attr:`FlatLoop.names`; the unknowns are a flat state vector ``x``
``(n_state,)``: the scalar unknowns in the order of ``Loop.unknowns``, then each
spherical row's rotation matrix, row-major (9 numbers).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from dualmech.core.kernel.dual_nb import INLINE, JIT, tadd, tmul, trotation, trotation_cs
from dualmech.core.loop import Loop, Var

#: Kind of a table entry: a constant, a value of ``vals`` (input or parameter), an unknown of ``x``.
CONST, VALUE, UNKNOWN = 0, 1, 2
#: Columns of the table, in the order of thesis eq. (1): theta, S, eta, alpha, a.
FIELDS = ("theta", "s", "eta", "alpha", "a")


class FlatLoop(NamedTuple):
    """A :class:`~dualmech.core.loop.Loop` as arrays (``R`` rows, ``M`` screws, ``G`` spin gauges).

    Few arrays, because every array handed to a compiled function costs two atomic
    reference-count updates (measured ~100 ns for a call with three arrays).

    ``table`` ``(R, 16)`` int: per table entry (columns :data:`FIELDS`) its kind (0:5), its
    index in ``vals`` or ``x`` (5:10), whether it moves, i.e. is an input or an unknown
    with a screw (10:15), and whether the row is spherical (15); ``const`` ``(R, 5)``: the
    constants; ``screws`` ``(M, 4)`` int, in row order (the rates rely on it): per screw its
    row, its carrier (screws before it whose motion carries it), its column in the tangent
    step (-1 for an input) and its index in ``vals`` (-1 for an unknown); ``gauges`` ``(G,)``
    the spin-gauged rows; ``scale`` the index in ``vals`` of the length scale (-1: none, 1);
    ``n_scalar`` scalar unknowns; ``n_step`` the tangent step's size.
    """

    table: np.ndarray
    const: np.ndarray
    screws: np.ndarray
    gauges: np.ndarray
    scale: int
    n_scalar: int
    n_step: int


#: Column offsets in :attr:`FlatLoop.table`.
KIND, REF, MOVES, SPHERICAL = 0, 5, 10, 15
#: Columns of :attr:`FlatLoop.screws`.
ROW, CARRIER, COLUMN, VALUE_INDEX = 0, 1, 2, 3


def value_names(loop: Loop) -> tuple[str, ...]:
    """Names of ``vals``: the loop's inputs, then its parameters, each once, in table order, then its length
    scale if no row holds it."""
    params = [
        v.name for r in loop.rows for f in FIELDS if isinstance(v := getattr(r, f), Var) and v.kind == "param"
    ]
    scale = [loop.length_scale] if loop.length_scale else []
    return tuple(dict.fromkeys(list(loop.inputs) + params + scale))


def _entries(loop: Loop, names: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray]:
    """``table`` and ``const`` of :class:`FlatLoop`."""
    table, const = np.zeros((len(loop.rows), 16), np.int64), np.zeros((len(loop.rows), 5))
    for i, row in enumerate(loop.rows):
        table[i, SPHERICAL] = row.spherical
        for f, name in enumerate(FIELDS):
            v = getattr(row, name)
            if not isinstance(v, Var):
                const[i, f] = float(v)
            elif v.kind == "unknown":
                table[i, [KIND + f, REF + f, MOVES + f]] = UNKNOWN, loop.unknowns.index(v.name), 1
            else:
                table[i, [KIND + f, REF + f, MOVES + f]] = VALUE, names.index(v.name), v.kind == "input"
    return table, const


def _screws(loop: Loop, names: tuple[str, ...]) -> np.ndarray:
    """``screws`` of :class:`FlatLoop`, in the order of :func:`dualmech.core.loop.evaluate`."""
    out: list[tuple[int, int, int, int]] = []
    ball = 0
    for i, row in enumerate(loop.rows):
        groups = [[("ball", k) for k in range(3)]] if row.spherical else [["theta", "s"], ["eta"]]
        for group in groups + [["alpha", "a"]]:
            first = len(out)
            for item in group:
                if isinstance(item, tuple):
                    out.append((i, first, len(loop.unknowns) + 3 * ball + item[1], -1))
                elif isinstance(v := getattr(row, item), Var) and v.kind == "unknown":
                    out.append((i, first, loop.unknowns.index(v.name), -1))
                elif isinstance(v, Var) and v.kind == "input":
                    out.append((i, first, -1, names.index(v.name)))
        ball += row.spherical
    return np.array(out, dtype=np.int64).reshape(-1, 4)


def flatten(loop: Loop) -> FlatLoop:
    """The :class:`FlatLoop` of ``loop``."""
    names = value_names(loop)
    table, const = _entries(loop, names)
    return FlatLoop(
        table,
        const,
        _screws(loop, names),
        np.array(loop.spin_gauges, dtype=np.int64),
        names.index(loop.length_scale) if loop.length_scale else -1,
        len(loop.unknowns),
        loop.n_unknown,
    )


def state_size(fl: FlatLoop) -> int:
    """Length of the flat state ``x``: scalar unknowns plus 9 per spherical row."""
    return fl.n_scalar + 9 * int(fl.table[:, SPHERICAL].sum())


@njit(**INLINE)
def _same(a: float, b: float) -> bool:
    """``a`` and ``b`` are the same number, down to the sign of a zero."""
    return a == b and math.copysign(1.0, a) == math.copysign(1.0, b)


@njit(**INLINE)
def _factors(turns: np.ndarray, i: int, stage: int, axis: int, angle: float, slide: float) -> tuple:
    """:func:`~dualmech.core.kernel.dual_nb.trotation` of ``angle``, ``slide``, remembered in
    ``turns[i, stage]`` (the angle, the slide, then the two 9-tuples): a turn that did not change since
    the last evaluation (an input or parameter, during the Newton iterations of a position) costs no
    trigonometry."""
    m = turns[i, stage]
    if _same(m[0], angle) and _same(m[1], slide):
        return (m[2], m[3], m[4], m[5], m[6], m[7], m[8], m[9], m[10]), (
            m[11], m[12], m[13], m[14], m[15], m[16], m[17], m[18], m[19],
        )
    f_re, f_du = trotation(axis, angle, slide)
    m[0], m[1] = angle, slide
    for k in range(9):
        m[2 + k], m[11 + k] = f_re[k], f_du[k]
    return f_re, f_du


@njit(**INLINE)
def _turn(
    axis: int, angle: float, slide: float, no_angle: bool, no_slide: bool, pre_re: tuple, pre_du: tuple,
    turns: np.ndarray, i: int, stage: int,
) -> tuple:
    """``pre @ rot_axis(angle + eps slide)`` on 9-tuples, skipping what constant zeros make needless
    (as :func:`dualmech.core.loop._turn`); the factors from :func:`_factors`."""
    if no_angle and no_slide:
        return pre_re, pre_du
    if no_angle:
        return pre_re, tadd(pre_du, tmul(pre_re, trotation_cs(axis, 1.0, 0.0, slide)[1]))
    f_re, f_du = _factors(turns, i, stage, axis, angle, slide)
    if no_slide:
        return tmul(pre_re, f_re), tmul(pre_du, f_re)
    return tmul(pre_re, f_re), tadd(tmul(pre_re, f_du), tmul(pre_du, f_re))


@njit(**INLINE)
def entry(table: np.ndarray, const: np.ndarray, vals: np.ndarray, x: np.ndarray, i: int, f: int) -> float:
    """Entry ``f`` (a column of :data:`FIELDS`) of table row ``i`` at this position."""
    k = table[i, KIND + f]
    return const[i, f] if k == CONST else (vals[table[i, REF + f]] if k == VALUE else x[table[i, REF + f]])


@njit(**INLINE)
def _zero(table: np.ndarray, const: np.ndarray, i: int, f: int) -> bool:
    """Whether entry ``f`` of row ``i`` is the constant 0 (its turn or slide can be skipped)."""
    return const[i, f] == 0.0 and table[i, KIND + f] == CONST


@njit(**JIT)
def evaluate(
    fl: FlatLoop, vals: np.ndarray, x: np.ndarray, frames: np.ndarray, lines: np.ndarray, turns: np.ndarray
) -> None:
    """Frames ``(R, 2, 3, 3)`` (``frames[i] = T_1 ... T_i``, the last is the loop product B, eq. 18)
    and screw lines ``(M, 2, 3)`` at one position (:func:`dualmech.core.loop.evaluate`).

    The running product is a pair of 9-tuples (registers).  ``turns`` ``(R, 3, 20)``: the factors of
    the last evaluation (:func:`_factors`; any content is valid, NaN to start).
    """
    table, const = fl.table, fl.const
    pre_re = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
    pre_du = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    m, ball = 0, 0
    for i in range(table.shape[0]):
        v = (  # the row's five entries at this position
            entry(table, const, vals, x, i, 0),
            entry(table, const, vals, x, i, 1),
            entry(table, const, vals, x, i, 2),
            entry(table, const, vals, x, i, 3),
            entry(table, const, vals, x, i, 4),
        )
        for stage in range(3):  # Z(theta + eps S), Y(eta), X(alpha + eps a); a ball replaces the first two
            if stage < 2 and table[i, SPHERICAL]:
                if stage == 0:
                    for k in range(3):
                        for r in range(3):
                            lines[m, 0, r], lines[m, 1, r] = pre_re[3 * r + k], pre_du[3 * r + k]
                        m += 1
                    o = fl.n_scalar + 9 * ball
                    rot = (
                        x[o],
                        x[o + 1],
                        x[o + 2],
                        x[o + 3],
                        x[o + 4],
                        x[o + 5],
                        x[o + 6],
                        x[o + 7],
                        x[o + 8],
                    )
                    pre_re, pre_du = tmul(pre_re, rot), tmul(pre_du, rot)
                    ball += 1
                continue
            axis, fa, fs = (2, 0, 1) if stage == 0 else ((1, 2, -1) if stage == 1 else (0, 3, 4))
            for f in (fa, fs):
                if f >= 0 and table[i, MOVES + f]:
                    slide = f != fa
                    for r in range(3):
                        lines[m, 0, r] = 0.0 if slide else pre_re[3 * r + axis]
                        lines[m, 1, r] = pre_re[3 * r + axis] if slide else pre_du[3 * r + axis]
                    m += 1
            no_angle, no_slide = _zero(table, const, i, fa), fs < 0 or _zero(table, const, i, fs)
            slide = 0.0 if fs < 0 else v[fs]
            pre_re, pre_du = _turn(axis, v[fa], slide, no_angle, no_slide, pre_re, pre_du, turns, i, stage)
        for r in range(9):
            frames[i, 0, r // 3, r % 3] = pre_re[r]
            frames[i, 1, r // 3, r % 3] = pre_du[r]


@njit(**INLINE)
def length_scale(fl: FlatLoop, vals: np.ndarray) -> float:
    """The loop's length scale at this position (1 without one)."""
    return 1.0 if fl.scale < 0 else vals[fl.scale]


@njit(**JIT)
def closure_residual(frames: np.ndarray, scale: float) -> float:
    """Size of :math:`\\hat B - \\hat I` of the last frame (:func:`dualmech.core.loop.closure_residual`)."""
    prim, dual = 0.0, 0.0
    last = frames.shape[0] - 1
    for i in range(3):
        for j in range(3):
            prim = max(prim, abs(frames[last, 0, i, j] - (1.0 if i == j else 0.0)))
            dual = max(dual, abs(frames[last, 1, i, j]))
    return max(prim, dual / scale)


@njit(**JIT)
def frame_origin(frames: np.ndarray, i: int) -> tuple:
    """Origin ``p = vee(M.du @ M.re^T)`` of frame ``i`` (:func:`dualmech.core.dual.origin`), a 3-tuple."""
    if i < 0:
        return 0.0, 0.0, 0.0
    re, du = frames[i, 0], frames[i, 1]
    m10 = du[1, 0] * re[0, 0] + du[1, 1] * re[0, 1] + du[1, 2] * re[0, 2]
    m01 = du[0, 0] * re[1, 0] + du[0, 1] * re[1, 1] + du[0, 2] * re[1, 2]
    m20 = du[2, 0] * re[0, 0] + du[2, 1] * re[0, 1] + du[2, 2] * re[0, 2]
    m02 = du[0, 0] * re[2, 0] + du[0, 1] * re[2, 1] + du[0, 2] * re[2, 2]
    m21 = du[2, 0] * re[1, 0] + du[2, 1] * re[1, 1] + du[2, 2] * re[1, 2]
    m12 = du[1, 0] * re[2, 0] + du[1, 1] * re[2, 1] + du[1, 2] * re[2, 2]
    return 0.5 * (m21 - m12), 0.5 * (m02 - m20), 0.5 * (m10 - m01)


@njit(**INLINE)
def screw_matrix(
    fl: FlatLoop,
    frames: np.ndarray,
    lines: np.ndarray,
    scale: float,
    mat: np.ndarray,
    gauge: np.ndarray,
    axes: np.ndarray,
) -> None:
    """The unknowns' screws as columns ``mat`` ``(6 + G, n_step)``, dual rows over ``scale``, with the
    spin-gauge rows; ``gauge`` ``(G, M)`` gets ``u . s_j`` for every screw up to the gauged row
    (:func:`~dualmech.core.loop.screw_jacobian`, :func:`~dualmech.core.loop.gauge_rows`);
    ``axes`` ``(G, 3)`` the gauge axes: from the ball centre of the gauged row to the next.
    """
    mat[:] = 0.0
    gauge[:] = 0.0
    screws, gauges = fl.screws, fl.gauges
    for g in range(gauges.size):
        s, e = frame_origin(frames, gauges[g] - 1), frame_origin(frames, gauges[g])
        d = (e[0] - s[0], e[1] - s[1], e[2] - s[2])
        norm = np.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
        for r in range(3):
            axes[g, r] = d[r] / norm
    for j in range(lines.shape[0]):
        for g in range(gauges.size):
            if screws[j, ROW] <= gauges[g]:
                gauge[g, j] = (
                    axes[g, 0] * lines[j, 0, 0] + axes[g, 1] * lines[j, 0, 1] + axes[g, 2] * lines[j, 0, 2]
                )
        col = screws[j, COLUMN]
        if col < 0:
            continue
        for r in range(3):
            mat[r, col] = lines[j, 0, r]
            mat[3 + r, col] = lines[j, 1, r] / scale
        for g in range(gauges.size):
            mat[6 + g, col] = gauge[g, j]
