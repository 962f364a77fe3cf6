"""``stream_solve``: each chunk is written on a writer thread while the kernel computes the next.

What the pipeline must keep (``tests/cli/test_solve_output.py`` holds the streamed rows and summary
to the case solved whole): a chunk's buffer is not overwritten while it is being written (two kernel
buffers in turn); an error of the writer is raised, not lost; an interrupted run leaves a readable
file of the chunks finished, as the sequential loop did.  No timing: the overlap is shown by a writer
that waits until the kernel has computed the next chunk.  Deliberate faults these tests were seen to
catch (each made by hand in a scratch edit, then undone): the sequential loop (no writer thread: the
writer waits for a chunk never computed); the writer's error only waited for (``wait([pending])``
instead of ``pending.result()``), or the last one not waited for at all.
"""

from __future__ import annotations

import threading

import numpy as np
import pytest

from dualmech.core import table
from dualmech.core.table import NUMERIC_COLUMNS, read_csv, read_parquet
from dualmech.models import slider_crank_kernel
from dualmech.models.case import load_case
from dualmech.validation import solve_output

#: Positions per chunk (a multiple of WARM_CHAIN) and chunks of :func:`_case` (360 positions).
CHUNK, CHUNKS = 100, 4


def _case(monkeypatch: pytest.MonkeyPatch):
    """The thesis example with some ``no_assembly`` rows, in chunks of :data:`CHUNK`, and its whole table."""
    monkeypatch.setattr(slider_crank_kernel, "CHUNK_POSITIONS", CHUNK)
    case = load_case("a4-30-s1-3.5").with_values({"geometry.slider_offset": 40.0})
    return case, slider_crank_kernel.solve_case(case)


def _same_rows(read: table.ResultTable, whole: table.ResultTable, rows: int) -> None:
    """The first ``rows`` rows of ``whole``, bit for bit (NaN as NaN)."""
    assert len(read) == rows
    for c in NUMERIC_COLUMNS:
        assert np.array_equal(read[c], whole[c][:rows], equal_nan=True), c
    assert list(read.status) == list(whole.status[:rows])


def _written_late(monkeypatch: pytest.MonkeyPatch, tmp_path, buffers: int | None = None):
    """Solve into Parquet with a writer that writes chunk ``k`` only once the kernel has computed chunk
    ``k + 1``; return the table read back, the whole table and, per chunk but the last, whether that
    happened while chunk ``k`` was being written.  ``buffers``: force the kernel's buffer count."""
    case, whole = _case(monkeypatch)
    computed, ready, overlapped = [0], threading.Condition(), []
    analyze, write = slider_crank_kernel.analyze_chunk, table.ParquetWriter.write
    chunks = slider_crank_kernel.iter_chunks

    def counted(*args, **kwargs):
        out = analyze(*args, **kwargs)
        with ready:
            computed[0] += 1
            ready.notify_all()
        return out

    def late(self, columns, codes) -> None:
        k = len(overlapped)
        if k < CHUNKS - 1:
            with ready:
                overlapped.append(ready.wait_for(lambda: computed[0] >= k + 2, timeout=5.0))
        write(self, columns, codes)

    monkeypatch.setattr(slider_crank_kernel, "analyze_chunk", counted)
    monkeypatch.setattr(table.ParquetWriter, "write", late)
    if buffers is not None:
        monkeypatch.setattr(slider_crank_kernel, "iter_chunks", lambda c, n, **_: chunks(c, n, buffers))
    solve_output.stream_solve(case, tmp_path / "s.parquet")
    return read_parquet(tmp_path / "s.parquet"), whole, overlapped


def test_a_chunk_is_written_while_the_next_is_computed(monkeypatch, tmp_path) -> None:
    read, whole, overlapped = _written_late(monkeypatch, tmp_path)
    assert overlapped == [True] * (CHUNKS - 1)
    _same_rows(read, whole, len(whole))


def test_one_kernel_buffer_would_be_overwritten_while_written(monkeypatch, tmp_path) -> None:
    """The check above fails when the kernel reuses one buffer: the next chunk overwrites the one
    being written."""
    read, whole, overlapped = _written_late(monkeypatch, tmp_path, buffers=1)
    assert overlapped == [True] * (CHUNKS - 1)
    with pytest.raises(AssertionError):
        _same_rows(read, whole, len(whole))


@pytest.mark.parametrize("failing", [1, CHUNKS - 1])
def test_an_error_of_the_writer_is_raised(monkeypatch, tmp_path, failing: int) -> None:
    """A write that fails (chunk ``failing``) stops the solve with its error; the chunks written before
    it are in the file."""
    case, whole = _case(monkeypatch)
    write, calls = table.ParquetWriter.write, []

    def failing_write(self, columns, codes) -> None:
        calls.append(len(codes))
        if len(calls) - 1 == failing:
            raise OSError("No space left on device")
        write(self, columns, codes)

    monkeypatch.setattr(table.ParquetWriter, "write", failing_write)
    with pytest.raises(OSError, match="No space left"):
        solve_output.stream_solve(case, tmp_path / "s.parquet")
    _same_rows(read_parquet(tmp_path / "s.parquet"), whole, failing * CHUNK)


@pytest.mark.parametrize("suffix", ["parquet", "csv"])
def test_an_interrupted_run_leaves_the_finished_chunks(monkeypatch, tmp_path, suffix: str) -> None:
    """Ctrl-C while the kernel computes chunk 2: chunks 0 and 1 (the one on the writer thread too) are in
    a file that reads back."""
    case, whole = _case(monkeypatch)
    analyze, calls = slider_crank_kernel.analyze_chunk, []

    def interrupted(*args, **kwargs):
        calls.append(1)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return analyze(*args, **kwargs)

    monkeypatch.setattr(slider_crank_kernel, "analyze_chunk", interrupted)
    with pytest.raises(KeyboardInterrupt):
        solve_output.stream_solve(case, tmp_path / f"s.{suffix}")
    read = read_parquet if suffix == "parquet" else read_csv
    _same_rows(read(tmp_path / f"s.{suffix}"), whole, 2 * CHUNK)


@pytest.mark.parametrize("suffix", ["parquet", "csv"])
def test_an_old_file_is_replaced_and_a_link_written_through(monkeypatch, tmp_path, suffix: str) -> None:
    """An existing file at the output path, longer than the new one, is replaced (it is removed first:
    ext4 writes a truncated file back when it is closed); a symbolic link is written through, not
    replaced by a file of its own."""
    case, whole = _case(monkeypatch)
    old, target, link = (tmp_path / f"{name}.{suffix}" for name in ("old", "target", "link"))
    for path in (old, target):
        path.write_bytes(b"x" * 1_000_000)
    link.symlink_to(target)
    for path in (old, link):
        solve_output.stream_solve(case, path)
    read = read_parquet if suffix == "parquet" else read_csv
    _same_rows(read(old), whole, len(whole))
    assert link.is_symlink()
    _same_rows(read(target), whole, len(whole))
