"""Hostile input, round 3 (issue 31): a seeded fuzz of every command and of the Python API.

Over 1,000 inputs per run (hypothesis, derandomized: the same inputs on every run), each command run
in this process through click's test runner, in a working folder beside an ``outside`` folder that holds
a victim file, with links into it planted in damaged run folders.  The property of every input:

* the exit code is one of the documented set (0 pass, 1 fail, 2 bad input, 3 incomplete, 4 workers
  lost, 130 interrupted); never 70, an internal error;
* a refusal (exit 2) is exactly one stderr line ``dualmech: error: ...``; no stderr line is Python's
  raw warning or traceback;
* nothing outside the working folder is written, deleted or followed (the outside folder's names,
  sizes and contents are the same after);
* no hang: each input has :data:`SECONDS_PER_INPUT` (``SIGALRM``);
* a solved table (CSV) has no non-finite number in a row marked ``ok``.

The Python API gets the same: a result, or one ``TypeError``/``ValueError`` line.  Costly commands
(validate, report, tolerance) run on a case of 12 positions and small studies.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import dualmech
from dualmech.models.case import preset_path
from tests.fuzz_harness import (
    COARSE_ANGLES,
    SECONDS_PER_INPUT,
    Sandbox,
    assert_ok_rows_finite,
    coarse,
    deadline,
    run,
    toml_text,
    toml_value,
)
from tests.hostile_inputs import HOSTILE_NUMBERS, HOSTILE_VALUES, mutate

#: Inputs per test; the sum is the fuzz's size per run (at least 1,000, issue 31).
SOLVE_EXAMPLES, OPTION_EXAMPLES, SPEC_EXAMPLES, RUNDIR_EXAMPLES, API_EXAMPLES = 560, 120, 120, 80, 200
CASE_FILES = sorted((Path(preset_path("ideal")).parent).glob("*.toml"))
#: A validate of the in-house engine and Pinocchio in this process, on ``case.toml`` of the working folder.
VALIDATE = ("validate", "case.toml", "--engines", "dualmech,pinocchio", "--jobs", "1")


@pytest.fixture(scope="module")
def sandbox(tmp_path_factory) -> Sandbox:
    return Sandbox(tmp_path_factory.mktemp("fuzz"))


# ----------------------------------------------------------------------------- strategies

@st.composite
def case_files(draw: st.DrawFn) -> str:
    """The text of a bundled case file, mutated 0-3 times, as TOML; sometimes damaged as text."""
    data = tomllib.loads(draw(st.sampled_from(CASE_FILES)).read_text())
    data = coarse(mutate(data, draw, draw(st.integers(0, 3))))
    text = toml_text(data)
    damage = draw(st.sampled_from(["none"] * 6 + ["truncate", "duplicate", "nul", "bom"]))
    if damage == "truncate":
        text = text[: draw(st.integers(0, len(text)))]
    elif damage == "duplicate":
        first = text.splitlines()[0] if text.strip() else "name = 'x'"
        text = first + "\n" + text
    elif damage == "nul":
        text = text.replace("=", "=\x00", 1)
    elif damage == "bom":
        text = "\ufeff" + text
    return text


# ----------------------------------------------------------------------------- commands on case files

@settings(max_examples=SOLVE_EXAMPLES, derandomize=True, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                 HealthCheck.function_scoped_fixture])
@given(text=case_files(), command=st.sampled_from(["solve", "solve", "solve-joint", "mjcf", "case-path"]))
def test_fuzzed_case_files_through_solve_mjcf_and_case_path(sandbox, text, command):
    with sandbox.fresh() as work:
        (work / "case.toml").write_text(text, encoding="utf-8", errors="surrogatepass")
        if command == "mjcf":
            run("mjcf", "case.toml", "-o", "model.xml")
        elif command == "case-path":
            run("case-path", "case.toml")
        else:
            extra = ["--frames", "joint"] if command == "solve-joint" else []
            code, _, _ = run("solve", "case.toml", "-o", "table.csv", *extra)
            if code == 0:
                assert_ok_rows_finite(work / "table.csv")


OPTIONS = st.one_of(HOSTILE_NUMBERS.map(str), st.sampled_from(["", "-1", "0", "nan", "inf", "1e999", "abc",
                                                                "../x", "/dev/null", "sqrt(-1)", "9**9**9"]))


@settings(max_examples=OPTION_EXAMPLES, derandomize=True, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(command=st.sampled_from(["simulate", "solve", "tolerance", "validate", "report", "benchmark"]),
       option=st.sampled_from(["--duration", "--torque", "--samples", "--rtol", "--psi0", "--damping", "-n",
                               "--seed", "--jobs", "--engines", "--engine", "--cases", "--repeats", "-o",
                               "--time-limit", "--max-evaluations", "--method", "--judge-samples"]),
       value=OPTIONS, source=st.sampled_from(["ideal", "thesis/ideal", "rssr", "nowhere", "case.toml"]))
def test_fuzzed_options_of_every_command(sandbox, command, option, value, source):
    with sandbox.fresh() as work:
        raw = coarse(tomllib.loads(preset_path("ideal").read_text()))
        (work / "case.toml").write_text(toml_text(raw))
        (work / "spec.toml").write_text('[tolerances]\n"geometry.crank_length" = '
                                        '{ dist = "normal", sd = 0.01 }\n')
        base = {
            "simulate": ["simulate", "case.toml", "--duration", "0.01", "--samples", "5"],
            "solve": ["solve", source, "-o", "t.csv"],
            "tolerance": ["tolerance", "case.toml", "--spec", "spec.toml", "-n", "3", "--method", "linear",
                          "--judge-samples", "0", "-o", "study"],
            "validate": [*VALIDATE, "-o", "run"],
            "report": ["report", "run"],
            "benchmark": ["benchmark", "--cases", "2", "--judge-cases", "0", "--big", "0", "--repeats", "1",
                          "--main-job", "0"],
        }[command]
        run(*base, option, value)


# ----------------------------------------------------------------------------- SPECs

@st.composite
def specs(draw: st.DrawFn) -> str:
    keys = ["geometry.crank_length", "geometry.rod_length", "geometry.slider_offset",
            "geometry.slider_twist_deg", "bodies.rod.mass", "geometry.nope", "motion.crank_rpm", ""]
    lines = []
    if draw(st.booleans()):
        lines.append(f"description = {toml_value(draw(HOSTILE_VALUES))}")
    lines.append("[tolerances]")
    if draw(st.booleans()):  # a valid entry first: the study runs, and what follows is checked with it
        lines.append('"geometry.rod_length" = { dist = "normal", sd = 0.05 }')
    for _ in range(draw(st.integers(0, 3))):
        key = draw(st.sampled_from(keys))
        dist = draw(st.sampled_from(["normal", "uniform", "triangular", "cauchy", 3]))
        fields = {"dist": dist}
        for name in draw(st.lists(st.sampled_from(["sd", "low", "high", "mean", "mode", "x"]), max_size=3)):
            fields[name] = draw(st.one_of(HOSTILE_NUMBERS, st.floats(-1.0, 1.0)))
        lines.append(f"{json.dumps(key)} = {toml_value(fields)}")
    if draw(st.integers(0, 5)) == 0 and len(lines) > 1:
        lines.append(lines[-1])  # the same key twice
    return "\n".join(lines) + "\n"


@settings(max_examples=SPEC_EXAMPLES, derandomize=True, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(spec=specs(), method=st.sampled_from(["linear", "mc"]))
def test_fuzzed_specs_through_the_tolerance_study(sandbox, spec, method):
    with sandbox.fresh() as work:
        raw = coarse(tomllib.loads(preset_path("ideal").read_text()))
        (work / "case.toml").write_text(toml_text(raw))
        (work / "spec.toml").write_text(spec)
        run("tolerance", "case.toml", "--spec", "spec.toml", "-n", "4", "--method", method,
            "--judge-samples", "0", "-o", "study")


# ----------------------------------------------------------------------------- damaged run folders

@pytest.fixture(scope="module")
def run_folder(tmp_path_factory) -> Path:
    """A finished run of a 12-position case with the in-house engine and Pinocchio, and its report."""
    folder = tmp_path_factory.mktemp("base-run")
    raw = coarse(tomllib.loads(preset_path("ideal").read_text()))
    (folder / "case.toml").write_text(toml_text(raw))
    old = Path.cwd()
    os.chdir(folder)
    try:
        code, _, err = run(*VALIDATE, "-o", "run")
    finally:
        os.chdir(old)
    assert code == 0, err
    return folder / "run"


def _damage(folder: Path, outside: Path, draw: st.DrawFn) -> None:
    """One damage to a copied run folder: links out, special files, broken or retyped JSON, escaping paths."""
    inside = folder.resolve()
    files = sorted(p for p in folder.rglob("*")
                   if p.is_file() and not p.is_symlink() and p.resolve().is_relative_to(inside))
    if not files:
        return
    target = draw(st.sampled_from(files))  # a regular file: the damage itself never writes through a link
    kind = draw(st.sampled_from(["link-file", "link-dir", "fifo", "truncate", "garbage", "retype", "escape",
                                 "delete", "lock-link", "figures-link", "empty"]))
    if kind == "link-file":
        target.unlink()
        target.symlink_to(outside / "victim.txt")
    elif kind == "link-dir" and (folder / "cases").is_dir() and not (folder / "cases").is_symlink():
        (folder / "cases").rename(folder / "cases-moved")
        (folder / "cases").symlink_to(outside / "folder", target_is_directory=True)
    elif kind == "fifo":
        target.unlink()
        os.mkfifo(target)
    elif kind == "truncate":
        data = target.read_bytes()
        target.write_bytes(data[: draw(st.integers(0, max(len(data) - 1, 0)))])
    elif kind == "garbage":
        target.write_bytes(draw(st.binary(max_size=64)))
    elif kind == "retype" and target.suffix == ".json":
        try:
            data = json.loads(target.read_text())
        except ValueError:
            return
        if isinstance(data, dict) and data:
            key = draw(st.sampled_from(sorted(data)))
            data[key] = draw(st.one_of(HOSTILE_VALUES, st.just([]), st.just({}), st.none()))
        target.write_text(json.dumps(data, allow_nan=True))
    elif kind == "escape" and (folder / "manifest.json") in files:
        manifest = folder / "manifest.json"
        try:
            data = json.loads(manifest.read_text())
        except ValueError:
            return
        data = data if isinstance(data, dict) else {}
        data["files"] = [*(data.get("files") or []), draw(st.sampled_from(
            ["../../outside/victim.txt", "figures/../../../outside/victim.txt", "/etc/passwd",
             str(outside / "victim.txt"), "figures/../../outside/folder"]))]
        manifest.write_text(json.dumps(data))
    elif kind == "delete":
        target.unlink()
    elif kind == "lock-link":
        (folder / ".dualmech.lock").unlink(missing_ok=True)
        (folder / ".dualmech.lock").symlink_to(outside / "victim.txt")
    elif kind == "figures-link" and (folder / "figures").is_dir() and not (folder / "figures").is_symlink():
        import shutil

        shutil.rmtree(folder / "figures")
        (folder / "figures").symlink_to(outside / "folder", target_is_directory=True)
    elif kind == "empty":
        target.write_bytes(b"")


@settings(max_examples=RUNDIR_EXAMPLES, derandomize=True, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(data=st.data(), command=st.sampled_from(["report", "resume", "report-elsewhere"]))
def test_damaged_run_folders_through_report_and_resume(sandbox, run_folder, data, command):
    import shutil

    with sandbox.fresh() as work:
        folder = work / "run"
        shutil.copytree(run_folder, folder, symlinks=True)
        for _ in range(data.draw(st.integers(1, 2))):
            _damage(folder, sandbox.outside, data.draw)
        if command == "report":
            run("report", "run", "--jobs", "1")
        elif command == "report-elsewhere":
            run("report", "run", "--jobs", "1", "-o", "elsewhere")
        else:
            (work / "case.toml").write_text((run_folder.parent / "case.toml").read_text())
            run(*VALIDATE, "--resume", "-o", "run")


# ----------------------------------------------------------------------------- the Python API

ARGUMENTS = st.one_of(
    HOSTILE_VALUES, st.none(), st.just(object()), st.just(Path("/")), st.just(b"ideal"),
    st.sampled_from(["ideal", "thesis/ideal", "rssr", "x" * 300, "../../outside/victim.txt"]))


def _api_call(draw: st.DrawFn) -> tuple[str, Any]:
    verb = draw(st.sampled_from(["solve", "load_case", "case_from_dict", "Case", "with_values", "simulate",
                                 "validate", "tolerance_study", "to_csv"]))
    a, b = draw(ARGUMENTS), draw(ARGUMENTS)
    case = dualmech.load_case("ideal").with_values({"motion.angles_deg": dict(COARSE_ANGLES)})
    calls = {
        "solve": lambda: dualmech.solve(a, engine=b if isinstance(b, str) else "dualmech"),
        "load_case": lambda: dualmech.load_case(a),
        "case_from_dict": lambda: dualmech.case_from_dict(a),
        "Case": lambda: dualmech.Case(a if isinstance(a, str) else "x", geometry=b),
        "with_values": lambda: case.with_values(a if not isinstance(a, str) else {a: b}),
        "simulate": lambda: dualmech.simulate(case, a, torque=b if not isinstance(b, str) else None),
        "validate": lambda: dualmech.validate(case, "run", engines=a, jobs=b),
        "tolerance_study": lambda: dualmech.tolerance_study(case, a, n=4, method="linear", outdir="study",
                                                            judge_samples=0),
        "to_csv": lambda: dualmech.solve(case).to_csv(a),
    }
    return verb, calls[verb]


@settings(max_examples=API_EXAMPLES, derandomize=True, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_the_python_api_returns_or_refuses_in_one_line(sandbox, data):
    verb, call = _api_call(data.draw)
    with sandbox.fresh(), deadline(SECONDS_PER_INPUT), contextlib.redirect_stderr(io.StringIO()) as err:
        try:
            result = call()
        except (TypeError, ValueError, OSError) as refusal:
            message = str(refusal)
            assert message and "\n" not in message and len(message) < 800, f"{verb}: {message!r}"
            return
    assert "Warning:" not in err.getvalue(), err.getvalue()
    table = getattr(result, "columns", None)  # a ResultTable's dict of columns (a Simulation's is a method)
    if isinstance(table, dict) and getattr(result, "status", None) is not None:
        ok = np.asarray(result.status) == "ok"
        for name, column in table.items():
            finite = np.isfinite(np.asarray(column, float)[ok])
            assert np.all(finite), f"{verb}: {name} not finite in an ok row"


# ----------------------------------------------------------------------------- the property is not vacuous

def test_the_fuzz_property_catches_a_write_outside_and_an_internal_error(sandbox, monkeypatch):
    """A command that writes beside the working folder, or ends in an internal error, fails the property."""
    with pytest.raises(AssertionError, match="outside the working folder"):
        with sandbox.fresh():
            (sandbox.outside / "victim.txt").write_text("overwritten\n")
    (sandbox.outside / "victim.txt").write_text("a user's file\n")
    import sys

    solve_module = sys.modules["dualmech.cli.solve"]  # the package's name `solve` is the command

    def broken(*_: Any, **__: Any) -> None:
        raise RuntimeError("a defect")

    monkeypatch.setattr(solve_module, "load_mechanism", broken)
    with sandbox.fresh(), pytest.raises(AssertionError, match="exit 70"):
        run("solve", "thesis/ideal", "-o", "t.csv")
