"""The in-house engine compiled: every position of a chunk analysed in parallel into preallocated columns.

Per position (one ``prange`` block of positions per thread): the closure strategy of
:mod:`dualmech.models.slider_crank_nb`, the edges of assembly
(:func:`dualmech.core.assembly.edge_status`), rates from screws
(:func:`dualmech.core.kernel.rates_nb.solve_rates`), inverse dynamics by dual momentum and
D'Alembert (:mod:`dualmech.core.kernel.dynamics_nb` and the closed-form elimination of
:func:`dualmech.core.reactions.solve_reactions`), dead centres, and the last step of
:func:`dualmech.core.status.settle` (``not_finite``, and NaN wherever a row's word does not
give a column).  Status words are integer codes (their positions in
:data:`dualmech.core.status.STATUSES`) until :func:`analyze_chunk` returns.

The numpy implementation in :mod:`dualmech.models.slider_crank` is the same algorithm
batched; ``tests/core/test_kernel.py`` holds the two to 1e-12.
"""

from __future__ import annotations

import math
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from functools import lru_cache
from typing import Iterator, Sequence

import numpy as np
from numba import njit

from dualmech.core.kernel import depends_on_kernel
from dualmech.core.kernel.closure_nb import Work, make_work
from dualmech.core.kernel.dual_nb import JIT, cross, dot
from dualmech.core.kernel.dynamics_nb import required_wrench
from dualmech.core.kernel.loop_nb import FlatLoop, flatten
from dualmech.core.kernel.rates_nb import solve_rates
from dualmech.core.motion import CrankState
from dualmech.core.status import STATUSES
from dualmech.core.table import NUMERIC_COLUMNS, ResultTable
from dualmech.models.case import Case
from dualmech.models.slider_crank_nb import (
    Rules,
    Scratch,
    close_reachable,
    make_scratch,
    pins,
    reach_and_foot,
    slider_line,
    warm_start,
)

depends_on_kernel(__file__)

#: Rows of the output array, in this order (the names of ``docs/conventions.md``, "Output columns").
OUT_COLUMNS: tuple[str, ...] = (
    "theta1_deg",
    "S1",
    "S4",
    "S4_dot",
    "S4_ddot",
    "j1_fx",
    "j1_fy",
    "j1_fz",
    "j1_mx",
    "j1_my",
    "j1_mz",
    "j2_fx",
    "j2_fy",
    "j2_fz",
    "j3_fx",
    "j3_fy",
    "j3_fz",
    "j4_fx",
    "j4_fy",
    "j4_fz",
    "j4_mx",
    "j4_my",
    "j4_mz",
    "slider_load",
    "drive_torque",
    "transmission",
    "residual",
    "closure_condition",
)
_THETA, _S1, _S4, _S4_DOT, _S4_DDOT, _REACT, _TRANS, _RESID, _COND = 0, 1, 2, 3, 4, 5, 25, 26, 27
#: Positions analysed together at most (about 250 bytes each with the crank states).
CHUNK_POSITIONS = 100_000
#: Largest crank-angle step [rad] across which a position starts from its predecessor (2 degrees:
#: the thesis's grids are 1 degree; a coarser grid starts every position cold, as the numpy solver).
WARM_SPAN = math.radians(2.0)
#: Every this many positions of a case (counted from its first) start cold, and only there may a block
#: of positions begin: each position's start, hence every bit of its result, is then the same whatever
#: the number of threads, the chunk size (a multiple of it) or the cases sharing a chunk.  A cold
#: start costs about 1 µs more; one in 100 positions adds about 1 %.
WARM_CHAIN = 100
#: Fewest positions worth a thread of their own.
BLOCK = 256
#: Blocks per thread in a chunk: uneven work (DFP, continuation near edges) evens out.
BLOCKS_PER_THREAD = 4


@njit(**JIT)
def _reactions(
    need: np.ndarray,
    p2: np.ndarray,
    p3: np.ndarray,
    k4: np.ndarray,
    torque: float,
    load: float,
    v: np.ndarray,
    out: np.ndarray,
) -> float:
    """The 20 reaction columns into ``out`` (order of :data:`OUT_COLUMNS`); returns the Newton-Euler residual.

    :func:`dualmech.core.reactions.solve_reactions` for one position: ``need`` ``(3, 2, 3)``
    what the joints must supply to crank, rod and slider; ``v`` ``(16, 3)`` scratch.
    """
    d, u, k2, j3p, j2p, t, j3, j2, j1f, j1m, j4f, j4mo, j4m = (
        v[0],
        v[1],
        v[2],
        v[3],
        v[4],
        v[5],
        v[6],
        v[7],
        v[8],
        v[9],
        v[10],
        v[11],
        v[12],
    )
    for i in range(3):
        d[i] = p3[i] - p2[i]
    a2 = math.sqrt(dot(d, d))
    for i in range(3):
        u[i] = d[i] / a2
    cross(p2, need[1, 0], t)
    for i in range(3):
        k2[i] = need[1, 1, i] - t[i]
    cross(u, k2, j3p)
    for i in range(3):
        j3p[i] /= a2
        j2p[i] = need[1, 0, i] + j3p[i]
    cross(p2, j2p, t)
    tau0 = need[0, 1, 2] + t[2]
    cross(p2, u, t)
    lever = t[2]
    s0 = (
        (need[2, 0, 0] - j3p[0]) * k4[0] + (need[2, 0, 1] - j3p[1]) * k4[1] + (need[2, 0, 2] - j3p[2]) * k4[2]
    )
    lam = (torque - tau0) / lever if math.isfinite(torque) else (s0 - load) / dot(u, k4)
    for i in range(3):
        j3[i] = j3p[i] + lam * u[i]
        j2[i] = need[1, 0, i] + j3[i]
        j1f[i] = need[0, 0, i] + j2[i]
        j4f[i] = need[2, 0, i] - j3[i]
    cross(p2, j2, t)
    for i in range(3):
        j1m[i] = need[0, 1, i] + t[i]
    cross(p3, j3, t)
    for i in range(3):
        j4mo[i] = need[2, 1, i] - t[i]
    cross(p3, j4f, t)
    for i in range(3):
        j4m[i] = j4mo[i] - t[i]
        out[i], out[3 + i], out[6 + i], out[9 + i], out[12 + i], out[15 + i] = (
            j1f[i],
            j1m[i],
            j2[i],
            j3[i],
            j4f[i],
            j4m[i],
        )
    out[18], out[19] = dot(j4f, k4), j1m[2]
    return _newton_euler_residual(need, p2, p3, j1f, j1m, j2, j3, j4f, j4mo, v[13:16])


@njit(**JIT)
def _newton_euler_residual(need, p2, p3, f1, m1, j2, j3, f4, m4o, v) -> float:
    """Largest violation of the 18 equations (:func:`dualmech.core.reactions._newton_euler_residual`)."""
    t2, t3 = v[0], v[1]
    cross(p2, j2, t2)
    cross(p3, j3, t3)
    f_err, m_err, f_scale, m_big = 0.0, 0.0, 0.0, 0.0
    for i in range(3):
        f_err = max(
            f_err,
            abs(f1[i] - j2[i] - need[0, 0, i]),
            abs(j2[i] - j3[i] - need[1, 0, i]),
            abs(j3[i] + f4[i] - need[2, 0, i]),
        )
        m_err = max(
            m_err,
            abs(m1[i] - t2[i] - need[0, 1, i]),
            abs(t2[i] - t3[i] - need[1, 1, i]),
            abs(t3[i] + m4o[i] - need[2, 1, i]),
        )
        f_scale = max(f_scale, abs(f1[i]), abs(j2[i]), abs(j3[i]), abs(f4[i]))
        m_big = max(m_big, abs(m1[i]), abs(m4o[i]))
    f_scale = max(f_scale, 1e-300)
    m_scale = max(m_big, f_scale * max(math.sqrt(dot(p2, p2)), math.sqrt(dot(p3, p3))))
    return max(f_err / f_scale, m_err / m_scale)


@njit(**JIT)
def _dynamics(
    rules: Rules,
    g: tuple,
    crank: np.ndarray,
    i: int,
    body: tuple,
    w: Work,
    sc: Scratch,
    p2: np.ndarray,
    p3: np.ndarray,
    k4: np.ndarray,
    col: np.ndarray,
) -> float:
    """Rates, transmission and reactions of a closed position into ``col``; returns the
    Newton-Euler residual."""
    fl, mass, com, inertia, gravity, torque, load = body
    sc.rates[:] = 0.0
    sc.rates[0, rules.vidx[0]], sc.rates[0, rules.vidx[1]] = crank[2, i], crank[3, i]
    sc.rates[1, rules.vidx[0]], sc.rates[1, rules.vidx[1]] = crank[4, i], crank[5, i]
    solve_rates(fl, sc.rates[0], sc.rates[1], w)
    col[_S4_DOT], col[_S4_DDOT] = w.q_dot[0], w.q_ddot[0]
    hub, need, rot = sc.vec[8], sc.need, sc.mats[3]
    hub[0], hub[1], hub[2] = 0.0, 0.0, g[1]
    col[_TRANS] = ((p2[0] - hub[0]) * (p3[1] - p2[1]) - (p2[1] - hub[1]) * (p3[0] - p2[0])) / g[3] / g[2]
    rot[:] = 0.0
    for k in range(3):
        rot[k, k] = 1.0
    frames = (w.frames[0, 0], w.frames[1, 0], rot)
    origins = (hub, p2, p3)
    for b in range(3):
        required_wrench(
            mass[b],
            com[b],
            inertia[b],
            frames[b],
            origins[b],
            w.twists[b],
            w.accels[b],
            gravity,
            sc.wide[16:24],
            need[b],
        )
    return _reactions(need, p2, p3, k4, torque, load, sc.wide[:16], col[_REACT : _REACT + 20])


@njit(**JIT)
def _settle(rules: Rules, status: int, col: np.ndarray) -> int:
    """``not_finite`` where a given column is not finite, then NaN where the word does not give it
    (:func:`dualmech.core.status.settle`)."""
    ok, dead, limit, not_finite = rules.codes[0], rules.codes[1], rules.codes[2], rules.codes[6]
    n_check = 25 if status == ok else (5 if status == dead else (2 if status == limit else 0))
    checks = (_S4, _COND, _S4_DOT, _S4_DDOT, _TRANS)
    for k in range(n_check):
        c = checks[k] if k < 5 else _REACT + k - 5
        if not math.isfinite(col[c]):
            status = not_finite
    if status != ok:
        col[_REACT : _REACT + 20] = np.nan
    if status != ok and status != dead:
        col[_S4_DOT], col[_S4_DDOT], col[_TRANS] = np.nan, np.nan, np.nan
    if status != ok and status != dead and status != limit:
        col[_S4], col[_COND] = np.nan, np.nan
    return status


@njit(**JIT)
def _position(
    i: int,
    fl,
    rules: Rules,
    crank: np.ndarray,
    case_of: np.ndarray,
    geo: np.ndarray,
    bodies: tuple,
    w: Work,
    sc: Scratch,
    out: np.ndarray,
    status: np.ndarray,
    iters: np.ndarray,
    dyn: np.ndarray,
    warm: bool,
) -> bool:
    """Analyse position ``i`` into row ``i`` of ``out``, with its status code, iterations and
    dynamics residual; ``warm``: whether position ``i - 1`` left a closed state and its rates in
    ``sc``, ``w`` to start from.  Returns whether position ``i`` leaves them for ``i + 1``."""
    c = case_of[i]
    g = (crank[0, i], crank[1, i], geo[c, 0], geo[c, 1], geo[c, 2], geo[c, 3])
    col = out[i]
    col[:] = np.nan
    col[_THETA], col[_S1] = math.degrees(g[0]), g[1]
    rho, foot = reach_and_foot(g)
    beyond = rho > 1.0 + rules.reach_tol
    word, it, residual, closed = rules.codes[5], 0, max(rho - 1.0, 0.0), False
    accepted = False
    if not beyond:
        if warm:
            speed = crank[2, i - 1]
            step = (crank[0, i] - crank[0, i - 1]) / speed if speed != 0.0 else 0.0
            accepted, it, residual = warm_start(fl, rules, g, step, w, sc)
        if accepted:
            word = rules.codes[0]
        else:
            word, it2, residual = close_reachable(fl, rules, g, w, sc)
            it += it2
        closed = word == rules.codes[0]
    col[_RESID] = residual
    k4, p2, p3 = sc.vec[11], sc.vec[12], sc.vec[13]
    cond = math.sqrt(1.0 - min(rho, 1.0) ** 2)
    if closed:
        k4_t = slider_line(g)[1]
        p2_t, p3_t = pins(fl, rules.vidx, g, sc.x[0], sc.vals, w.frames, w.lines, accepted)
        for k in range(3):
            k4[k], p2[k], p3[k] = k4_t[k], p2_t[k], p3_t[k]
        rod = (p3[0] - p2[0], p3[1] - p2[1], p3[2] - p2[2])
        cond = abs(rod[0] * k4[0] + rod[1] * k4[1] + rod[2] * k4[2]) / math.sqrt(
            rod[0] * rod[0] + rod[1] * rod[1] + rod[2] * rod[2]
        )
    if not beyond and word == rules.codes[5]:
        word = rules.codes[4]
    if not beyond and cond < rules.limit_band:
        word = rules.codes[2]
    col[_COND] = np.nan if beyond else cond
    col[_S4] = foot if (word == rules.codes[2] and not closed) else sc.x[0, 0]
    dyn[i] = np.nan
    if word == rules.codes[0]:
        torque, load = bodies[4][c], bodies[5][c]
        body = (fl, bodies[0][c], bodies[1][c], bodies[2][c], bodies[3][c], torque, load)
        dyn[i] = _dynamics(rules, g, crank, i, body, w, sc, p2, p3, k4, col)
        if math.isfinite(torque) and abs(col[_TRANS]) < rules.dead_centre:
            word = rules.codes[1]
    status[i] = _settle(rules, word, col)
    iters[i] = it
    return status[i] == rules.codes[0] or status[i] == rules.codes[1]


@njit(**JIT)
def analyze_range(
    lo: int,
    hi: int,
    w: Work,
    sc: Scratch,
    fl,
    rules: Rules,
    crank: np.ndarray,
    case_of: np.ndarray,
    geo: np.ndarray,
    bodies: tuple,
    out: np.ndarray,
    status: np.ndarray,
    iters: np.ndarray,
    dyn: np.ndarray,
    cold: np.ndarray,
) -> None:
    """Analyse positions ``lo..hi-1`` into the preallocated outputs (one thread; the GIL released).

    ``crank`` ``(6, n)``: theta, S1 and their first and second rates; ``case_of`` ``(n,)``
    the case of each position; ``geo`` ``(cases, 4)``: a1, a2, a4, alpha4; ``bodies``: per
    case the masses ``(cases, 3)``, centres of mass ``(cases, 3, 3)``, inertias ``(cases, 3, 3, 3)``
    of crank, rod and slider, gravity ``(cases, 3)``, the given drive torque and slider load
    ``(cases,)`` (NaN where not given); ``out`` ``(n, len(OUT_COLUMNS))`` (a row per position:
    written where it is computed), ``status``,
    ``iters``, ``dyn`` ``(n,)``; ``cold`` ``(n,)`` bool: the positions that start cold
    (:func:`chain_starts`; ``lo`` must be one); ``w``, ``sc``: this thread's scratch (:func:`_scratch`).
    """
    warm = False
    for i in range(lo, hi):
        warm = warm and not cold[i] and abs(crank[0, i] - crank[0, i - 1]) <= WARM_SPAN
        warm = _position(i, fl, rules, crank, case_of, geo, bodies, w, sc, out, status, iters, dyn, warm)


def threads() -> int:
    """Worker threads of the kernel: the CPUs this process may run on."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


@lru_cache(maxsize=1)
def _pool() -> ThreadPoolExecutor:
    return ThreadPoolExecutor(max_workers=threads(), thread_name_prefix="dualmech-kernel")


# a forked child (a process pool's worker) inherits the pool object but not its threads: start afresh
os.register_at_fork(after_in_child=_pool.cache_clear)


def _scratch(fl: FlatLoop, rules: Rules) -> tuple[Work, Scratch]:
    """The scratch arrays of one block of positions (the compiled code allocates nothing)."""
    w = make_work(fl)
    return w, make_scratch(rules.vidx.size, w.base.size)


def chain_starts(case_of: np.ndarray, index: np.ndarray | None = None) -> np.ndarray:
    """``(n,)`` bool: the positions that start cold: the first of each run of one case in ``case_of``, and
    every :data:`WARM_CHAIN` of a case's positions (``index``: their indices in the case; default:
    counted from the run's first)."""
    n = case_of.size
    at = np.arange(n)
    first = np.ones(n, dtype=bool)
    first[1:] = case_of[1:] != case_of[:-1]
    if index is None:
        index = at - np.maximum.accumulate(np.where(first, at, 0))
    return first | (index % WARM_CHAIN == 0)


def _run(n: int, fl: FlatLoop, rules: Rules, args: tuple) -> None:
    """:func:`analyze_range` over ``n`` positions, :data:`BLOCKS_PER_THREAD` blocks a thread, in parallel;
    blocks begin at cold starts (the last of ``args``) only."""
    parts = max(1, min(n // BLOCK, threads() * BLOCKS_PER_THREAD))
    starts = np.flatnonzero(args[-1])
    cut = starts[np.minimum(np.searchsorted(starts, np.linspace(0, n, parts + 1)[1:-1]), starts.size - 1)]
    bounds = np.unique(np.concatenate([[0], cut, [n]]))
    parts = bounds.size - 1
    if parts == 1:
        analyze_range(0, n, *_scratch(fl, rules), fl, rules, *args)
        return
    futures = [
        _pool().submit(analyze_range, int(a), int(b), *_scratch(fl, rules), fl, rules, *args)
        for a, b in zip(bounds[:-1], bounds[1:])
    ]
    for f in futures:
        f.result()


@lru_cache(maxsize=1)
def _setup() -> tuple[FlatLoop, Rules]:
    """The flat loop and the :class:`Rules` (read from their homes) of the slider crank."""
    from dualmech.core.kernel.closure_nb import closure_tols
    from dualmech.core.kernel.loop_nb import value_names
    from dualmech.core.status import Status
    from dualmech.core.thresholds import ASSEMBLY_LIMIT_CONDITION, ASSEMBLY_REACH
    from dualmech.models import slider_crank_loop as sc

    names = value_names(sc.LOOP)
    vidx = np.array([names.index(k) for k in ("theta1", "S1", "a1", "a2", "a4", "alpha4")], dtype=np.int64)
    order = (
        Status.OK,
        Status.DEAD_CENTRE,
        Status.ASSEMBLY_LIMIT,
        Status.BRANCH_JUMP,
        Status.NOT_CONVERGED,
        Status.NO_ASSEMBLY,
        Status.NOT_FINITE,
    )
    codes = np.array([STATUSES.index(s.value) for s in order], dtype=np.int64)
    rules = Rules(
        closure_tols(),
        vidx,
        codes,
        ASSEMBLY_REACH.value,
        ASSEMBLY_LIMIT_CONDITION.value,
        sc.DEAD_CENTRE,
        sc.CONTINUATION_STEPS,
    )
    return flatten(sc.LOOP), rules


#: Status words by code (:data:`dualmech.core.status.STATUSES`), for turning codes into words.
WORDS = np.array(STATUSES, dtype=object)


@dataclass(frozen=True)
class Chunk:
    """The kernel's answer for consecutive positions of one or more cases (arrays ``(n,)``).

    ``columns`` maps every name of :data:`OUT_COLUMNS` to a column (a strided view) of one ``(n, 28)`` array;
    ``status`` holds codes into :data:`WORDS`; ``iterations`` closure iterations;
    ``dynamics_residual`` the Newton-Euler residual (NaN where the reactions are not given).
    """

    columns: dict[str, np.ndarray]
    status: np.ndarray
    iterations: np.ndarray
    dynamics_residual: np.ndarray

    def words(self) -> np.ndarray:
        """Status words, object array ``(n,)``."""
        return WORDS[self.status]


def case_arrays(cases: Sequence[Case]) -> tuple[np.ndarray, tuple]:
    """Geometry ``(cases, 4)`` and the per-case body and load arrays of :func:`analyze_positions`."""
    geo = np.array(
        [
            [
                c.geometry.crank_length,
                c.geometry.rod_length,
                c.geometry.slider_offset,
                c.geometry.slider_twist,
            ]
            for c in cases
        ],
        dtype=float,
    )
    parts = [[getattr(c.bodies, b) for b in ("crank", "rod", "slider")] for c in cases]
    mass = np.array([[b.mass for b in p] for p in parts], dtype=float)
    com = np.array([[b.com for b in p] for p in parts], dtype=float)
    inertia = np.array([[b.inertia for b in p] for p in parts], dtype=float)
    gravity = np.array([c.loads.gravity for c in cases], dtype=float).reshape(len(cases), 3)
    given = np.array(
        [
            [
                np.nan if c.loads.drive_torque is None else c.loads.drive_torque,
                np.nan if c.loads.slider_force is None else c.loads.slider_force,
            ]
            for c in cases
        ],
        dtype=float,
    )
    return geo, (mass, com, inertia, gravity, given[:, 0].copy(), given[:, 1].copy())


def analyze_chunk(
    cases: Sequence[Case], cranks: Sequence[CrankState], out: np.ndarray | None = None
) -> Chunk:
    """Analyse the positions ``cranks[i]`` of every ``cases[i]``, concatenated, with the compiled kernel.

    ``out`` ``(>= n, len(OUT_COLUMNS))``: a buffer to reuse (its first ``n`` rows are written).
    """
    counts = [len(c) for c in cranks]
    crank = np.empty((6, sum(counts)))
    for k, name in enumerate(("theta", "s", "theta_dot", "s_dot", "theta_ddot", "s_ddot")):
        np.concatenate([getattr(c, name) for c in cranks], out=crank[k])
    case_of = np.repeat(np.arange(len(cases), dtype=np.int64), counts)
    geo, bodies = case_arrays(cases)
    return analyze_positions(crank, case_of, geo, bodies, out)


def analyze_positions(
    crank: np.ndarray,
    case_of: np.ndarray,
    geo: np.ndarray,
    bodies: tuple,
    out: np.ndarray | None = None,
    index: np.ndarray | None = None,
) -> Chunk:
    """Analyse positions given as arrays (no :class:`Case` objects: for many designs at once).

    ``crank`` ``(6, n)``: theta [rad], S1 and their first and second time derivatives; ``case_of``
    ``(n,)`` int64: the design of each position, indexing the first axis of ``geo`` ``(designs, 4)``
    (a1, a2, a4, alpha4 [rad]) and of each array of ``bodies`` (the layout of :func:`case_arrays`:
    masses ``(designs, 3)``, centres of mass ``(designs, 3, 3)``, inertias ``(designs, 3, 3, 3)``
    of crank, rod and slider, gravity ``(designs, 3)``, given drive torque and slider load
    ``(designs,)``, NaN where not given).  ``out``: a ``(>= n, len(OUT_COLUMNS))`` buffer to reuse.
    ``index`` ``(n,)``: each position's index in its design (default: from its run's start), which
    fixes the cold starts (:func:`chain_starts`); a run that does not begin at a multiple of
    :data:`WARM_CHAIN` starts cold there, so its bits may differ from the whole design's.
    """
    fl, rules = _setup()
    n = crank.shape[1]
    if out is None or out.shape[0] < n:
        out = np.empty((n, len(OUT_COLUMNS)))
    out = out[:n]
    status, iters, dyn = np.empty(n, np.int8), np.empty(n, np.int64), np.empty(n)
    _run(n, fl, rules, (crank, case_of, geo, bodies, out, status, iters, dyn, chain_starts(case_of, index)))
    return Chunk(dict(zip(OUT_COLUMNS, out.T)), status, iters, dyn)


def iter_chunks(case: Case, chunk_positions: int) -> Iterator[Chunk]:
    """The positions of one case in chunks of ``chunk_positions`` (rounded up to a multiple of
    :data:`WARM_CHAIN`, so that no chain of warm starts straddles two chunks), one output buffer reused.

    Memory stays bounded by the chunk, however many positions the case has.
    """
    angles = np.asarray(case.motion.angles_deg, dtype=float)
    chunk_positions = -(-chunk_positions // WARM_CHAIN) * WARM_CHAIN
    buffer = np.empty((min(chunk_positions, max(1, angles.size)), len(OUT_COLUMNS)))
    for lo in range(0, angles.size, chunk_positions):
        crank = case.motion.state(case.geometry.crank_axial_shift, angles[lo : lo + chunk_positions])
        yield analyze_chunk([case], [crank], buffer)


def to_table(case: Case, chunk: Chunk) -> ResultTable:
    """The common result table of one case's :class:`Chunk` (columns copied out of the buffer)."""
    from dualmech.models.slider_crank import status_messages

    cols = {c: chunk.columns[c].copy() for c in NUMERIC_COLUMNS}
    status = chunk.words()
    meta = {
        "iterations": chunk.iterations.copy(),
        "dynamics_residual": chunk.dynamics_residual.copy(),
        "messages": status_messages(cols["theta1_deg"], status),
    }
    return ResultTable("dualmech", case.name, cols, status, meta)


def solve_cases(cases: Sequence[Case], chunk_positions: int = CHUNK_POSITIONS) -> list[ResultTable]:
    """The result table of every case, cases batched together in chunks of about ``chunk_positions``."""
    tables: list[ResultTable] = []
    group: list[Case] = []
    for i, case in enumerate(cases):
        group.append(case)
        size = sum(len(c.motion.angles_deg) for c in group)
        if size >= chunk_positions or i == len(cases) - 1:
            chunk = analyze_chunk(group, [c.motion.state(c.geometry.crank_axial_shift) for c in group])
            start = 0
            for c in group:
                n = len(c.motion.angles_deg)
                part = slice(start, start + n)
                tables.append(
                    to_table(
                        c,
                        Chunk(
                            {k: v[part] for k, v in chunk.columns.items()},
                            chunk.status[part],
                            chunk.iterations[part],
                            chunk.dynamics_residual[part],
                        ),
                    )
                )
                start += n
            group = []
    return tables


def solve_case(case: Case) -> ResultTable:
    """In-house engine, compiled: every position of ``case`` in one chunk, as the common result table."""
    n = len(case.motion.angles_deg)
    return to_table(case, next(iter_chunks(case, max(1, n))))
