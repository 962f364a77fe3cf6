"""The in-house engine compiled: the positions of a chunk analysed in parallel into preallocated rows.

Positions are split into blocks, each analysed on a thread of a pool with the GIL released
(:func:`dualmech.models.slider_crank.position_nb.analyze_range`: one position at a time, warm
starts along the crank angle in fixed chains, see :data:`WARM_CHAIN`); the scratch of each block
is allocated here, since the compiled code allocates nothing.  Cases, designs given as arrays,
and chunks of one long case all go through :func:`start_positions`; status codes become words
in :class:`Chunk`.

The numpy implementation in :mod:`dualmech.models.slider_crank.analysis` is the same algorithm
batched; ``tests/core/test_kernel.py`` holds the two to 1e-12.
"""

from __future__ import annotations

from collections import deque
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from functools import lru_cache
from itertools import islice
from typing import Iterator, Sequence

import numpy as np

from dualmech.core.kernel.closure_nb import Work, make_work
from dualmech.core.kernel.compiles import compile_session
from dualmech.core.kernel.loop_nb import FlatLoop, flatten
from dualmech.core.kernel.pool import kernel_pool as _pool
from dualmech.core.kernel.pool import threads
from dualmech.core.motion import CrankState
from dualmech.core.status import STATUSES, Status
from dualmech.core.table import NUMERIC_COLUMNS, ResultTable
from dualmech.models.angle_ranges import status_messages
from dualmech.models.case import Case
from dualmech.models.slider_crank.kernel_nb import (
    Rules,
    Scratch,
    make_scratch,
)
from dualmech.models.slider_crank.position_nb import OUT_COLUMNS, analyze_range

#: Positions analysed together at most (about 250 bytes each with the crank states).
CHUNK_POSITIONS = 100_000
#: Every this many positions of a case (counted from its first) start cold, and only there may a block
#: of positions begin: each position's start, hence every bit of its result, is then the same whatever
#: the number of threads, the chunk size (a multiple of it) or the cases sharing a chunk.  A cold
#: start costs about 1 µs more; one in 100 positions adds about 1 %.
WARM_CHAIN = 100
#: Fewest positions worth a thread of their own.
BLOCK = 256
#: Blocks per thread in a chunk: uneven work (DFP, continuation near edges) evens out.
BLOCKS_PER_THREAD = 4


def _scratch(fl: FlatLoop, rules: Rules) -> tuple[Work, Scratch]:
    """The scratch arrays of one block of positions (the compiled code allocates nothing)."""
    w = make_work(fl)
    return w, make_scratch(rules.vidx.size, w.base.size)


def chain_aligned(chunk_positions: int) -> int:
    """``chunk_positions`` rounded up to a multiple of :data:`WARM_CHAIN`: chunks of a case that begin
    where a chain of warm starts begins give the same bits as the case in one piece."""
    return -(-chunk_positions // WARM_CHAIN) * WARM_CHAIN


def chain_starts(case_of: np.ndarray, index: np.ndarray | None = None) -> np.ndarray:
    """``(n,)`` bool: the positions that start cold: the first of each run of one case in ``case_of``, and
    every :data:`WARM_CHAIN` of a case's positions (``index``: their indices in the case; default:
    counted from the run's first)."""
    n = case_of.size
    first = np.ones(n, dtype=bool)
    first[1:] = case_of[1:] != case_of[:-1]
    if index is None:  # each position less the first of its run
        starts = np.flatnonzero(first)
        index = np.arange(n) - np.repeat(starts, np.diff(np.append(starts, n)))
    return first | (index % WARM_CHAIN == 0)


def _start(n: int, fl: FlatLoop, rules: Rules, args: tuple) -> list[Future]:
    """:func:`analyze_range` over ``n`` positions, :data:`BLOCKS_PER_THREAD` blocks a thread, submitted to
    the kernel's threads (the futures of the blocks returned), or run here if one block is all (no futures);
    blocks begin at cold starts (the last of ``args``) only."""
    parts = max(1, min(n // BLOCK, threads() * BLOCKS_PER_THREAD))
    starts = np.flatnonzero(args[-1])
    cut = starts[np.minimum(np.searchsorted(starts, np.linspace(0, n, parts + 1)[1:-1]), starts.size - 1)]
    bounds = np.unique(np.concatenate([[0], cut, [n]]))
    if bounds.size == 2:
        analyze_range(0, n, *_scratch(fl, rules), fl, rules, *args)
        return []
    return [
        _pool().submit(analyze_range, int(a), int(b), *_scratch(fl, rules), fl, rules, *args)
        for a, b in zip(bounds[:-1], bounds[1:])
    ]


@lru_cache(maxsize=1)
def load_kernel() -> tuple[FlatLoop, Rules]:
    """The flat loop and the :class:`Rules` (read from their homes) of the slider crank, the kernel loaded
    from numba's disk cache or, cold, compiled (minutes, once, logged as one compile: its run on no
    positions, with the one signature of every call, :func:`start_positions`'s C-contiguous arrays)."""
    from dualmech.core import thresholds as th
    from dualmech.core.kernel.closure_nb import closure_tols
    from dualmech.core.kernel.loop_nb import value_names
    from dualmech.core.status import Status as S
    from dualmech.models.slider_crank import loop as sc

    names = value_names(sc.LOOP)
    vidx = np.array([names.index(k) for k in ("theta1", "S1", "a1", "a2", "a4", "alpha4")], dtype=np.int64)
    order = (S.OK, S.DEAD_CENTRE, S.ASSEMBLY_LIMIT, S.BRANCH_JUMP, S.NOT_CONVERGED, S.NO_ASSEMBLY,
             S.NOT_FINITE, S.JOINT_LOCK)
    codes = np.array([STATUSES.index(s.value) for s in order], dtype=np.int64)
    tols = closure_tols()
    rules = Rules(tols, tols._replace(closure=0.0), th.EDGE_REFINE_CONDITION.value, vidx, codes,
                  th.ASSEMBLY_REACH.value, th.ASSEMBLY_LIMIT_CONDITION.value, sc.DEAD_CENTRE,
                  th.JOINT_LOCK_CONDITION.value, sc.CONTINUATION_STEPS)
    fl, z = flatten(sc.LOOP), np.empty
    bodies = (z((0, 3)), z((0, 3, 3)), z((0, 3, 3, 3)), z((0, 3)), z(0), z(0))
    with compile_session():
        analyze_range(0, 0, *_scratch(fl, rules), fl, rules, z((6, 0)), z(0, np.int64), z((0, 5)), bodies,
                      z((len(OUT_COLUMNS), 0)), z(0, np.int8), z(0, np.int64), z(0), z(0, bool))
    return fl, rules


#: Status words by code (:data:`dualmech.core.status.STATUSES`), for turning codes into words.
WORDS = np.array(STATUSES, dtype=object)
#: The code of ``no_assembly``.
NO_ASSEMBLY = STATUSES.index(Status.NO_ASSEMBLY)


@dataclass(frozen=True)
class Chunk:
    """The kernel's answer for consecutive positions of one or more cases (arrays ``(n,)``).

    ``columns`` maps every name of :data:`OUT_COLUMNS` to a row (contiguous) of one ``(31, n)`` array;
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


@dataclass(frozen=True)
class Running:
    """A :class:`Chunk` whose positions are being analysed: ``blocks`` the futures of its blocks on the
    kernel's threads (none if it was analysed where it was started)."""

    chunk: Chunk
    blocks: list[Future]

    def result(self) -> Chunk:
        """The chunk, once every block is analysed (a block's error is raised here)."""
        for block in self.blocks:
            block.result()
        return self.chunk

    def cancel(self) -> None:
        """Drop the blocks not begun; those running finish into the chunk's buffer."""
        for block in self.blocks:
            block.cancel()


def case_arrays(cases: Sequence[Case]) -> tuple[np.ndarray, tuple]:
    """Geometry ``(cases, 5)`` (a1, a2, a4, alpha4, 1 for a universal joint 3) and the per-case body and
    load arrays of :func:`start_positions`."""
    geo = np.array(
        [
            [
                c.geometry.crank_length,
                c.geometry.rod_length,
                c.geometry.slider_offset,
                c.geometry.slider_twist,
                float(c.joints.universal),
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

    ``out``: a C-contiguous buffer to reuse, of ``len(OUT_COLUMNS) * n`` elements or more (its first
    ones are written, as a ``(len(OUT_COLUMNS), n)`` array).
    """
    return start_chunk(cases, cranks, out).result()


def start_chunk(
    cases: Sequence[Case], cranks: Sequence[CrankState], out: np.ndarray | None = None
) -> Running:
    """:func:`analyze_chunk` begun on the kernel's threads, not waited for."""
    counts = [len(c) for c in cranks]
    crank = np.empty((6, sum(counts)))
    for k, name in enumerate(("theta", "s", "theta_dot", "s_dot", "theta_ddot", "s_ddot")):
        np.concatenate([getattr(c, name) for c in cranks], out=crank[k])
    case_of = np.repeat(np.arange(len(cases), dtype=np.int64), counts)
    geo, bodies = case_arrays(cases)
    return start_positions(crank, case_of, geo, bodies, out)


def start_positions(
    crank: np.ndarray,
    case_of: np.ndarray,
    geo: np.ndarray,
    bodies: tuple,
    out: np.ndarray | None = None,
    index: np.ndarray | None = None,
) -> Running:
    """Begin the analysis of positions given as arrays (no :class:`Case` objects: for many designs at
    once) on the kernel's threads; :meth:`Running.result` waits for it.  A second chunk begun before
    the first is done keeps both threads busy while the first's last block finishes.

    ``crank`` ``(6, n)``: theta [rad], S1 and their first and second time derivatives; ``case_of``
    ``(n,)`` int64: the design of each position, indexing the first axis of ``geo`` ``(designs, 4)``
    (a1, a2, a4, alpha4 [rad]) and of each array of ``bodies`` (the layout of :func:`case_arrays`:
    masses ``(designs, 3)``, centres of mass ``(designs, 3, 3)``, inertias ``(designs, 3, 3, 3)``
    of crank, rod and slider, gravity ``(designs, 3)``, given drive torque and slider load
    ``(designs,)``, NaN where not given).  ``out``: a buffer to reuse, as in :func:`analyze_chunk`.
    ``index`` ``(n,)``: each position's index in its design (default: from its run's start), which
    fixes the cold starts (:func:`chain_starts`); a run that does not begin at a multiple of
    :data:`WARM_CHAIN` starts cold there, so its bits may differ from the whole design's.
    """
    fl, rules = load_kernel()
    n = crank.shape[1]
    out = _rows(out, n)
    status, iters, dyn = np.empty(n, np.int8), np.empty(n, np.int64), np.empty(n)
    args = (crank, case_of, geo, bodies, out, status, iters, dyn, chain_starts(case_of, index))
    return Running(Chunk(dict(zip(OUT_COLUMNS, out)), status, iters, dyn), _start(n, fl, rules, args))


def _rows(buffer: np.ndarray | None, n: int) -> np.ndarray:
    """A C-contiguous ``(len(OUT_COLUMNS), n)`` view of the first elements of ``buffer`` (new if there is
    none or it is too small).  Not ``buffer[:, :n]``: that slice (a case's last, partial chunk) would reach
    the kernel with numba's ``A`` layout, a second signature, compiled again for minutes."""
    size = len(OUT_COLUMNS) * n
    if buffer is None or buffer.size < size:
        return np.empty((len(OUT_COLUMNS), n))
    if not buffer.flags.c_contiguous:
        raise ValueError(f"out: expected a C-contiguous buffer, got strides {buffer.strides}")
    return buffer.reshape(-1)[:size].reshape(len(OUT_COLUMNS), n)


def iter_chunks(case: Case, chunk_positions: int, buffers: int = 1, ahead: int = 0) -> Iterator[Chunk]:
    """The positions of one case in chunks of ``chunk_positions`` (rounded up to a multiple of
    :data:`WARM_CHAIN`, so that no chain of warm starts straddles two chunks), in ``buffers`` output
    buffers reused in turn: chunk ``k`` is written into buffer ``k % buffers``.

    The kernel's threads run ``ahead`` chunks beyond the one yielded last (with 0 they wait at each
    chunk's end while its last block finishes): chunk ``k`` is begun when chunk ``k - ahead`` is asked
    for, so a consumer may read chunk ``k`` (write it to a file on another thread) until it asks for
    chunk ``k + buffers - ahead``.  Memory stays bounded by ``buffers`` chunks, however many positions
    the case has.
    """
    if buffers < 1:
        raise ValueError(f"buffers: expected at least 1, got {buffers}")
    if not 0 <= ahead < buffers:
        raise ValueError(
            f"ahead: expected 0 to {buffers - 1} (fewer than the {buffers} buffers), got {ahead}"
        )
    angles = np.asarray(case.motion.angles_deg, dtype=float)
    chunk_positions = chain_aligned(chunk_positions)
    rows = min(chunk_positions, max(1, angles.size))
    los = range(0, angles.size, chunk_positions)
    pool = [np.empty((len(OUT_COLUMNS), rows)) for _ in range(max(1, min(buffers, len(los))))]

    def crank(lo: int) -> CrankState:
        return case.own_crank_states(angles[lo : lo + chunk_positions])

    # each chunk's crank states are made on a helper thread while the kernel analyses the one before
    with ThreadPoolExecutor(max_workers=1, thread_name_prefix="dualmech-crank") as helper:

        def begun() -> Iterator[Running]:
            states = helper.submit(crank, 0)
            for j in range(len(los)):
                ready = states.result()
                if j + 1 < len(los):
                    states = helper.submit(crank, los[j + 1])
                yield start_chunk([case], [ready], pool[j % len(pool)])

        for running in _ahead(begun(), ahead):
            yield running.result()


def _ahead(begun: Iterator[Running], ahead: int) -> Iterator[Running]:
    """The chunks of ``begun`` in order, chunk ``k + ahead`` begun (drawn from ``begun``) before chunk ``k``
    is handed on; those begun and not handed on are cancelled when the consumer stops early (or fails)."""
    queue = deque(islice(begun, ahead))
    try:
        for running in begun:
            queue.append(running)
            yield queue.popleft()
        while queue:
            yield queue.popleft()
    finally:
        for running in queue:
            running.cancel()


def to_table(case: Case, chunk: Chunk, copy: bool = True) -> ResultTable:
    """The common result table of one case's :class:`Chunk`; ``copy``: columns copied out of the buffer
    (``False`` where the chunk's arrays are the table's to keep)."""
    cols = {c: chunk.columns[c].copy() if copy else chunk.columns[c] for c in NUMERIC_COLUMNS}
    meta = {
        "iterations": chunk.iterations.copy() if copy else chunk.iterations,
        "dynamics_residual": chunk.dynamics_residual.copy() if copy else chunk.dynamics_residual,
        "messages": status_messages(cols["theta1_deg"], chunk.status == NO_ASSEMBLY),
    }
    return ResultTable("dualmech", case.name, cols, chunk.words(), meta)


def _groups(sizes: Sequence[int], chunk_positions: int) -> list[list[int]]:
    """Consecutive indices of ``sizes`` in groups of at least ``chunk_positions`` in all (the last one
    may be smaller)."""
    groups: list[list[int]] = [[]]
    size = 0
    for i, n in enumerate(sizes):
        if size >= chunk_positions:
            groups.append([])
            size = 0
        groups[-1].append(i)
        size += n
    return groups if groups[0] else []


def solve_cases(cases: Sequence[Case], chunk_positions: int = CHUNK_POSITIONS,
                cranks: Sequence[CrankState] | None = None) -> list[ResultTable]:
    """The result table of every case (at its own crank states, or at ``cranks[i]`` for ``cases[i]``), cases
    batched together in chunks of about ``chunk_positions``.

    Each chunk is begun before the tables of the one before are made, so the kernel's threads do not
    wait for that Python.  Each chunk's columns are copied once, into one contiguous ``(columns, n)``
    array whose rows the chunk's tables share (not copied again per case and column).
    """
    def begin(group: list[int]) -> Running:
        states = [cases[j].own_crank_states() if cranks is None else cranks[j] for j in group]
        return start_chunk([cases[j] for j in group], states)

    sizes = [len(c.motion.angles_deg) for c in cases] if cranks is None else [len(s) for s in cranks]
    groups = _groups(sizes, chunk_positions)
    tables: list[ResultTable] = []
    for group, running in zip(groups, _ahead(map(begin, groups), 1)):
        chunk = running.result()
        columns = np.array([chunk.columns[c] for c in NUMERIC_COLUMNS])
        start = 0
        for j in group:
            part = slice(start, start + sizes[j])
            start = part.stop
            own = Chunk(dict(zip(NUMERIC_COLUMNS, columns[:, part])), chunk.status[part],
                        chunk.iterations[part], chunk.dynamics_residual[part])
            tables.append(to_table(cases[j], own, copy=False))
    return tables


def solve_case(case: Case) -> ResultTable:
    """In-house engine, compiled: every position of ``case`` in one chunk, as the common result table."""
    n = len(case.motion.angles_deg)
    return to_table(case, next(iter_chunks(case, max(1, n))))
