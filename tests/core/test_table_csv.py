"""CSV output of a result table (``core/table.py``): the same bytes as before, faster, and atomic.

Why (issue 31): ``ResultTable.to_csv(path)`` from Python wrote ``path`` directly: a full disk or an
interrupt left a partial table under the final name and destroyed the old one.  And ``write_csv``
formatted row by row in interpreted Python.
"""

from __future__ import annotations

import csv
import io
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from dualmech.core.table import NUMERIC_COLUMNS, ResultTable, write_csv, write_parquet

from ..validation.test_hostile_writers import OLD, _small_disk
from ..validation.test_validate import ROOT


def _row_by_row(columns: dict[str, np.ndarray], status: np.ndarray) -> str:
    """The writer as it was (the ``csv`` module, ``repr(float(value))`` row by row): the oracle."""
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow([*columns, "status"])
    data = list(columns.values())
    for i in range(status.shape[0]):
        writer.writerow([repr(float(col[i])) for col in data] + [status[i]])
    return buf.getvalue()


def _hostile_table(rng: np.random.Generator, n: int) -> ResultTable:
    """Every kind of double a table can hold, mixed into every column: NaN (also a payload and a negative
    one), infinities, both zeros, subnormals, the extremes, 17-digit values, repeats and integers; and
    status words, one that the ``csv`` module must quote."""
    special = np.array([np.nan, -np.nan, np.inf, -np.inf, 0.0, -0.0, 5e-324, -5e-324,
                        2.2250738585072009e-308, 1.7976931308262e308, -1.7976931308262e308, 0.1, 1 / 3, 1e16,
                        1e-5, 123456789012345680.0, 0.30000000000000004, 1.0, -2.0, 9007199254740993.0])
    payload = np.array([0x7FF8000000000123], dtype=np.int64).view(np.float64)
    columns = {}
    for c in NUMERIC_COLUMNS:
        col = rng.standard_normal(n) * 10.0 ** rng.integers(-320, 300, n)
        picks = rng.random(n) < 0.5
        col[picks] = rng.choice(np.concatenate([special, payload]), picks.sum())
        columns[c] = col
    status = rng.choice(np.array(["ok", "dead_centre", 'odd, "quoted"\nword', ""], dtype=object), n)
    return ResultTable("dualmech", "hostile", columns, status)


@pytest.mark.parametrize("n", [0, 1, 3000])
def test_csv_text_is_byte_identical_to_the_row_by_row_writer(n):
    rng = np.random.default_rng(31)
    table = _hostile_table(rng, n)
    columns = {c: table.columns[c] for c in NUMERIC_COLUMNS}
    assert table.to_csv() == _row_by_row(columns, table.status)
    with np.errstate(over="ignore"):  # beyond float32's range: inf, as intended
        as_float32 = {c: v.astype(np.float32) for c, v in columns.items()}  # any float dtype, as before
    assert write_csv(as_float32, table.status) == _row_by_row(as_float32, table.status)


_WRITE_BIG = textwrap.dedent("""
    import sys
    import numpy as np
    from dualmech.core.table import NUMERIC_COLUMNS, ResultTable, write_parquet
    n = 20_000
    table = ResultTable("dualmech", "big", {c: np.random.default_rng(0).standard_normal(n)
                                           for c in NUMERIC_COLUMNS}, np.array(["ok"] * n, dtype=object))
    table.to_csv(sys.argv[1]) if sys.argv[1].endswith(".csv") else write_parquet(table, sys.argv[1])
""")


@pytest.mark.parametrize("name", ["out.csv", "out.parquet"])
def test_a_table_written_onto_a_full_disk_leaves_the_old_file_and_no_partial(tmp_path, name):
    """A full disk (the child's files may not grow beyond 64 KiB) while ``to_csv(path)`` or
    ``write_parquet`` writes from Python: the old file stays whole, nothing else is left beside it."""
    folder = tmp_path / "out"
    folder.mkdir()
    out = folder / name
    out.write_text(OLD)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    done = subprocess.run([sys.executable, "-c", _WRITE_BIG, str(out)], cwd=ROOT, env=env,
                          capture_output=True, text=True, preexec_fn=_small_disk(65_536), timeout=300)
    assert done.returncode != 0, "the write did not fail: the limit is not applied"
    assert out.read_text() == OLD
    assert [p.name for p in folder.iterdir()] == [name]


def test_to_csv_replaces_the_file_and_returns_its_text(tmp_path):
    columns = _hostile_table(np.random.default_rng(3), 50).columns
    table = ResultTable("dualmech", "t", columns, np.array(["ok", "dead_centre"] * 25, dtype=object))
    out = tmp_path / "t.csv"
    out.write_text(OLD)
    text = table.to_csv(out)
    assert out.read_text() == text and text.startswith(",".join(NUMERIC_COLUMNS) + ",status\n")
    write_parquet(table, tmp_path / "t.parquet")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.csv", "t.parquet"]
