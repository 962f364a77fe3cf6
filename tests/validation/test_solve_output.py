"""``stream_solve``: each chunk is written on a writer thread while the kernel computes the next.

What the pipeline must keep (``tests/cli/test_solve_output.py`` holds the streamed rows and summary
to the case solved whole): a chunk's buffer is not overwritten while it is being written (three
kernel buffers in turn, the kernel one chunk ahead); an error of the writer is raised, not lost; an
interrupted run leaves a readable file of the chunks finished, as the sequential loop did.  No
timing: the overlap is shown by a writer that waits until the kernel has computed the next chunk.
Deliberate faults these tests were seen to catch (each made by hand in a scratch edit, then undone):
the sequential loop (no writer thread: the writer waits for a chunk never computed); the writer's
error only waited for (``wait([pending])`` instead of ``pending.result()``), or the last one not
waited for at all; two buffers with the kernel one chunk ahead; a chunk begun ahead into the buffer
of the chunk yielded.
"""

from __future__ import annotations

import threading

import numpy as np
import pytest

from dualmech.core import table
from dualmech.core.table import NUMERIC_COLUMNS, read_csv, read_parquet
from dualmech.models.case import load_case
from dualmech.models.slider_crank import kernel as slider_crank_kernel
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


def _written_late(monkeypatch: pytest.MonkeyPatch, tmp_path, buffers: tuple[int, int] | None = None):
    """Solve into Parquet with a writer that writes chunk ``k`` only once the kernel has computed chunk
    ``k + 1``; return the table read back, the whole table and, per chunk but the last, whether that
    happened while chunk ``k`` was being written.  ``buffers``: force the kernel's buffer count and how
    many chunks it runs ahead."""
    case, whole = _case(monkeypatch)
    computed, ready, overlapped = [0], threading.Condition(), []
    result, write = slider_crank_kernel.Running.result, table.ParquetWriter.write
    chunks = slider_crank_kernel.iter_chunks

    def counted(self):
        out = result(self)
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

    monkeypatch.setattr(slider_crank_kernel.Running, "result", counted)
    monkeypatch.setattr(table.ParquetWriter, "write", late)
    if buffers is not None:
        monkeypatch.setattr(slider_crank_kernel, "iter_chunks", lambda c, n, **_: chunks(c, n, *buffers))
    solve_output.stream_solve(case, tmp_path / "s.parquet")
    return read_parquet(tmp_path / "s.parquet"), whole, overlapped


def test_a_chunk_is_written_while_the_next_is_computed(monkeypatch, tmp_path) -> None:
    read, whole, overlapped = _written_late(monkeypatch, tmp_path)
    assert overlapped == [True] * (CHUNKS - 1)
    _same_rows(read, whole, len(whole))


@pytest.mark.parametrize("buffers", [(1, 0), (2, 1)], ids=["one buffer", "two buffers, one chunk ahead"])
def test_too_few_kernel_buffers_would_be_overwritten_while_written(monkeypatch, tmp_path, buffers) -> None:
    """The check above fails with one buffer fewer than it needs: with one, the next chunk overwrites
    the one being written; with two and the kernel one chunk ahead, the chunk after next does."""
    read, whole, overlapped = _written_late(monkeypatch, tmp_path, buffers)
    assert overlapped == [True] * (CHUNKS - 1)
    with pytest.raises(AssertionError):
        _same_rows(read, whole, len(whole))


@pytest.mark.parametrize("failing", [1, CHUNKS - 1])
def test_an_error_of_the_writer_is_raised(monkeypatch, tmp_path, failing: int) -> None:
    """A write that fails (chunk ``failing``) stops the solve with its error; the old file stays whole and
    no partial file is left (issue 31: written beside, renamed only when whole)."""
    case, whole = _case(monkeypatch)
    write, calls = table.ParquetWriter.write, []

    def failing_write(self, columns, codes) -> None:
        calls.append(len(codes))
        if len(calls) - 1 == failing:
            raise OSError("No space left on device")
        write(self, columns, codes)

    monkeypatch.setattr(table.ParquetWriter, "write", failing_write)
    (tmp_path / "s.parquet").write_bytes(b"the old file")
    with pytest.raises(OSError, match="No space left"):
        solve_output.stream_solve(case, tmp_path / "s.parquet")
    assert (tmp_path / "s.parquet").read_bytes() == b"the old file"
    assert [p.name for p in tmp_path.iterdir()] == ["s.parquet"]


@pytest.mark.parametrize("suffix", ["parquet", "csv"])
def test_an_interrupted_run_leaves_the_old_file_and_no_partial(monkeypatch, tmp_path, suffix: str) -> None:
    """Ctrl-C while the kernel computes chunk 2 (chunk 1 on the writer thread): the old file stays whole
    and the partial one is removed (issue 31: before, the cut file was left under the final name)."""
    case, whole = _case(monkeypatch)
    result, calls = slider_crank_kernel.Running.result, []

    def interrupted(self):
        calls.append(1)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return result(self)

    monkeypatch.setattr(slider_crank_kernel.Running, "result", interrupted)
    (tmp_path / f"s.{suffix}").write_bytes(b"the old file")
    with pytest.raises(KeyboardInterrupt):
        solve_output.stream_solve(case, tmp_path / f"s.{suffix}")
    assert len(calls) == 3
    assert (tmp_path / f"s.{suffix}").read_bytes() == b"the old file"
    assert [p.name for p in tmp_path.iterdir()] == [f"s.{suffix}"]


@pytest.mark.parametrize("suffix", ["parquet", "csv"])
def test_an_old_file_is_replaced_and_a_link_written_through(monkeypatch, tmp_path, suffix: str) -> None:
    """An existing file at the output path, longer than the new one, is replaced (renamed over: a new
    file beside it, fsynced); a symbolic link is written through, not replaced by a file of its own."""
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
