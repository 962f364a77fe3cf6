"""One matrix of several kinds (issue 32): a slider crank, an RSSR and a loop table listed together run as one
run, each case compared by its kind's gate (``validation/compare/run.py``), one verdict, one report, one
baseline.  The oracle: each kind's own run, alone, gives exactly the checks the mixed run gives its cases."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

import dualmech
from dualmech.validation.compare.baseline import compare_baseline
from tests.engine_faults import fault_engine

pytest.importorskip("pinocchio")

ENGINES = "dualmech,pinocchio"
#: The listed cases, and the ids they get (their names, file-name safe).
LISTED = {"thesis/a4-30-s1-3": "thesis-a4-30-s1-3", "rssr": "rssr-crank-rocker", "rscr": "rscr"}


def _mixed(tmp_path: Path) -> Path:
    path = tmp_path / "mixed.toml"
    path.write_text('name = "mixed"\ncases = [' + ", ".join(f'"{c}"' for c in LISTED) + "]\n")
    return path


@pytest.fixture(scope="module")
def mixed_run(tmp_path_factory):
    folder = tmp_path_factory.mktemp("mixed")
    run = dualmech.validate(_mixed(folder), folder / "run", engines=ENGINES, jobs=1)
    run.write_report()
    return run


def _checks(run) -> dict[tuple[str, str, str], tuple[float, bool]]:
    return {(c.case, c.engine, c.quantity): (c.max_rel, c.passed) for c in run.comparison.checks}


def test_a_mixed_matrix_is_each_kinds_own_run(mixed_run, tmp_path) -> None:
    """Every check of the mixed run is the one its case gets in a run of that case alone (same worst
    relative difference, same verdict), and nothing else is checked."""
    assert str(mixed_run.verdict) == "PASS"
    assert [c.id for c in mixed_run.matrix.cases] == list(LISTED.values())
    alone = {}
    for source in LISTED:
        run = dualmech.validate(source, tmp_path / source.replace("/", "-"), engines=ENGINES, jobs=1)
        case_id = run.matrix.cases[0].id
        alone |= {(LISTED[source], e, q): v for (c, e, q), v in _checks(run).items() if c == case_id}
    mixed = _checks(mixed_run)
    assert mixed.keys() == alone.keys()
    for key, (max_rel, passed) in mixed.items():
        assert passed == alone[key][1], key
        assert_allclose(max_rel, alone[key][0], rtol=0, atol=0, equal_nan=True, err_msg=str(key))


def test_the_mixed_report_has_each_kinds_sections(mixed_run) -> None:
    out = mixed_run.outdir
    summary = json.loads((out / "summary.json").read_text())
    assert [(c["id"], c["kind"], c["mode"], c["key"]) for c in summary["cases"]] == [
        ("thesis-a4-30-s1-3", "slider-crank", "torque", "theta1_deg"),
        ("rssr-crank-rocker", "rssr", "", "theta1_deg"), ("rscr", "loop", "", "theta1_deg")]
    assert set(summary["strokes"]["thesis-a4-30-s1-3"]) == {"dualmech", "pinocchio"}
    assert summary["strokes"]["rssr-crank-rocker"] == {} == summary["strokes"]["rscr"]
    markdown = (out / "report.md").read_text()
    assert "### slider crank" in markdown and "### rssr: rssr-crank-rocker" in markdown
    assert "### loop: rscr" in markdown and "| case | kind or mode |" in markdown
    figures = {p.name for p in (out / "figures").iterdir()}
    assert {"heatmap-pinocchio.png", "heatmap-tables-pinocchio.png", "linkage-rssr-crank-rocker.png",
            "linkage-rscr.png", "balancing-shaking-force.png"} <= figures
    assert {p.name for p in (out / "tables").iterdir()} == {"rssr-crank-rocker", "rscr"}
    assert (out / "tables" / "rscr" / "pinocchio.csv").stat().st_size > 1000


def test_the_mixed_baseline_holds_each_kinds_reference_values(mixed_run) -> None:
    """The baseline keeps the slider crank's stroke and every other kind's column peaks; a 0.1 % shift of the
    RSSR's output-angle peak in the baseline is a regression of that case only."""
    baseline = mixed_run.baseline()
    references = {c: v["reference"] for c, v in baseline["cases"].items()}
    stroke = mixed_run.comparison.strokes["thesis-a4-30-s1-3"]["dualmech"]
    assert_allclose(references["thesis-a4-30-s1-3"]["stroke"], stroke, rtol=0, atol=0)
    table = mixed_run.results["rssr-crank-rocker"]["dualmech"]
    peak = float(np.max(np.abs(table["phi4_deg"][np.isfinite(table["phi4_deg"])])))
    assert references["rssr-crank-rocker"]["stroke"] is None
    assert_allclose(references["rssr-crank-rocker"]["peaks"]["phi4_deg"], peak, rtol=0, atol=0)
    assert compare_baseline(baseline, baseline) == []
    shifted = json.loads(json.dumps(baseline))
    shifted["cases"]["rssr-crank-rocker"]["reference"]["peaks"]["phi4_deg"] *= 1.001
    regressions = compare_baseline(baseline, shifted)
    assert regressions and {r.case for r in regressions} == {"rssr-crank-rocker"}


@pytest.mark.parametrize("kind, failing", [("rssr", "rssr-crank-rocker"),
                                           ("slider-crank", "thesis-a4-30-s1-3")])
def test_a_fault_in_one_kinds_judge_fails_that_case_only(tmp_path, monkeypatch, kind: str,
                                                         failing: str) -> None:
    """Deliberate fault: Pinocchio's joint-2 x force of one kind's cases 1e-6 of its peak off: the mixed run
    FAILs on that kind's case, the others pass."""
    column = "j2_fx"

    def shifted(table):
        values = table.columns[column]
        return replace(table, columns={**table.columns, column: values + 1e-6 * np.nanmax(np.abs(values))})

    fault_engine(monkeypatch, "pinocchio", shifted, (kind,))
    run = dualmech.validate(_mixed(tmp_path), tmp_path / "run", engines=ENGINES, jobs=1)
    assert str(run.verdict) == "FAIL"
    assert {(c.case, c.quantity) for c in run.comparison.failures()} == {(failing, column)}
