"""``core/table.ParquetWriter``: what it writes reads back bit for bit, in the file's agreed encodings.

The writer hands contiguous float64 columns (the kernel's: rows of one ``(31, n)`` array) to pyarrow
as they are and copies any other (strided views, other dtypes) first; both kinds are written here.  The
float columns are written plain (no dictionary), ``status`` dictionary-encoded, snappy, with statistics.
Deliberate faults these tests were seen to catch (each made by hand in a scratch edit, then undone):
pyarrow's default ``use_dictionary=True``; ``close`` without the lock.
"""

from __future__ import annotations

import threading

import numpy as np
import pyarrow.parquet as pq
import pytest

from dualmech.core import table
from dualmech.core.table import NUMERIC_COLUMNS, STATUSES, ParquetWriter, read_parquet, status_codes

#: Row groups of uneven sizes, each from a column-major buffer (contiguous rows, as the kernel gives them)
#: and from a row-major one (strided columns): one row, a smaller group after a larger one.
GROUPS = (8209, 1, 300, 5000)


def _rows(n: int, seed: int) -> np.ndarray:
    """``(n, 31)`` row-major floats with the values a bit-for-bit copy must keep: NaN (two payloads),
    -0.0, infinities, subnormals."""
    rng = np.random.default_rng(seed)
    rows = rng.normal(size=(n, len(NUMERIC_COLUMNS))) * 10.0 ** rng.integers(-300, 300, size=(n, 1))
    special = np.array([np.nan, -0.0, np.inf, -np.inf, 5e-324, np.float64(np.nan) * -1.0])
    pick = rng.random(rows.shape) < 0.05
    rows[pick] = rng.choice(special, size=int(pick.sum()))
    rows[0, 0] = np.frombuffer(np.uint64(0x7FF8_0000_0000_0BAD).tobytes(), dtype=np.float64)[0]
    return rows


def _write_groups(path) -> tuple[np.ndarray, np.ndarray]:
    """Write :data:`GROUPS` as row groups, alternately from the contiguous rows of one ``(31, n)`` buffer
    (as the kernel gives them) and from the strided column views of an ``(n, 31)`` one; return all rows
    ``(N, 31)`` and status words ``(N,)``."""
    rng = np.random.default_rng(1)
    all_rows, all_words = [], []
    with ParquetWriter(path) as writer:
        for k, n in enumerate(GROUPS):
            rows = _rows(n, k)
            words = rng.choice(np.array(STATUSES, dtype=object), size=n)
            columns = rows.T.copy() if k % 2 == 0 else rows.T
            writer.write(dict(zip(NUMERIC_COLUMNS, columns)), status_codes(words))
            all_rows.append(rows.copy())
            all_words.append(words)
    return np.concatenate(all_rows), np.concatenate(all_words)


def _assert_same_bits(read: table.ResultTable, rows: np.ndarray, words: np.ndarray) -> None:
    for i, c in enumerate(NUMERIC_COLUMNS):
        got, expected = read[c].view(np.uint64), np.ascontiguousarray(rows[:, i]).view(np.uint64)
        assert np.array_equal(got, expected), c
    assert list(read.status) == list(words)


def test_rows_read_back_bit_for_bit(tmp_path) -> None:
    rows, words = _write_groups(tmp_path / "t.parquet")
    assert pq.ParquetFile(tmp_path / "t.parquet").metadata.num_row_groups == len(GROUPS)
    _assert_same_bits(read_parquet(tmp_path / "t.parquet"), rows, words)


def test_the_bit_check_sees_one_ulp(tmp_path) -> None:
    """The check above fails when one value of the last row differs by one unit in the last place."""
    rows, words = _write_groups(tmp_path / "t.parquet")
    read = read_parquet(tmp_path / "t.parquet")
    rows[-1, 5] = np.nextafter(rows[-1, 5], np.inf) if np.isfinite(rows[-1, 5]) else 1.0
    with pytest.raises(AssertionError, match=NUMERIC_COLUMNS[5]):
        _assert_same_bits(read, rows, words)


def _encodings(path) -> dict[str, tuple]:
    """Column name -> (encodings, compression, has min/max statistics) of the first row group."""
    group = pq.ParquetFile(path).metadata.row_group(0)
    out = {}
    for i in range(group.num_columns):
        col = group.column(i)
        out[col.path_in_schema] = (set(col.encodings), col.compression, col.statistics.has_min_max)
    return out


def test_floats_are_plain_status_is_a_dictionary(tmp_path) -> None:
    _write_groups(tmp_path / "t.parquet")
    found = _encodings(tmp_path / "t.parquet")
    assert list(found) == list(NUMERIC_COLUMNS) + ["status"]
    dictionary = {c for c, (enc, _, _) in found.items() if enc & {"PLAIN_DICTIONARY", "RLE_DICTIONARY"}}
    assert dictionary == {"status"}
    assert {comp for _, comp, _ in found.values()} == {"SNAPPY"}
    assert all(stats for _, _, stats in found.values())
    # pyarrow's defaults (a dictionary for every column), which the check above refuses
    data = pq.read_table(tmp_path / "t.parquet")
    pq.write_table(data, tmp_path / "default.parquet")
    default = _encodings(tmp_path / "default.parquet")
    assert {c for c, (enc, _, _) in default.items() if "RLE_DICTIONARY" in enc} != {"status"}


def test_a_column_of_the_wrong_length_is_refused(tmp_path) -> None:
    columns = {c: np.zeros(4) for c in NUMERIC_COLUMNS} | {"S4": np.zeros(1)}
    with ParquetWriter(tmp_path / "t.parquet") as writer, pytest.raises(ValueError, match="'S4'.*\\(4,\\)"):
        writer.write(columns, np.zeros(4, dtype=np.int8))


def test_close_waits_for_a_write_in_progress(tmp_path) -> None:
    """A write on another thread (the pipelined solve's writer) finishes before the file is closed."""
    writer = ParquetWriter(tmp_path / "t.parquet")
    entered, release, order = threading.Event(), threading.Event(), []
    inner = writer._writer

    class Slow:
        def write_table(self, data) -> None:
            entered.set()
            release.wait(10.0)
            inner.write_table(data)
            order.append("write")

        def close(self) -> None:
            inner.close()
            order.append("close")

    writer._writer = Slow()
    rows = _rows(10, 0)
    columns = dict(zip(NUMERIC_COLUMNS, rows.T))
    t = threading.Thread(target=writer.write, args=(columns, np.zeros(10, np.int8)))
    t.start()
    assert entered.wait(10.0)
    closer = threading.Thread(target=writer.close)
    closer.start()
    closer.join(0.2)  # a close that does not wait has long finished by now
    release.set()
    t.join()
    closer.join()
    assert order == ["write", "close"]
    _assert_same_bits(read_parquet(tmp_path / "t.parquet"), rows, np.array(["ok"] * 10, dtype=object))


def test_status_codes_are_the_words_places_and_refuse_another_word() -> None:
    words = np.array(["ok", "no_assembly", "ok", STATUSES[-1]], dtype=object)
    assert status_codes(words).tolist() == [STATUSES.index(w) for w in words]
    assert status_codes(np.array(["ok", "ok"])).dtype == np.int8  # numpy's own strings too
    with pytest.raises(ValueError, match="'garbage' is not a status word"):
        status_codes(np.array(["ok", "garbage"], dtype=object))
