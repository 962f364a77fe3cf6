"""A linkage run's report is the slider crank's (issue 32, "one report"): every value it shows against an
oracle read apart from the report's code -- the peak joint loads and the dead centres against the tables'
own columns (``tables/<case>/<engine>.csv``), the summary's verdicts and the tolerances against the checks
of ``summary.json``, the environment against ``run.json``, the interactive engine-overlay figure against
the tables and the gate's relative differences."""

from __future__ import annotations

import base64
import json
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from numpy.testing import assert_allclose

from dualmech.cli import main
from dualmech.core.thresholds import ROUND_OFF_RELATIVE
from dualmech.models.linkages import linkage_case, table_spec
from dualmech.validation.compare.tables import compared_columns, relative_differences
from dualmech.validation.exit_codes import EXIT_PASS
from dualmech.validation.matrix import load_matrix
from dualmech.validation.matrix.tolerances import group_tolerances
from dualmech.validation.provenance import machine
from dualmech.validation.report.tables import table_specs
from tests.engine_faults import fault_engine
from tests.validation.runs import run_cases, table_figures

pytest.importorskip("pinocchio")

#: float32, the interactive figures' arrays: 2^-24 relative (plotly.js typed arrays, ``"f4"``).
FLOAT32 = 2.0 ** -23
#: Rows of the bundled RSSR (2 deg grid) flagged dead_centre by the deliberate fault below.
FLAGGED = (20, 110)


def _validate(tmp_path: Path, source: str) -> Path:
    out = tmp_path / source
    result = CliRunner().invoke(main, ["validate", source, "-o", str(out), "--engines", "dualmech,pinocchio",
                                       "--jobs", "1"])
    assert result.exit_code == EXIT_PASS, result.output
    return out


def _table(out: Path, case: str, engine: str) -> dict[str, np.ndarray]:
    """The stored CSV of one engine: numeric columns as floats, ``status`` as words."""
    lines = (out / "tables" / case / f"{engine}.csv").read_text().splitlines()
    names = lines[0].split(",")
    rows = [line.split(",") for line in lines[1:]]
    return {n: np.array([r[i] for r in rows], dtype=str if n == "status" else float)
            for i, n in enumerate(names)}


def _escaped(text: str) -> str:
    """``text`` as the report's Markdown writes it (HTML and the markup characters escaped)."""
    text = text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
    return re.sub(r"([\\`*_{}\[\]()#+!|~])", r"\\\1", text)


def _expected_peaks(table: dict[str, np.ndarray], key: str, unit: dict[str, str]) -> list[str]:
    """Every load cell of the peak table, from the columns alone: per joint (``<joint>_f{x,y,z}``,
    ``<joint>_m{x,y,z}``) the magnitude's largest value over the ok rows and where, then each scalar effort;
    a peak at most ``ROUND_OFF_RELATIVE`` of its group's largest is 0 (round-off), a spread that small is
    constant."""
    ok = table["status"] == "ok"
    loads: list[tuple[str, np.ndarray, str]] = []
    joints = dict.fromkeys(m.group(1, 2) for n in table if (m := re.fullmatch(r"(.+)_([fm])[xyz]", n)))
    for joint, kind in joints:
        vector = np.stack([table[f"{joint}_{kind}{a}"] for a in "xyz"])
        loads.append((f"{joint} |{kind}|", np.sqrt((vector ** 2).sum(axis=0)), "force" if kind == "f" else
                      "moment"))
    for name in table:
        if name.endswith("torque") or name.startswith("effort_"):
            loads.append((f"|{name}|", np.abs(table[name]), "force" if name.startswith("effort_s") else
                          "moment"))
    peaks = [(name, np.where(ok, m, -np.inf), group) for name, m, group in loads]
    top = {g: max(m.max() for _, m, mg in peaks if mg == g) for g in ("force", "moment")}
    cells = []
    for _, m, group in peaks:
        i = int(np.argmax(m))
        level = ROUND_OFF_RELATIVE.value * top[group]
        if m[i] <= level:
            where = " ".join(filter(None, ("round-off", f"{m[i]:.1e}", unit[group]))) if m[i] > 0 else \
                "exactly 0"
            parts = ("0", unit[group], where)
        elif m[i] - m[ok].min() <= level:
            parts = (f"{m[i]:.4g}", unit[group], "constant")
        else:
            parts = (f"{m[i]:.4g}", unit[group], f"at {table[key][i]:g}°")
        cells.append(" ".join(part for part in parts if part))  # no unit: none shown, no double space
    return [_escaped(c) for c in cells]


def others(status: np.ndarray) -> str:
    """The peak table's "other positions" cell of a table's ``status`` column: its words other than ``ok`` and
    ``dead_centre``, each with its count, in alphabetical order, or ``none``."""
    words, counts = np.unique(status, return_counts=True)
    return _escaped(", ".join(f"{w} {n}" for w, n in zip(words, counts) if w not in ("ok", "dead_centre"))
                    or "none")


def row(markdown: str, section: str, case: str) -> list[str]:
    """The cells of ``case``'s row in the first table of ``section``."""
    text = markdown.split(f"## {section}\n", 1)[1].split("\n## ", 1)[0]
    line = next(line for line in text.splitlines() if line.startswith(f"| {_escaped(case)} |"))
    return [cell.strip() for cell in re.split(r"(?<!\\)\|", line)[1:-1]]


@pytest.mark.parametrize("source, case, units", [
    ("rssr", "rssr-crank-rocker", {"force": "N", "moment": "N·m"}),
    ("rscr", "rscr", {"force": "", "moment": ""}),  # units = "SI": not a unit system: none shown
])
def test_the_peak_loads_are_the_tables_own(tmp_path, source: str, case: str, units: dict) -> None:
    """The peak-load row of a case is its reference table's columns' peaks (the RSCR's spherical joint 2
    carries no moment: 0, with its round-off), at the input where they occur; the summary row is the
    worst check of each judge in ``summary.json``."""
    out = _validate(tmp_path, source)
    markdown = (out / "report.md").read_text()
    kind = "loop" if source == "rscr" else source
    key = table_spec(kind, linkage_case(source)).key
    table = _table(out, case, "dualmech")
    expected = _expected_peaks(table, key, units)
    if source == "rscr":
        assert "0 round-off" in " ".join(expected)
    assert row(markdown, "Peak joint loads", case) == [case, *expected, "0", others(table["status"])]
    summary = json.loads((out / "summary.json").read_text())
    checks = [c for c in summary["checks"] if c["engine"] == "pinocchio"]
    assert all(c["passed"] for c in checks)
    ratio, quantity = max((c["max_rel"] / c["tolerance"]["value"], c["quantity"]) for c in checks
                          if c["tolerance"]["value"] > 0)  # the status check: exact, and passed
    assert row(markdown, "Summary", case) == [case, kind, "0", f"✓ {ratio:.2g} ({_escaped(quantity)})"]


def test_dead_centres_tolerances_and_environment_are_the_runs(tmp_path,
                                                              monkeypatch: pytest.MonkeyPatch) -> None:
    """Deliberate fault in both engines: two RSSR rows flagged ``dead_centre`` (their reactions blanked):
    the report lists their input values per engine as the tables' status columns have them, counts them in
    the summary and leaves them out of the peaks; the tolerances are those the checks were held to; the
    environment is ``run.json``'s."""
    spec = table_spec("rssr", linkage_case("rssr"))

    def flagged(table):
        status = np.array(table.status, dtype=object)
        status[list(FLAGGED)] = "dead_centre"
        columns = {c: np.where(status == "dead_centre", np.nan, v) if c in spec.reactions else v
                   for c, v in table.columns.items()}
        return replace(table, columns=columns, status=status)

    for engine in ("dualmech", "pinocchio"):
        fault_engine(monkeypatch, engine, flagged, ("rssr",))
    out = _validate(tmp_path, "rssr")
    markdown = (out / "report.md").read_text()
    case = "rssr-crank-rocker"
    listed = []
    for engine in ("dualmech", "pinocchio"):
        table = _table(out, case, engine)
        listed.append(", ".join(f"{a:g}" for a in table["theta1_deg"][table["status"] == "dead_centre"]))
    assert listed[0] == "40, 220"
    assert row(markdown, "Dead centres", case) == [case, *listed]
    assert row(markdown, "Summary", case)[2] == "2"
    reference = _table(out, case, "dualmech")
    assert row(markdown, "Peak joint loads", case) == [
        case, *_expected_peaks(reference, "theta1_deg", {"force": "N", "moment": "N·m"}), "2",
        others(reference["status"])]
    summary = json.loads((out / "summary.json").read_text())
    held = {(c["tolerance"]["name"], c["tolerance"]["value"]) for c in summary["checks"]
            if c["engine"] == "pinocchio" and c["tolerance"]["value"] > 0}
    tolerances = markdown.split("## Tolerances\n", 1)[1].split("\n## ", 1)[0]
    rows = re.findall(r"^\| (\S+) \| (\S+) \|", tolerances, re.M)
    shown = {(name, float(value)) for name, value in rows if name != "name"}
    assert shown == {(_escaped(n), v) for n, v in held} and len(held) == 2
    run = json.loads((out / "run.json").read_text())
    environment = markdown.split("## Environment\n", 1)[1]
    assert f"- run started: {_escaped(run['started'])}" in environment
    assert f"with {run['jobs']} job(s)" in environment
    for engine, target in run["registry"].items():
        assert f"{engine} = {_escaped(target)}" in environment
    assert run["machine"] == machine()  # held to the system's tools in tests/validation/test_provenance.py
    shown = "; ".join(f"{k}: {v}" for k, v in run["machine"].items())
    assert f"- machine: {_escaped(shown)}" in environment


def test_the_overlay_figure_is_every_engines_output_and_ratio(tmp_path) -> None:
    """Each case's figure plots every engine's output column against the input, and each judge's worst
    ratio to tolerance per row: the gate's relative differences over its tolerances, recomputed here; the
    HTML page's interactive figure carries the same arrays (float32)."""
    matrix = load_matrix("rccc").with_engines(("dualmech", "pinocchio"))
    run = run_cases(matrix, jobs=1)
    (spec,) = [s for s in table_figures(run) if s.section == "case"]
    title, x_label, y_label, curves = spec.job[1]
    entry = matrix.cases[0]
    table_of = table_specs(matrix)[entry.id][1]
    assert (spec.key, x_label, y_label) == (f"linkage-{entry.id}", "theta1 (deg)", "theta4_deg")
    reference, judge = run.results[entry.id]["dualmech"], run.results[entry.id]["pinocchio"]
    assert [c[0] for c in curves] == ["dualmech", "pinocchio"] and curves[0][3] is None
    for (_, x, y, _, _), table in zip(curves, (reference, judge)):
        assert_allclose(x, table["theta1_deg"], rtol=0, atol=0)
        assert_allclose(y, table["theta4_deg"], rtol=0, atol=0)
    tolerances = group_tolerances("pinocchio")
    columns = compared_columns(table_of, judge)
    rel = relative_differences(reference, judge, table_of, columns)
    ratio = np.nanmax(np.stack([rel[c] / tolerances["kinematics" if c in table_of.kinematics else
                                                     "reactions"].value for c in columns]), axis=0)
    assert_allclose(curves[1][4], ratio, rtol=1e-12, atol=0)
    out = tmp_path / "run"
    result = CliRunner().invoke(main, ["validate", "rccc", "-o", str(out), "--engines", "dualmech,pinocchio",
                                       "--jobs", "1"])
    assert result.exit_code == EXIT_PASS, result.output
    html = (out / "report.html").read_text()
    data = re.search(rf'<script type="application/json" id="data-{spec.key}">(.*?)</script>', html, re.S)
    figure = json.loads(data.group(1))
    traces = {(t["meta"], t.get("yaxis", "y")): t for t in figure["data"]}

    def decoded(array: dict) -> np.ndarray:
        return np.frombuffer(base64.b64decode(array["bdata"]), dtype="<f4")

    for engine, table in (("dualmech", reference), ("pinocchio", judge)):
        assert_allclose(decoded(traces[engine, "y"]["y"]), table["theta4_deg"], rtol=FLOAT32, atol=0)
    assert_allclose(decoded(traces["pinocchio", "y2"]["y"]), np.clip(ratio, 1e-17, None), rtol=FLOAT32,
                    atol=0)


def test_a_failing_check_is_listed_as_summary_json_has_it(tmp_path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Deliberate fault: Pinocchio's RCCC output angle 1e-6 deg off.  The verdict line, the summary cell
    (✗ and the failing quantity) and the failure list are the failing checks of ``summary.json``."""
    def shifted(table):
        return replace(table, columns={**table.columns, "theta4_deg": table.columns["theta4_deg"] + 1e-6})

    fault_engine(monkeypatch, "pinocchio", shifted, ("rccc",))
    out = tmp_path / "run"
    result = CliRunner().invoke(main, ["validate", "rccc", "-o", str(out), "--engines", "dualmech,pinocchio",
                                       "--jobs", "1"])
    assert result.exit_code == 1, result.output
    summary = json.loads((out / "summary.json").read_text())
    failed = [c for c in summary["checks"] if not c["passed"]]
    assert [c["quantity"] for c in failed] == ["theta4_deg"]
    markdown = (out / "report.md").read_text()
    n = len(summary["checks"])
    assert f"**FAIL**: {n - 1} of {n} checks passed; 1 of 1 cases run;" in markdown
    assert row(markdown, "Summary", "rccc-example") == ["rccc-example", "rccc", "0", "✗ theta4\\_deg"]
    listed = markdown.split("## Failures\n", 1)[1].split("\n## ", 1)[0]
    assert f"- rccc-example / pinocchio: theta4\\_deg: {_escaped(failed[0]['detail'])}" in listed
