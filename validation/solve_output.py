"""The output of ``dualmech solve``: the table as CSV or Parquet, long in-house cases streamed chunk by chunk.

A case of more than :data:`STREAM_POSITIONS` crank positions solved by the in-house engine
never exists whole in memory: the compiled kernel analyses it chunk by chunk into three
buffers used in turn (:func:`~dualmech.models.slider_crank.kernel.iter_chunks`), one chunk ahead,
and each chunk goes to the file (a Parquet row group, or CSV rows) on a writer thread while the
kernel computes the next, so memory is bounded by three chunks (and the writer's buffer).  Its summary then
gives what can be gathered on the way: status counts, stroke, worst closure residual and the
``no_assembly`` ranges (the design peaks need the table: load the Parquet file).
"""

from __future__ import annotations

import os
import threading
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Iterable

import numpy as np

from dualmech.core.files import replacing
from dualmech.core.status import STATUSES
from dualmech.core.table import NUMERIC_COLUMNS, ColumnTable, ParquetWriter, status_codes, write_parquet
from dualmech.models.case import Case
from dualmech.models.plausibility import masses_line
from dualmech.models.tables import LinkageTable
from dualmech.models.units import column_unit

if TYPE_CHECKING:  # the kernel (numba) is imported when a case is solved, not with the command line
    from dualmech.models.loop.chunks import Chunk as LoopChunk
    from dualmech.models.loop.description import LoopMechanism
    from dualmech.models.slider_crank.kernel import Chunk
    from dualmech.validation.progress import ProgressCallback

#: Cases longer than this stream to their file (one chunk of the kernel each).
STREAM_POSITIONS = 100_000
#: Positions of a loop table's chunk (:func:`stream_loop_solve`): ~2.8 kB each while it is analysed.
LOOP_CHUNK = 65_536
#: Output formats by file suffix.
FORMATS = (".csv", ".parquet")


def output_format(path: str | Path) -> str:
    """``.csv`` or ``.parquet`` from the file name; a ValueError naming the suffix otherwise."""
    suffix = Path(path).suffix.lower()
    if suffix not in FORMATS:
        raise ValueError(
            f"-o {path}: unknown output format {suffix or '(no suffix)'!r} (valid: {', '.join(FORMATS)})"
        )
    return suffix


def write_table(table: ColumnTable, path: str | Path) -> None:
    """Write ``table`` to ``path`` in the format of its suffix (:func:`output_format`), atomically: written
    beside, fsynced, renamed (:func:`~dualmech.core.files.replacing`); a failed or interrupted write
    leaves the old file as it was."""
    if output_format(path) == ".parquet":
        write_parquet(table, path)
    else:
        table.to_csv(path)


class _Tally:
    """What a streamed solve's summary needs, gathered chunk by chunk."""

    def __init__(self) -> None:
        self.counts = np.zeros(len(STATUSES), dtype=np.int64)
        self.extremes: list[tuple[float, float]] = []  # (S4, theta1_deg) of each chunk's max and min
        self.worst = -np.inf
        self.no_assembly: list[np.ndarray] = []  # the rows of each chunk that are no_assembly

    def add(self, columns: dict[str, np.ndarray], codes: np.ndarray) -> None:
        first = int(self.counts.sum())  # the chunk's first row in the case
        beyond = codes == STATUSES.index("no_assembly")
        self.no_assembly.append(first + np.flatnonzero(beyond))
        self.counts += np.bincount(codes, minlength=len(STATUSES))
        s4, theta = columns["S4"], columns["theta1_deg"]
        if np.isfinite(s4).any():
            for i in (int(np.nanargmax(s4)), int(np.nanargmin(s4))):
                self.extremes.append((float(s4[i]), float(theta[i])))
        closed = columns["residual"][~beyond]  # beyond reach: the reach's excess, not a closure residual
        if np.isfinite(closed).any():
            self.worst = max(self.worst, float(np.nanmax(closed)))

    def text(self, case: Case, messages: list[str]) -> str:
        lines = [f"case {case.name} (dualmech): {int(self.counts.sum())} positions, streamed",
                 masses_line(case)]
        lines.append("status: " + ", ".join(f"{w} {n}" for w, n in sorted(zip(STATUSES, self.counts)) if n))
        if self.extremes:
            hi = max(self.extremes, key=lambda e: e[0])  # first of equal maxima, as nanargmax
            lo = min(self.extremes, key=lambda e: e[0])
            unit = f" {column_unit('S4', case.units)}".rstrip()
            lines.append(
                f"stroke: {hi[0] - lo[0]:.9g}{unit} (max S4 {hi[0]:.9g} at {hi[1]:g} deg, "
                f"min S4 {lo[0]:.9g} at {lo[1]:g} deg)"
            )
        if np.isfinite(self.worst):
            lines.append(f"worst closure residual: {self.worst:.3g}")
        return "\n".join(lines + messages)


def _pipelined(chunks: Iterable[Chunk], sink: Callable[[int, Chunk], None]) -> None:
    """``sink(k, chunk)`` for every chunk in order, on a writer thread while the next chunk is computed.

    One chunk at most is being written: chunk ``k + 1`` is handed over once chunk ``k`` is written, and
    only then is chunk ``k + 2`` asked for (and chunk ``k + 3`` begun), so with the kernel one chunk
    ahead three buffers used in turn suffice
    (:func:`~dualmech.models.slider_crank.kernel.iter_chunks` with ``buffers=3, ahead=1``).  An exception of
    ``sink`` is raised here (when the next chunk is ready, or at the end); on any exception, an
    interrupt too, the write in flight is finished first, so the caller may then close the file with
    every finished chunk in it.
    """
    with ThreadPoolExecutor(max_workers=1, thread_name_prefix="dualmech-writer") as writer:
        pending: Future | None = None
        for k, chunk in enumerate(chunks):
            if pending is not None:
                pending.result()
            pending = writer.submit(sink, k, chunk)
        if pending is not None:
            pending.result()


def _hold_old_file(path: Path) -> int | None:
    """A descriptor of the regular file (not a link) at ``path``, or ``None``: held while the new file is
    renamed over it, so that the old file's blocks are freed when the descriptor is closed
    (:func:`_let_go`, on a helper thread), not in the rename: freeing a 350 MB file took 20 ms."""
    if not path.is_file() or path.is_symlink():
        return None
    try:
        return os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC)
    except OSError:  # unreadable: its blocks are freed in the rename
        return None


def _let_go(held: int | None) -> None:
    if held is not None:
        threading.Thread(target=os.close, args=(held,), name="dualmech-free", daemon=True).start()


def is_long(case: Case) -> bool:
    """Whether ``case`` has more than :data:`STREAM_POSITIONS` crank positions (``solve -o`` streams it)."""
    return len(case.motion.angles_deg) > STREAM_POSITIONS


def stream_solve(case: Case, path: str | Path, progress: ProgressCallback | None = None) -> str:
    """Solve ``case`` with the compiled in-house engine chunk by chunk into ``path``; return the summary;
    ``progress(positions written, positions, "")`` after each chunk.

    Each chunk is written (and tallied) on a writer thread while the kernel computes the next
    (:func:`_pipelined`), the kernel's threads going on to the chunk after without waiting at a chunk's
    end: memory is three chunks of the kernel's rows and the writer's buffer.  The file is written beside
    ``path`` and renamed onto it once whole and fsynced (:func:`~dualmech.core.files.replacing`):
    an error, a full disk or Ctrl-C leaves the old file as it was and no partial one.
    """
    from dualmech.models.angle_ranges import no_assembly_message, row_ranges
    from dualmech.models.slider_crank.kernel import CHUNK_POSITIONS, iter_chunks, to_table

    tally = _Tally()

    def rows(chunk: Chunk) -> tuple[dict[str, np.ndarray], np.ndarray, Callable[[], str]]:
        tally.add(chunk.columns, chunk.status)
        return chunk.columns, chunk.status, lambda: to_table(case, chunk).to_csv()

    _stream_into(path, NUMERIC_COLUMNS, iter_chunks(case, CHUNK_POSITIONS, buffers=3, ahead=1), rows,
                 len(case.motion.angles_deg), progress)
    theta = np.asarray(case.motion.angles_deg, dtype=float)
    ranges = row_ranges(theta, np.concatenate(tally.no_assembly))
    return tally.text(case, no_assembly_message(ranges))


def is_long_loop(mechanism: "LoopMechanism") -> bool:
    """Whether loop table ``mechanism`` has more than :data:`STREAM_POSITIONS` drive positions (``solve -o``
    streams it)."""
    return np.asarray(mechanism.drive.positions).size > STREAM_POSITIONS


def stream_loop_solve(mechanism: "LoopMechanism", path: str | Path,
                      progress: ProgressCallback | None = None) -> str:
    """Solve loop table ``mechanism`` with the in-house engine chunk by chunk into ``path``
    (:func:`~dualmech.models.loop.chunks.iter_analyses`, :data:`LOOP_CHUNK` positions each; each chunk's
    table made and written on a writer thread while the next is analysed, :func:`_pipelined`: the table's
    numpy work on one core beside the kernel on every core); return the summary, as
    ``solve`` gives it of the whole table (:func:`dualmech.models.linkages.summary`: from the status words
    and closure residuals kept on the way, 9 bytes a position); ``progress(positions written, positions,
    "")`` after each chunk.  Written beside ``path`` and renamed onto it once whole, as
    :func:`stream_solve`."""
    from dualmech.models.linkages import summary
    from dualmech.models.loop.chunks import chunk_table, iter_analyses
    from dualmech.models.loop.columns import key_values, loop_spec
    from dualmech.models.loop.table import ENGINE, gap_messages

    spec = loop_spec(mechanism)
    n = np.asarray(mechanism.drive.positions).size
    codes, residual, written = np.empty(n, dtype=np.int8), np.empty(n), [0]

    def rows(chunk: LoopChunk) -> tuple[dict[str, np.ndarray], np.ndarray, Callable[[], str]]:
        table = chunk_table(chunk)
        kept = slice(written[0], written[0] + len(table))
        codes[kept], residual[kept] = status_codes(table.status), table.columns["residual"]
        written[0] += len(table)
        return table.columns, codes[kept], table.to_csv

    _stream_into(path, spec.columns, iter_analyses(mechanism, LOOP_CHUNK), rows, n, progress)
    words = np.asarray(STATUSES, dtype=object)[codes]
    table = LinkageTable(ENGINE, mechanism.name, {spec.key: key_values(mechanism), "residual": residual},
                         words, {})
    table.meta["messages"] = gap_messages(table, spec)
    return summary(table)


def _stream_into(path: str | Path, names: tuple[str, ...], chunks: Iterable, rows: Callable,
                 total: int, progress: ProgressCallback | None) -> None:
    """Write ``chunks`` (of ``total`` positions) into ``path`` as they come, each on a writer thread while the
    next is computed (:func:`_pipelined`): ``rows(chunk)`` gives its columns (``names`` of them go to
    Parquet), its status codes and a function of its CSV text (the header dropped after the first chunk);
    ``progress(positions written, total, "")`` after each.  Written beside ``path`` and renamed onto it
    once whole and fsynced (:func:`~dualmech.core.files.replacing`): an error, a full disk or Ctrl-C leaves
    the old file as it was and no partial one."""
    parquet = output_format(path) == ".parquet"
    held = _hold_old_file(Path(path))
    written = [0]
    try:
        with replacing(path) as (tmp, fd):
            out = ParquetWriter(tmp, names) if parquet else os.fdopen(os.dup(fd), "w")

            def sink(k: int, chunk: object) -> None:
                columns, codes, csv = rows(chunk)
                if parquet:
                    out.write(columns, codes)
                else:
                    text = csv()
                    out.write(text if k == 0 else text.split("\n", 1)[1])
                written[0] += codes.size
                if progress is not None:
                    progress(written[0], total, "")

            with out:
                _pipelined(chunks, sink)
    finally:
        _let_go(held)
