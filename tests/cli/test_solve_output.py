"""``dualmech solve -o``: Parquet beside CSV, and long in-house cases (slider crank, loop table) streamed
chunk by chunk."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from click.testing import CliRunner
from numpy.testing import assert_allclose

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


def test_long_loop_tables_stream_in_chunks_with_the_whole_runs_rows(tmp_path, monkeypatch) -> None:
    """``solve -o`` of a long loop table (here: over 10 positions, chunks of 7) writes the whole run's rows,
    to rounding (``tests/models/loop/test_chunks.py``), in both formats, and prints its summary (the worst
    residual is a rounding-level number of either run)."""
    import pyarrow.parquet as pq

    from dualmech.models.catalogue import load_mechanism
    from dualmech.models.linkages import summary
    from dualmech.models.loop.table import solve_loop_table

    monkeypatch.setattr(solve_output, "STREAM_POSITIONS", 10)
    monkeypatch.setattr(solve_output, "LOOP_CHUNK", 7)
    source = str(Path(__file__).parents[1] / "validation" / "data" / "rrcrc.toml")
    whole = solve_loop_table(load_mechanism(source))
    for suffix in ("parquet", "csv"):
        res = CliRunner().invoke(main, ["solve", source, "-o", str(tmp_path / f"t.{suffix}")])
        assert res.exit_code == 0, res.output
        expected = [line for line in summary(whole).splitlines() if "residual" not in line]
        printed = [line for line in res.output.splitlines() if not line.startswith("solve ")]
        assert [line for line in printed if "residual" not in line] == expected
        assert any(line.startswith("worst closure residual: ") for line in printed)
    parquet = pq.read_table(tmp_path / "t.parquet")
    csv = (tmp_path / "t.csv").read_text().splitlines()
    assert parquet.column_names == [*whole.columns, "status"] and csv[0] == ",".join(parquet.column_names)
    assert len(csv) == len(whole) + 1 and parquet.column("status").to_pylist() == list(whole.status)
    for c, values in whole.columns.items():
        scale = max(float(np.nanmax(np.abs(values), initial=0.0)), 1.0)
        assert_allclose(parquet.column(c).to_numpy(), values, rtol=0, atol=1e-12 * scale, err_msg=c)
