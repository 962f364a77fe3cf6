"""The gate's failure paths: every way a comparison can be wrong must end in FAIL or INCOMPLETE, never PASS.

Each test names the bullet of the verdicts issue (issue 10, "Why") it holds; the
engines are the stand-ins of ``matrix_fakes`` with their tables edited to show
one fault at a time, so a test fails for exactly one reason.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from dualmech.cli import main
from dualmech.core.status import Status
from dualmech.core.table import ResultTable
from dualmech.validation import provenance
from dualmech.validation.compare import STATUS, Verdict, compare_case, compare_run
from dualmech.validation.compare.baseline import baseline_summary, compare_baseline
from dualmech.validation.compare.conditioning import Conditioning, edge_error
from dualmech.validation.compare.junit import junit_tree
from dualmech.validation.engines import ENGINES
from dualmech.validation.matrix import load_matrix
from dualmech.validation.report import derived, render
from dualmech.validation.run.runner import case_file, load_results, run_matrix
from dualmech.validation.tolerances import ASSEMBLY_LIMIT_CONDITION, CLOSURE_PRECISION
from tests import matrix_fakes
from tests.validation.test_validate import FAKE_REGISTRY, FAKES


def _edited(
    table: ResultTable, rows: np.ndarray | slice, status: str | None = None, **values: float
) -> ResultTable:
    """A copy of ``table`` with ``status`` and column values set on ``rows``."""
    cols = {k: v.copy() for k, v in table.columns.items()}
    words = np.asarray(table.status, dtype=object).copy()
    if status is not None:
        words[rows] = status
    for name, value in values.items():
        cols[name][rows] = value
    return replace(table, columns=cols, status=words)


def _unassembled(table: ResultTable, status: str) -> ResultTable:
    nan = {c: np.nan for c in table.columns if c != "theta1_deg"}
    return _edited(table, slice(None), status, **nan)


def test_all_agreeing_fakes_pass(matrix, results):
    comparison = compare_run(matrix, results)
    assert comparison.verdict is Verdict.PASS, [c.detail for c in comparison.failures()]


def test_reference_assembling_nowhere_fails_with_one_line(matrix, results):
    """Why: a case that assembles at no position showed `stroke nan`, `✓ 0.0e+00` and PASS."""
    cid = matrix.cases[0].id
    for e in results[cid]:
        results[cid][e] = _unassembled(results[cid][e], Status.NO_ASSEMBLY)
    comparison = compare_run(matrix, results)
    assert comparison.verdict is Verdict.FAIL
    ref = [c for c in comparison.for_engine(cid, "dualmech") if c.quantity == STATUS]
    assert ref and not ref[0].passed and "assembles at no crank position" in ref[0].detail
    assert "\n" not in ref[0].detail


@pytest.mark.parametrize("ref_word, judge_word", [
    ("not_converged", "not_converged"),  # a reference failing everywhere judged by a judge failing too
    ("not_converged", "no_assembly"),
    ("not_converged", "branch_jump"),
    ("no_assembly", "branch_jump"),  # "neither assembles" rows were dropped
    ("ok", "no_assembly"),
    ("no_assembly", "ok"),
])
def test_status_disagreement_or_engine_failure_fails(matrix, results, ref_word, judge_word):
    """Why: comparison looked only at whether each engine assembled a row, never at the word."""
    cid = matrix.cases[0].id
    rows = slice(2, 4)
    ref, judge = results[cid]["dualmech"], results[cid]["pinocchio"]
    nan = {c: np.nan for c in ref.columns if c != "theta1_deg"}
    results[cid]["dualmech"] = _edited(ref, rows, ref_word, **(nan if ref_word != "ok" else {}))
    results[cid]["pinocchio"] = _edited(judge, rows, judge_word, **(nan if judge_word != "ok" else {}))
    comparison = compare_run(matrix, results)
    assert comparison.verdict is Verdict.FAIL
    failed = {(c.engine, c.quantity) for c in comparison.failures()}
    assert ("dualmech", STATUS) in failed or ("pinocchio", STATUS) in failed


def test_reference_failing_everywhere_fails_every_check(matrix, results):
    """Why: a reference `not_converged` everywhere against a failing judge passed every check."""
    cid = matrix.cases[0].id
    for e in results[cid]:
        results[cid][e] = _unassembled(results[cid][e], Status.NOT_CONVERGED)
    comparison = compare_run(matrix, results)
    assert comparison.verdict is Verdict.FAIL
    judge_checks = comparison.for_engine(cid, "pinocchio")
    assert not all(c.passed for c in judge_checks)
    numeric = [c for c in judge_checks if c.quantity not in (STATUS,)]
    assert all(not c.passed for c in numeric), "a quantity with zero rows compared passed"


@pytest.mark.parametrize("engine", ["dualmech", "pinocchio"])
@pytest.mark.parametrize("value", [np.nan, np.inf])
def test_non_finite_value_in_an_ok_row_fails(matrix, results, engine, value):
    """Why: rows with NaN/inf values could be marked ok (crank_rpm = 1e308)."""
    cid = matrix.cases[1].id
    results[cid][engine] = _edited(results[cid][engine], slice(5, 6), j2_fx=value)
    comparison = compare_run(matrix, results)
    assert comparison.verdict is Verdict.FAIL
    assert any("non-finite" in c.detail for c in comparison.failures())


def test_dead_centre_flags_may_differ_only_within_the_band(matrix, results):
    """A stated rule, not a loophole: ok against dead_centre passes only where |t| is within the band."""
    mc = next(m for m in matrix.cases if m.mode == "torque")
    ref, judge = results[mc.id]["dualmech"], results[mc.id]["pinocchio"]
    i = int(np.argmin(np.where(ref.status == Status.OK, np.abs(ref["transmission"]), np.inf)))
    band = matrix.tolerance("pinocchio", "dead_centre_band").value
    reactions = {c: np.nan for c in ref.columns if c.startswith("j") or c in ("slider_load", "drive_torque")}
    flagged = _edited(judge, slice(i, i + 1), Status.DEAD_CENTRE, **reactions, transmission=0.4 * band)
    near = _edited(ref, slice(i, i + 1), transmission=0.5 * band)
    far = _edited(ref, slice(i, i + 1), transmission=0.5)
    tols = matrix.tolerances["pinocchio"]
    assert all(c.passed for c in compare_case(mc.id, mc.mode, near, flagged, matrix.quantities, tols)
               if c.quantity == STATUS)
    status = [
        c for c in compare_case(mc.id, mc.mode, far, flagged, matrix.quantities, tols) if c.quantity == STATUS
    ]
    assert not status[0].passed and "reference ok, judge dead_centre" in status[0].detail
    far_judge = _edited(
        flagged, slice(i, i + 1), transmission=0.5
    )  # the judge's own t says it is no dead centre
    status = [c for c in compare_case(mc.id, mc.mode, near, far_judge, matrix.quantities, tols)
              if c.quantity == STATUS]
    assert not status[0].passed


def test_missing_case_or_engine_is_incomplete_never_pass(matrix, results):
    """Why: a case missing from the results was skipped."""
    del results[matrix.cases[-1].id]
    del results[matrix.cases[0].id]["mujoco"]
    comparison = compare_run(matrix, results)
    assert comparison.verdict is Verdict.INCOMPLETE and not comparison.passed
    assert {c.engine for c in comparison.missing} == {"dualmech", "pinocchio", "mujoco"}


def test_a_failure_beside_missing_work_is_fail(matrix, results):
    del results[matrix.cases[-1].id]
    results[matrix.cases[0].id]["mujoco"] = matrix_fakes.solve_case_broken(matrix.cases[0].case())
    assert compare_run(matrix, results).verdict is Verdict.FAIL


def test_crashing_engine_fails_with_its_one_line_error(matrix, results):
    cid = matrix.cases[0].id
    results[cid]["mujoco"] = "RuntimeError: engine exploded on ideal"
    results[cid]["dualmech"] = "ValueError: " + "x" * 1000
    comparison = compare_run(matrix, results)
    assert comparison.verdict is Verdict.FAIL
    details = {c.engine: c.detail for c in comparison.failures() if c.case == cid}
    assert details["mujoco"] == "RuntimeError: engine exploded on ideal"
    assert len(details["dualmech"]) <= 200
    assert "the reference failed" in details["pinocchio"]


def test_nothing_compared_is_not_a_pass(matrix):
    assert compare_run(matrix, {}).verdict is Verdict.INCOMPLETE


# ----------------------------------------------------------------------------- runs, JUnit, resume


def test_interrupted_run_reports_incomplete_and_exits_3(small, tmp_path):
    """Why: a run interrupted after 7 of 18 cases wrote a report that said PASS and "passed": true."""
    matrix = load_matrix(small)
    out = tmp_path / "run"
    run_matrix(matrix, out, jobs=1, registry=FAKE_REGISTRY)
    case_file(out, matrix.cases[-1].id).unlink()  # as if the run had stopped before the last case
    result = CliRunner().invoke(main, ["report", str(out), "--jobs", "1"])
    assert result.exit_code == 3, result.output
    assert result.output.startswith("INCOMPLETE")
    summary = json.loads((out / "summary.json").read_text())
    assert summary["passed"] is False and summary["verdict"] == "INCOMPLETE" and summary["n_missing"] == 3
    assert "**INCOMPLETE**" in (out / "report.md").read_text()


def test_junit_shows_incomplete_work_and_baseline_regressions_as_failures(matrix, results):
    """Why: a regression only the baseline caught exited 1 with 0 failures in the JUnit file."""
    comparison = compare_run(matrix, results)
    summary = baseline_summary(matrix, comparison, results)
    worse = json.loads(json.dumps(summary))
    cid = matrix.cases[0].id
    worse["cases"][cid]["checks"]["mujoco"]["j1_fx"]["max_rel"] = 1e-20  # the run is now "worse" than this
    regressions = compare_baseline(summary, worse)
    assert regressions
    del results[matrix.cases[-1].id]
    comparison = compare_run(matrix, results)
    root = junit_tree(matrix, comparison, regressions=regressions, versions={"pin": "4.1.0"}).getroot()
    kinds = [f.get("type") for f in root.iter("failure")]
    assert "Regression" in kinds and "Incomplete" in kinds and not root.findall(".//skipped")
    assert int(root.find("testsuite").get("failures")) == len(kinds)
    props = {p.get("name"): p.get("value") for p in root.iter("property")}
    assert props["pin"] == "4.1.0" and props["verdict"] == "INCOMPLETE"


def test_resume_recomputes_results_of_other_code(small, tmp_path, monkeypatch):
    """Why: --resume reused results computed by older code, so the gate passed on stale numbers."""
    matrix = load_matrix(small)
    out = tmp_path / "run"
    run_matrix(matrix, out, jobs=1, registry=FAKE_REGISTRY)
    assert run_matrix(matrix, out, jobs=1, resume=True, registry=FAKE_REGISTRY).ran == 0
    stored = json.loads(case_file(out, matrix.cases[0].id).read_text())
    assert stored["engines"]["pinocchio"]["versions"]["pin"] == provenance.version_of("pin")
    monkeypatch.setattr(provenance, "code_fingerprint", lambda: "other-source")
    again = run_matrix(matrix, out, jobs=1, resume=True, registry=FAKE_REGISTRY)
    assert again.ran == len(matrix.cases) * len(matrix.engines) and again.skipped == 0


def test_engine_library_version_is_part_of_the_fingerprint(monkeypatch):
    before = provenance.result_fingerprint({"a": 1}, "pinocchio", "m:f")
    monkeypatch.setattr(provenance, "version_of", lambda name: "0.0-other")
    assert provenance.result_fingerprint({"a": 1}, "pinocchio", "m:f") != before


@pytest.mark.parametrize("engine, library", [("pinocchio", "pin"), ("mujoco", "mujoco"),
                                             ("mujoco-sim", "mujoco"), ("exudyn", "exudyn")])
def test_every_judge_names_its_own_library_in_the_fingerprint(engine: str, library: str) -> None:
    """A stored result is re-run when its judge's library changes version (``--resume``, the baseline's
    provenance): every registered judge's fingerprint names its library.  The Exudyn judge's did not (its
    results named numpy alone)."""
    assert set(provenance.ENGINE_LIBRARIES) == set(ENGINES)
    names = provenance.result_fingerprint({"a": 1}, engine, "m:f")["libraries"]
    assert f"{library} {provenance.version_of(library)}" in names.split(", ")


def test_crashed_engine_keeps_its_traceback_in_the_log(small, tmp_path):
    matrix = load_matrix(small)
    out = tmp_path / "run"
    registry = dict(FAKE_REGISTRY, mujoco=f"{FAKES}:solve_case_raises")
    run_matrix(matrix, out, jobs=1, registry=registry)
    stored = load_results(out, matrix)[matrix.cases[0].id]["mujoco"]
    assert stored.startswith("RuntimeError: engine exploded") and "\n" not in stored
    log = (out / "run.log").read_text()
    assert "Traceback" in log and "solve_case_raises" in log


def test_a_broken_report_section_fails_the_report(small, tmp_path, monkeypatch):
    """Why: the findings section caught every exception and printed "not available"."""
    matrix = load_matrix(small)
    out = tmp_path / "run"
    run_matrix(matrix, out, jobs=1, registry=FAKE_REGISTRY)
    monkeypatch.setattr(derived, "FINDINGS_FUNCTION", f"{FAKES}:solve_case_raises")
    with pytest.raises(render.ReportError, match="report section 'findings' failed: TypeError"):
        render.write_report(out, None, jobs=1)
    assert not Path(out / "summary.json").exists()


NO_ASSEMBLY_MATRIX = """
name = "far-slider"
base = "{base}"
engines = ["dualmech", "pinocchio", "mujoco"]
reference = "dualmech"
set = {{ "motion.angles_deg" = {{ start = 0.0, stop = 360.0, step = 30.0 }} }}

[[sweep]]
name = "far"
{expect}
grid = {{ "geometry.slider_offset" = [0.3] }}
include_base = false
"""


@pytest.mark.parametrize("expect, code", [("", 1), ('expect = "no_assembly"', 0)])
def test_a_geometry_that_cannot_assemble_fails_unless_declared(tmp_path, expect, code):
    """Why: slider offset 0.3 m with a 0.05 m crank and a 0.2 m rod said `stroke nan`, `✓ 0.0e+00`, PASS."""
    base = tmp_path / "design.toml"
    text = (Path(__file__).resolve().parents[3] / "models/cases/thesis/ideal.toml").read_text()
    base.write_text(text.replace('units = "inch-lbf-s"', 'units = "m-N-s"')
                    .replace("crank_length = 12.0", "crank_length = 0.05")
                    .replace("rod_length = 50.0", "rod_length = 0.2"))
    matrix = tmp_path / "far.toml"
    matrix.write_text(NO_ASSEMBLY_MATRIX.format(base=base, expect=expect))
    out = tmp_path / "run"
    result = CliRunner().invoke(main, ["validate", str(matrix), "-o", str(out), "--jobs", "1"])
    assert result.exit_code == code, result.output
    if code:
        assert "assembles at no crank position" in result.output
    else:
        assert "PASS" in result.output


def test_assembly_limit_flags_may_differ_only_near_the_flag(matrix, results):
    """ok against assembly_limit passes only where the closure condition is within the band of the flag."""
    mc = matrix.cases[0]
    ref, judge = results[mc.id]["dualmech"], results[mc.id]["pinocchio"]
    band = matrix.tolerance("pinocchio", "assembly_limit_band").value
    rates = {c: np.nan for c in ref.columns if c not in ("theta1_deg", "S1", "S4", "closure_condition")}
    flagged = _edited(judge, slice(1, 2), Status.ASSEMBLY_LIMIT, **rates,
                      closure_condition=ASSEMBLY_LIMIT_CONDITION.value - 0.5 * band)
    tols = matrix.tolerances["pinocchio"]
    for condition, passes in ((ASSEMBLY_LIMIT_CONDITION.value + 0.5 * band, True),
                              (ASSEMBLY_LIMIT_CONDITION.value + 2.0 * band, False), (0.5, False)):
        edited = _edited(ref, slice(1, 2), closure_condition=condition)
        status = [c for c in compare_case(mc.id, mc.mode, edited, flagged, matrix.quantities, tols)
                  if c.quantity == STATUS]
        assert status[0].passed is passes, (condition, status[0].detail)


@pytest.mark.parametrize("condition", [0.0, 1e-6, 0.5 * ASSEMBLY_LIMIT_CONDITION.value])
def test_the_pose_at_the_assembly_limit_is_held_to_the_edge_law(matrix, results, condition):
    """S4 where the rod is nearly normal to the slider line: the kinematics tolerance plus the edge law's
    ``2 a2 H(c)`` (validation/compare/conditioning.py), no flat band: half of it passes, twice fails."""
    mc = matrix.cases[0]
    case = mc.case()
    ref, judge = results[mc.id]["dualmech"], results[mc.id]["pinocchio"]
    rates = {c: np.nan for c in ref.columns if c not in ("theta1_deg", "S1", "S4", "closure_condition")}
    at_limit = {"closure_condition": condition, **rates}
    ref = _edited(ref, slice(1, 2), Status.ASSEMBLY_LIMIT, **at_limit)
    length = np.nanmax(np.abs(np.r_[ref["S4"], ref["S1"]]))
    tols = matrix.tolerances["pinocchio"]
    conditioning = Conditioning.of(case, ref)
    low = np.sqrt(max(condition**2 - 4.0 * CLOSURE_PRECISION.value, 0.0))
    allowed = tols["S4"].value * length + 2.0 * case.geometry.rod_length * float(edge_error(np.array(low)))
    for shift, passes in ((0.5, True), (2.0, False)):
        moved = _edited(judge, slice(1, 2), Status.ASSEMBLY_LIMIT, **at_limit,
                        S4=ref["S4"][1] + shift * allowed)
        checks = compare_case(mc.id, mc.mode, ref, moved, matrix.quantities, tols, conditioning=conditioning)
        s4 = next(c for c in checks if c.quantity == "S4")
        assert s4.passed is passes, (shift, s4.detail)
    assert allowed < 2e-6 * length  # the law's largest widening at a2 = 50, c = 0: 2 a2 2 sqrt(1e-13)


@pytest.mark.parametrize("t, mode", [(1e-13, "torque"), (5e-9, "force")])
def test_a_judge_that_never_flags_a_dead_centre_fails(matrix, results, t, mode):
    """At an exact dead centre (below every engine's flag), or in force mode, no band excuses an ok."""
    mc = next(m for m in matrix.cases if m.mode == "torque")
    ref, judge = results[mc.id]["dualmech"], results[mc.id]["pinocchio"]
    reactions = {c: np.nan for c in ref.columns if c.startswith("j") or c in ("slider_load", "drive_torque")}
    flagged = _edited(ref, slice(1, 2), Status.DEAD_CENTRE, **reactions, transmission=t)
    unflagged = _edited(judge, slice(1, 2), transmission=t)
    status = [c for c in compare_case(mc.id, mode, flagged, unflagged, matrix.quantities,
                                      matrix.tolerances["pinocchio"]) if c.quantity == STATUS]
    assert not status[0].passed and "reference dead_centre, judge ok" in status[0].detail


def test_the_comparison_keeps_each_judges_worst_r_i_per_row(matrix, results):
    """What the report's difference figures draw: per row, the worst kinematic and the worst reaction r_i
    of a judge (the gate's own).  Deliberate fault in the judge: j2_fy 1e-6 too large where it is not
    zero, so the reaction curve rises off zero on those rows and the kinematic one stays at zero."""
    from dualmech.core.table import REACTION_COLUMNS

    mc = matrix.cases[0]
    judge = results[mc.id]["pinocchio"]
    results[mc.id]["pinocchio"] = replace(judge, columns={**judge.columns,
                                                          "j2_fy": judge["j2_fy"] * (1 + 1e-6)})
    theta, kinematic, reactions = compare_run(matrix, results).row_differences[mc.id]["pinocchio"]
    ref = results[mc.id][matrix.reference]
    np.testing.assert_array_equal(theta, ref["theta1_deg"])
    assert "j2_fy" in matrix.quantities and "j2_fy" in REACTION_COLUMNS
    # the fake judge's own deviation is ~1e-13 (matrix_fakes.solve_case_judge); the fault's is 1e-6 of j2_fy
    noise_ceiling, fault_floor = 1e-12, 1e-8
    assert np.nanmax(kinematic) < noise_ceiling
    assert np.nanmax(reactions) > fault_floor
