"""The validation matrix, its runner, comparison, JUnit, baseline and report (issue: `dualmech validate`)."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from numpy.testing import assert_array_equal

from dualmech.cli import main
from dualmech.validation import engines
from dualmech.validation.compare import compare_run
from dualmech.validation.compare.baseline import baseline_summary, compare_baseline
from dualmech.validation.matrix import MatrixError, load_matrix, parse_matrix
from dualmech.validation.report.render import write_report
from dualmech.validation.run import runner
from dualmech.validation.run.runner import load_entries, load_results, run_matrix

ROOT = Path(__file__).resolve().parents[2]
FAKES = "tests.matrix_fakes"
FAKE_REGISTRY = {"dualmech": f"{FAKES}:solve_case", "pinocchio": f"{FAKES}:solve_case_judge",
                 "mujoco": f"{FAKES}:solve_case_judge_b"}

def perturbed_inhouse(case):
    """A judge that is the in-house engine with one reaction perturbed by 1e-6 of its value."""
    from dualmech.models.slider_crank.analysis import solve_case

    table = solve_case(case)
    table.columns["j3_fy"] = table.columns["j3_fy"] * (1.0 + 1e-6)
    return table


def _tables_equal(a, b) -> None:
    assert a.keys() == b.keys()
    for case_id in a:
        for engine, ta in a[case_id].items():
            tb = b[case_id][engine]
            assert_array_equal(ta.status, tb.status)
            for name, col in ta.columns.items():
                assert_array_equal(col, tb.columns[name], err_msg=f"{case_id} {engine} {name}")


# ----------------------------------------------------------------------------- the matrix


def test_default_matrix_is_the_thesis_study():
    m = load_matrix()
    assert m.name == "thesis-1991" and m.reference == "dualmech"
    assert m.engines == ("dualmech", "pinocchio", "mujoco", "mujoco-sim")
    assert len(m.cases) == 18 and set(m.modes) == {"torque", "force"}
    values = {tuple(sorted(c.values.items())) for c in m.cases if c.mode == "torque"}
    assert (("geometry.crank_axial_shift", 3.5), ("geometry.slider_offset", 10.0)) in values
    # S1 = 0 as the base
    assert (("geometry.slider_offset", 20.0), ("geometry.slider_twist_deg", 232.0)) in values
    # the issues' tolerances: rigid judges 1e-10 kinematics / 1e-9 reactions, the simulation 1e-5 stroke /
    # 1e-3
    assert m.tolerance("pinocchio", "S4").value == 1e-10 and m.tolerance("mujoco", "j2_fx").value == 1e-9
    assert (
        m.tolerance("mujoco-sim", "stroke").value == 1e-5 and m.tolerance("mujoco-sim", "j2_fx").value == 1e-3
    )
    assert m.tolerance("pinocchio", "j1_mz").reason


@pytest.mark.parametrize("edit, words", [
    (lambda d: d.update(colour="red"), ["colour"]),
    (lambda d: d.update(engines=["dualmech", "ode"]), ["ode"]),
    (lambda d: d["sweep"][0]["grid"].update({"geometry.rod_lenght": [1.0]}), ["rod_lenght"]),
    (lambda d: d.update(tolerances={"j1_fx": "NO_SUCH_TOLERANCE"}), ["NO_SUCH_TOLERANCE"]),
])
def test_bad_matrix_is_one_line(small, edit, words):
    import tomllib

    data = tomllib.loads(small.read_text())
    edit(data)
    with pytest.raises((MatrixError, ValueError)) as err:
        parse_matrix(data)
    msg = str(err.value)
    assert "\n" not in msg
    for w in words:
        assert w in msg, msg


# ----------------------------------------------------------------------------- real engines, end to end


def test_validate_small_matrix_on_real_engines(small, tmp_path):
    out, junit = tmp_path / "run", tmp_path / "junit.xml"
    result = CliRunner().invoke(main, ["validate", str(small), "-o", str(out), "--jobs", "1",
                                       "--engines", "dualmech,pinocchio,mujoco", "--junit", str(junit)])
    assert result.exit_code == 0, result.output
    assert "PASS" in result.output
    assert len(list((out / "cases").glob("*.json"))) == 6  # (ideal + 2) x 2 modes
    assert (out / "report.html").is_file() and (out / "report.md").is_file()
    suite = ET.parse(junit).getroot()
    cases = suite.findall(".//testcase")
    assert len(cases) == 6 * 3 and not suite.findall(".//failure")  # one per case x engine


def test_broken_judge_fails_names_case_and_quantity(small, tmp_path, monkeypatch):
    """A judge with one reaction perturbed by 1e-6: validate exits 1, names it, and JUnit records it."""
    fake = {"slider-crank": "tests.validation.test_validate:perturbed_inhouse"}
    monkeypatch.setitem(engines.ENGINES, "mujoco", fake)
    out, junit = tmp_path / "run", tmp_path / "junit.xml"
    result = CliRunner().invoke(main, ["validate", str(small), "-o", str(out), "--jobs", "1",
                                       "--engines", "dualmech,mujoco", "--junit", str(junit)])
    assert result.exit_code == 1, result.output
    assert "FAIL" in result.output and "j3_fy" in result.output
    failures = ET.parse(junit).getroot().findall(".//testcase[failure]")
    assert failures, "no failing test case in the JUnit file"
    text = " ".join((f.get("name") or "") + " " + (f.find("failure").get("message") or "") for f in failures)
    assert "j3_fy" in text and "a4=10" in text


# ----------------------------------------------------------------------------- runner


def test_interrupted_run_resumes_to_identical_results(small, tmp_path, monkeypatch):
    """Kill a run halfway (SIGKILL, no clean-up), re-run with resume: every stored result is kept and only
    the others run, giving the same results as an uninterrupted run.  All three runs use the same
    registry (a result's fingerprint holds its engine's function: one stored by another is run again),
    the two after the kill without the slow-down."""
    matrix = load_matrix(small)
    slow = dict(FAKE_REGISTRY, dualmech=f"{FAKES}:solve_case_slow")
    killed = tmp_path / "killed"
    script = (
        "import sys; from dualmech.validation.matrix import load_matrix; "
        "from dualmech.validation.run.runner import run_matrix; "
        f"run_matrix(load_matrix({str(small)!r}), {str(killed)!r}, jobs=1, registry={slow!r})"
    )
    env = dict(os.environ, MATRIX_FAKES_DELAY="0.3", PYTHONPATH=str(ROOT))
    proc = subprocess.Popen([sys.executable, "-c", script], cwd=ROOT, env=env)
    deadline = time.time() + 60
    while time.time() < deadline and len(list((killed / "cases").glob("*.json"))) < 2:
        time.sleep(0.05)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    # (case, engine) results stored: the run hands out the longest engine's tasks first, so every case
    # may have a file by now, but not every engine's result
    done = sum(len(per) for per in load_entries(killed, matrix).values())
    assert 2 <= done < len(matrix.cases) * 3, done
    monkeypatch.setenv("MATRIX_FAKES_DELAY", "0")
    outcome = run_matrix(matrix, killed, jobs=1, resume=True, registry=slow)
    assert (outcome.skipped, outcome.ran) == (done, len(matrix.cases) * 3 - done)  # (case, engine) results
    clean = tmp_path / "clean"
    run_matrix(matrix, clean, jobs=1, registry=slow)
    _tables_equal(load_results(killed, matrix), load_results(clean, matrix))


def test_dask_cluster_on_loopback_gives_the_same_results(small, tmp_path):
    distributed = pytest.importorskip("distributed")
    matrix = load_matrix(small)
    run_matrix(matrix, tmp_path / "local", jobs=1, registry=FAKE_REGISTRY)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        # the workers import the fakes by module path
        with distributed.Client(cluster) as client:
            client.run(lambda root: sys.path.insert(0, root) if root not in sys.path else None, str(ROOT))
        run_matrix(matrix, tmp_path / "dask", scheduler=cluster.scheduler_address, registry=FAKE_REGISTRY)
    _tables_equal(load_results(tmp_path / "dask", matrix), load_results(tmp_path / "local", matrix))


def test_baseline_catches_a_regression(small, tmp_path):
    matrix = load_matrix(small)
    run_matrix(matrix, tmp_path / "a", jobs=1, registry=FAKE_REGISTRY)
    results = load_results(tmp_path / "a", matrix)
    summary = baseline_summary(matrix, compare_run(matrix, results), results)
    assert compare_baseline(summary, json.loads(json.dumps(summary))) == []
    # the same judge now agrees only to 1e-11 instead of 1e-13: still within tolerance, but a regression
    worse = dict(FAKE_REGISTRY, pinocchio=f"{FAKES}:solve_case_judge_b")
    run_matrix(matrix, tmp_path / "b", jobs=1, registry=worse)
    results_b = load_results(tmp_path / "b", matrix)
    comparison_b = compare_run(matrix, results_b)
    assert comparison_b.passed
    regressions = compare_baseline(baseline_summary(matrix, comparison_b, results_b), summary)
    assert regressions and any("pinocchio" in str(r) for r in regressions)


# ----------------------------------------------------------------------------- report


def chromium() -> str:
    """Debian's chromium for the report's browser tests: required in CI (.ci/run installs it), else a skip."""
    browser = shutil.which("chromium") or shutil.which("chromium-browser")
    if browser is None:
        if os.environ.get("CI"):
            pytest.fail("chromium is required in CI (.ci/run installs Debian's chromium)")
        pytest.skip("chromium not installed (apt-get install chromium)")
    return browser


def test_user_text_is_escaped_in_the_report(small, tmp_path):
    matrix = load_matrix(small)
    out = tmp_path / "run"
    run_matrix(matrix, out, jobs=1, registry=FAKE_REGISTRY)
    files = write_report(out, None, jobs=1)
    html = Path(files.html).read_text()
    assert "<b>coarse</b>" not in html and "&lt;b&gt;coarse&lt;/b&gt;" in html
    assert "<b>coarse</b>" not in Path(files.markdown).read_text()
    assert np.isfinite(files.seconds)


def test_the_results_in_memory_are_those_stored(tmp_path):
    """The report draws from the run's results in memory (``write_report(results=...)``), so they must be
    what ``load_results`` reads back from the run's files: the same engines in the matrix's order, the same
    meta and the same bits in every column (NaN where NaN)."""
    from dualmech.verbs import validate

    run = validate("thesis/a4-30-s1-3.5", tmp_path / "run", engines=("dualmech", "mujoco"), jobs=2)
    matrix, _ = runner.load_run(run.outdir)
    stored = runner.load_results(run.outdir, matrix)
    assert list(stored) == list(run.results)
    for cid, per in stored.items():
        assert list(per) == list(run.results[cid]) == list(matrix.engines)
        for engine, table in per.items():
            kept = run.results[cid][engine]
            assert table.meta == kept.meta and list(table.columns) == list(kept.columns)
            assert_array_equal(table.status, kept.status)
            for name, column in table.columns.items():
                assert_array_equal(column, kept.columns[name], err_msg=f"{cid} {engine} {name}")
