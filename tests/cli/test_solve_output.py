"""``dualmech solve -o``: Parquet beside CSV, and long in-house cases streamed chunk by chunk."""

from __future__ import annotations

import numpy as np
from click.testing import CliRunner

from dualmech.cli import main
from dualmech.core.table import NUMERIC_COLUMNS, read_csv, read_parquet
from dualmech.models.case import load_case
from dualmech.models.slider_crank import kernel as slider_crank_kernel
from dualmech.validation import solve_output


def _same(a, b) -> None:
    for c in NUMERIC_COLUMNS:
        assert np.array_equal(a[c], b[c], equal_nan=True), c
    assert list(a.status) == list(b.status)


def test_parquet_holds_what_csv_holds(tmp_path) -> None:
    runner = CliRunner()
    for suffix in ("parquet", "csv"):
        res = runner.invoke(main, ["solve", "a4-30-s1-3.5", "-o", str(tmp_path / f"t.{suffix}")])
        assert res.exit_code == 0, res.output
    _same(read_parquet(tmp_path / "t.parquet"), read_csv(tmp_path / "t.csv"))


def test_long_cases_stream_in_chunks_with_the_same_rows(tmp_path, monkeypatch) -> None:
    """Streamed (chunks of 80 positions, rounded up to a warm-start chain: 4 chunks of at most 100 rows in
    three buffers taken in turn) = solved whole, in both formats; so is the summary."""
    monkeypatch.setattr(solve_output, "STREAM_POSITIONS", 100)
    monkeypatch.setattr(slider_crank_kernel, "CHUNK_POSITIONS", 80)
    case = load_case("a4-30-s1-3.5").with_values({"geometry.slider_offset": 40.0})  # some no_assembly rows
    whole = slider_crank_kernel.solve_case(case)
    assert "no_assembly" in set(whole.status) and "ok" in set(whole.status)
    for suffix, read in (("parquet", read_parquet), ("csv", read_csv)):
        calls: list[tuple] = []
        text = solve_output.stream_solve(case, tmp_path / f"s.{suffix}", lambda *a: calls.append(a))
        _same(read(tmp_path / f"s.{suffix}"), whole)
        assert "streamed" in text and whole.meta["messages"][0] in text
        assert " in (max S4 " in text  # the stroke's unit, inches
        assert calls == [(100, 360, ""), (200, 360, ""), (300, 360, ""), (360, 360, "")]  # positions written
    assert (tmp_path / "s.csv").read_text() == whole.to_csv()


def test_unknown_output_format_is_refused() -> None:
    res = CliRunner().invoke(main, ["solve", "ideal", "-o", "table.xlsx"])
    assert res.exit_code == 2 and "unknown output format '.xlsx'" in res.output
