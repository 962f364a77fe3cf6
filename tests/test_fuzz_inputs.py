"""Hostile input (issue 11): fuzzed case and matrix files, and the inputs the issue lists.

Property of every input: loading raises a ``ValueError`` whose message is one line
starting with the key it is about, or the input loads and the in-house engine gives
only finite numbers in its ``ok`` rows (and, for a matrix, every name that becomes a
file name is one safe path component).  The fuzz drives the library in-process (a
coarse angle step keeps each solve to milliseconds); a few end-to-end runs of the
command line check exit code 2 and exactly one stderr line.  Hypothesis runs
derandomized (the same inputs on every run) with a stated number of examples.
"""

from __future__ import annotations

import copy
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from dualmech.core.status import Status
from dualmech.models.case import case_from_dict, preset_path
from dualmech.models.slider_crank import solve_case
from dualmech.validation.matrix import check_file_name, matrix_from_dict, parse_matrix

ROOT = Path(__file__).resolve().parents[1]
CASE_FILES = sorted((ROOT / "models" / "cases" / "thesis").glob("*.toml"))
MATRIX_FILES = sorted((ROOT / "validation" / "matrices").glob("*.toml"))
#: Examples per fuzz test (two case tests and one matrix test: 400 + 150 + 150 inputs per run).
CASE_EXAMPLES, LEAF_EXAMPLES, MATRIX_EXAMPLES = 400, 150, 150
#: A message names its key first: a key of the case or matrix format (then '.', '[', ':' or ' '),
#: or an unknown key as written (then the message says "unknown"), or the file.
FORMAT_KEYS = ("name units description geometry motion bodies loads case base base_label engines reference "
               "quantities set labels load_modes sweep tolerances matrix").split()
KEY_FIRST = re.compile(r"^(" + "|".join(FORMAT_KEYS) + r")[.\[: ]")
#: Angles per fuzzed case when solving (the engine's cost is per position).
COARSE_STEP = 30.0

# ----------------------------------------------------------------------------- strategies

HOSTILE_NUMBERS = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0, -0.0, 1e300, -1e300, 1e308, -1e308, 1e160, 5e-324, 1e-300, 1e15, 1e16, 1e-15, 1e-16,
                     1e7, 1.0000001e7, 1e10, 1e6, -1e6, 360.0, 1e-7]),
    st.integers(min_value=-(10**400), max_value=10**400),
    st.integers(min_value=-1000, max_value=1000),
    st.booleans(),
)
HOSTILE_VALUES = st.one_of(
    HOSTILE_NUMBERS,
    st.text(max_size=30),
    st.lists(HOSTILE_NUMBERS, max_size=5),
    st.dictionaries(st.text(max_size=8), HOSTILE_NUMBERS, max_size=3),
    st.just("\x00/../x"),
)


def _paths(node: object, prefix: tuple = ()) -> list[tuple]:
    """Every key path of a parsed TOML table (into tables and arrays)."""
    out = [prefix] if prefix else []
    if isinstance(node, dict):
        for k, v in node.items():
            out += _paths(v, prefix + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            out += _paths(v, prefix + (i,))
    return out


def _mutate(data: dict, draw: st.DrawFn, count: int) -> dict:
    """``count`` edits of ``data``: replace, delete or scale a leaf, add a key, or change a table."""
    data = copy.deepcopy(data)
    for _ in range(count):
        paths = _paths(data)
        path = draw(st.sampled_from(paths)) if paths else ()
        parent: object = data
        for k in path[:-1]:
            parent = parent[k]
        leaf = path[-1] if path else None
        old = parent[leaf] if path else None
        edit = draw(st.sampled_from(["replace", "replace", "scale", "delete", "add", "units"]))
        if edit == "replace" and path:
            parent[leaf] = draw(HOSTILE_VALUES)
        elif edit == "scale" and path and (isinstance(old, float) or type(old) is int and abs(old) < 2**53):
            parent[leaf] = old * draw(st.sampled_from([-1.0, 0.0, 1e-20, 1e-8, 1e8, 1e20, 1e150]))
        elif edit == "delete" and path:
            del parent[leaf]
        elif edit == "add" and isinstance(old, dict):
            old[draw(st.text(min_size=1, max_size=10))] = draw(HOSTILE_VALUES)
        elif edit == "units":
            data["units"] = draw(st.one_of(st.sampled_from(["m-kg-s", "mm-N-s", "SI", "inch-lbf-s "]),
                                           st.text(max_size=12)))
    return data


@st.composite
def mutated_cases(draw: st.DrawFn) -> dict:
    path = draw(st.sampled_from(CASE_FILES))
    return _mutate(tomllib.loads(path.read_text()), draw, draw(st.integers(1, 3)))


@st.composite
def mutated_matrices(draw: st.DrawFn) -> tuple[dict, Path]:
    path = draw(st.sampled_from(MATRIX_FILES))
    data = _mutate(tomllib.loads(path.read_text()), draw, draw(st.integers(1, 3)))
    if draw(st.booleans()):
        data.pop("load_modes", None)
    if draw(st.booleans()) and isinstance(data.get("sweep"), list) and data["sweep"]:
        sweep = data["sweep"][0]
        if isinstance(sweep, dict):
            sweep["expect"] = draw(st.sampled_from(["no_assembly", "no_assembly", "maybe", 1]))
    if draw(st.booleans()):
        data["name"] = draw(st.sampled_from(["/tmp/victim", "../../x", "a/b", "..", ".hidden", "-rf",
                                             "x" * 101, "ok-name", "a\x00b", "tab\tname", "ünï", ""]))
    return data, path


# ----------------------------------------------------------------------------- the property

def _assert_one_line_naming_a_key(err: ValueError) -> None:
    msg = str(err)
    assert msg and "\n" not in msg and len(msg) < 600, repr(msg)
    assert KEY_FIRST.match(msg) or ": unknown" in msg or msg.startswith("/"), f"no key first: {msg!r}"


def _assert_finite_ok_rows(case) -> None:
    if len(case.motion.angles_deg) > 360 / COARSE_STEP:
        case = case.with_values({"motion.angles_deg": {"start": 0.0, "stop": 360.0, "step": COARSE_STEP}})
    with np.errstate(all="ignore"):  # the engine flags such rows; the property is what it calls ok
        table = solve_case(case)
    ok = table.status == Status.OK
    for name, column in table.columns.items():
        bad = ok & ~np.isfinite(np.asarray(column, dtype=float))
        assert not bad.any(), (f"{case.name}: {name} not finite in {int(bad.sum())} ok rows, "
                               f"e.g. at {table['theta1_deg'][bad][:3]} deg")


def _check_case(data: dict) -> None:
    try:
        case = case_from_dict(data)
    except ValueError as err:
        _assert_one_line_naming_a_key(err)
        return
    _assert_finite_ok_rows(case)


@settings(max_examples=CASE_EXAMPLES, derandomize=True, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(mutated_cases())
def test_fuzzed_case_files_load_cleanly_or_fail_in_one_line(data):
    _check_case(data)


@settings(max_examples=LEAF_EXAMPLES, derandomize=True, deadline=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from(CASE_FILES),
       st.sampled_from(["geometry.crank_length", "geometry.rod_length", "geometry.slider_offset",
                        "geometry.slider_twist_deg", "geometry.crank_axial_shift", "motion.crank_rpm",
                        "motion.crank_accel", "motion.axial_amplitude", "motion.axial_cycles",
                        "bodies.crank_radius", "bodies.rod_radius", "bodies.slider_side",
                        "bodies.weight_density", "bodies.gravity_constant", "loads.drive_torque"]),
       st.one_of(HOSTILE_NUMBERS, st.floats(min_value=-1e15, max_value=1e15)))
def test_every_number_of_a_case_at_any_value(path, key, value):
    """One number at a time, over its whole range and beyond: within the range the engine is finite."""
    data = tomllib.loads(path.read_text())
    section, leaf = key.split(".")
    data[section][leaf] = value
    _check_case(data)


@settings(max_examples=MATRIX_EXAMPLES, derandomize=True, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(mutated_matrices())
def test_fuzzed_matrix_files_expand_cleanly_or_fail_in_one_line(data_and_path):
    data, path = data_and_path
    try:
        matrix = parse_matrix(data, source=str(path), matrix_file=path)
    except ValueError as err:
        _assert_one_line_naming_a_key(err)
        return
    for name in (matrix.name, *(c.id for c in matrix.cases), *(s.name for s in matrix.sweeps)):
        assert check_file_name("name", name) == name and Path(name).name == name and name not in (".", "..")
    assert matrix_from_dict(matrix.to_dict()) == matrix
    assert len(matrix.cases) <= 1000
    for mc in matrix.cases[:4]:  # a few cases per matrix keeps the run short; the case fuzz does the rest
        _assert_finite_ok_rows(mc.case())


# ----------------------------------------------------------------------------- the issue's inputs, one by one

def _ideal() -> dict:
    return tomllib.loads(preset_path("ideal").read_text())


def test_the_fuzz_property_catches_a_non_finite_ok_row(monkeypatch):
    """The property is not vacuous: an engine that calls a NaN row ok fails it."""
    real = solve_case

    def broken(case):
        table = real(case)
        table.columns["j2_fx"][0] = np.nan
        table.status[0] = Status.OK
        return table

    monkeypatch.setattr(sys.modules[__name__], "solve_case", broken)
    with pytest.raises(AssertionError, match="j2_fx not finite"):
        _check_case(_ideal())


def _run(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "dualmech.cli", *args], capture_output=True,
                          text=True, cwd=cwd, timeout=60)


def _write_case(tmp_path: Path, edit) -> Path:
    data = _ideal()
    edit(data)
    lines = []
    for section, table in data.items():
        if not isinstance(table, dict):
            lines.insert(0, f"{section} = {_toml(table)}")
            continue
        lines.append(f"[{section}]")
        lines += [f"{k} = {_toml(v)}" for k, v in table.items()]
    path = tmp_path / "case.toml"
    path.write_text("\n".join(lines) + "\n")
    return path


def _toml(v: object) -> str:
    if isinstance(v, bool):
        return str(v).lower()
    if isinstance(v, str):
        return '"' + v + '"'
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {_toml(x)}" for k, x in v.items()) + " }"
    if isinstance(v, list):
        return "[" + ", ".join(_toml(x) for x in v) + "]"
    return str(v)  # TOML writes floats and integers as Python does ("1e+300" is valid TOML)


CASE_EDITS = {
    "1e300 length": (lambda d: d["geometry"].update(crank_length=1e300), "geometry.crank_length"),
    "crank_rpm 1e160": (lambda d: d["motion"].update(crank_rpm=1e160), "motion.crank_rpm"),
    "crank_rpm 1e308": (lambda d: d["motion"].update(crank_rpm=1e308), "motion.crank_rpm"),
    "crank_accel -1e308": (lambda d: d["motion"].update(crank_accel=-1e308), "motion.crank_accel"),
    "huge integer": (lambda d: d["geometry"].update(rod_length=10**400), "geometry.rod_length"),
    "overflowing step": (lambda d: d["motion"].update(angles_deg={"step": 5e-324}), "motion.angles_deg.step"),
    "unknown units": (lambda d: d.update(units="parsec-stone-fortnight"), "units"),
}


@pytest.mark.parametrize("what", sorted(CASE_EDITS))
def test_cli_solve_refuses_the_issues_case_inputs_in_one_line(tmp_path, what):
    edit, key = CASE_EDITS[what]
    proc = _run("solve", str(_write_case(tmp_path, edit)), "-o", str(tmp_path / "out.csv"), cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"dualmech: error: {key}:"), proc.stderr
    assert not (tmp_path / "out.csv").exists()


def test_cli_solve_refuses_deeply_nested_toml(tmp_path):
    path = tmp_path / "deep.toml"
    path.write_text('name = "x"\nunits = ' + "{ a = " * 5000 + "1" + " }" * 5000 + "\n")
    proc = _run("solve", str(path), cwd=tmp_path)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert "nested 5000 deep" in proc.stderr


@pytest.mark.parametrize("option, value, words", [
    ("--torque", "1e400", ["inf"]),            # crashed inside the error handler
    ("--torque", "sqrt(-1)", ["not a real number"]),  # hung
    ("--torque", "9**9**9", ["exponent"]),     # hung
    ("--rtol", "nan", ["--rtol", "nan"]),       # hung
    ("--samples", "1" + "0" * 5000, ["--samples", "100,000"]),
    ("--duration", "abc", ["--duration", "'abc'"]),
])
def test_cli_simulate_refuses_the_issues_options_in_one_line(tmp_path, option, value, words):
    out = str(tmp_path / "o.csv")
    proc = _run("simulate", "ideal", "--duration", "0.01", option, value, "-o", out, cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("dualmech: error: "), proc.stderr
    for w in words:
        assert w in lines[0], (w, lines[0])


MATRIX = """
name = "{name}"
base = "thesis/ideal"
engines = ["dualmech", "pinocchio"]
set = {{ "motion.angles_deg" = {{ start = 0.0, stop = 360.0, step = 90.0 }} }}

[[sweep]]
name = "a4"
grid = {{ "geometry.slider_offset" = [10.0] }}
"""


@pytest.mark.parametrize("name", ["VICTIM", "../../victim", "a/../../victim", "..", "victim\x01"])
def test_a_matrix_name_that_leaves_the_output_folder_is_refused_and_nothing_is_written(tmp_path, name):
    """The matrix name is the default output folder runs/<name>: it wrote to '/tmp/victim' and '../../x'."""
    work = tmp_path / "a" / "b"
    work.mkdir(parents=True)
    victim = tmp_path / "victim"
    path = work / "m.toml"
    path.write_text(MATRIX.format(name=str(victim) if name == "VICTIM" else name.replace("\x01", "\\u0001")))
    proc = _run("validate", str(path), "--jobs", "1", cwd=work)
    assert proc.returncode == 2, proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and "name: " in proc.stderr, proc.stderr
    assert not victim.exists() and sorted(p.name for p in tmp_path.rglob("*")) == ["a", "b", "m.toml"]


def test_a_matrix_without_load_modes_runs_in_the_base_case_mode():
    """The format calls [load_modes] optional; it raised StopIteration."""
    matrix = parse_matrix(tomllib.loads(MATRIX.format(name="no-modes")))
    assert matrix.modes == ("torque",) and [c.id for c in matrix.cases] == ["torque_base", "torque_a4=10"]
    assert all(c.case().loads.drive_torque == 100.0 for c in matrix.cases)


def test_sweep_expect_is_declared_carried_and_checked():
    data = tomllib.loads(MATRIX.format(name="expect"))
    data["sweep"].append({"name": "beyond", "expect": "no_assembly", "include_base": False,
                          "grid": {"geometry.slider_offset": [80.0]}})
    matrix = parse_matrix(data)
    expects = {c.id: c.expect for c in matrix.cases}
    assert expects == {"torque_base": None, "torque_a4=10": None, "torque_a4=80": "no_assembly"}
    assert {c.id: c.expect for c in matrix_from_dict(matrix.to_dict()).cases} == expects
    data["sweep"][1]["expect"] = "no-assembly"
    with pytest.raises(ValueError, match=r"sweep\[1\]\.expect: 'no-assembly' is not an expectation"):
        parse_matrix(data)


def test_a_matrix_is_bounded_before_it_is_expanded():
    data = tomllib.loads(MATRIX.format(name="big"))
    data["sweep"][0]["grid"] = {"geometry.slider_offset": list(range(100)),
                                "geometry.rod_length": [50.0 + k for k in range(100)],
                                "geometry.crank_axial_shift": list(range(100))}
    with pytest.raises(ValueError, match=r"more than 1,000 cases .*1,000,000 points"):
        parse_matrix(data)


def test_an_unknown_key_is_named_with_every_valid_key_sorted():
    """One helper writes every "unknown key" line (models.inputs.check_keys): the key (quoted when odd) and
    the valid keys, sorted; a sweep's and a SPEC's keys go through it."""
    from dualmech.models.inputs import check_keys
    from dualmech.models.tolerance.spec import SpecError, spec_from_dict

    with pytest.raises(ValueError) as err:
        check_keys("bodies.crank", {"mass": 1.0, "colour": "red"}, {"mass", "inertia", "com"})
    assert str(err.value) == "bodies.crank.colour: unknown key (valid: com, inertia, mass)"
    with pytest.raises(SpecError) as err:
        spec_from_dict({"tolerances": {}, "a b": 1})
    assert str(err.value) == "'a b': unknown key (valid top-level keys: description, tolerances)"
    data = tomllib.loads(MATRIX.format(name="keys"))
    data["sweep"][0]["grids"] = {}
    with pytest.raises(ValueError) as err:
        parse_matrix(data)
    assert str(err.value) == ("sweep[0].grids: unknown key "
                              "(valid: cases, expect, fixed, grid, include_base, label, name)")
    check_keys("", {"name": "x"}, ("name",))  # every key valid: no error


def test_report_of_a_crank_at_rest_has_no_balancing_ratio():
    """crank_rpm = 0 (quasi-static, a meaningful case) divided by a zero shaking force in the report."""
    from dualmech.validation.derived import balancing

    data = tomllib.loads(MATRIX.format(name="rest"))
    data["set"]["motion.crank_rpm"] = 0.0
    rows = balancing(parse_matrix(data)).rows
    assert rows and all(r["force_before"] == 0.0 and r["ratio"] is None for r in rows)


# ----------------------------------------------------------------------------- the last line of defence

def _command(exc: BaseException):
    import click

    from dualmech.cli.errors import one_line_errors

    @click.command()
    @click.option("-o", "--output", "outdir", default=None)
    @one_line_errors
    def cmd(outdir):
        raise exc

    return cmd


def test_an_internal_error_is_one_line_exit_70_with_the_traceback_in_the_output_folder(tmp_path):
    res = CliRunner().invoke(_command(KeyError("no such thing\nsecond line")), ["-o", str(tmp_path)])
    assert res.exit_code == 70
    line = res.output.strip()
    assert "\n" not in line and line.startswith("dualmech: internal error: KeyError: 'no such thing")
    log = Path(line.rsplit("traceback in ", 1)[1])
    assert log.parent == tmp_path and "Traceback" in log.read_text() and "KeyError" in log.read_text()


def test_an_internal_error_without_an_output_folder_logs_to_a_temporary_file():
    res = CliRunner().invoke(_command(ZeroDivisionError("float division by zero")), [])
    assert res.exit_code == 70
    log = Path(res.output.strip().rsplit("traceback in ", 1)[1])
    try:
        assert log.is_file() and "ZeroDivisionError" in log.read_text()
    finally:
        log.unlink()


def test_a_bad_input_message_is_cut_to_its_first_line():
    big = ValueError("x: got array([" + ", ".join(["1.0"] * 2000) + "])\n  [more rows]\n")
    res = CliRunner().invoke(_command(big), [])
    assert res.exit_code == 2
    line = res.output.strip()
    assert "\n" not in line and line.startswith("dualmech: error: x: got array([1.0")
    assert line.endswith(" ...")
    assert len(line) < 400


def test_keyboard_interrupt_and_usage_errors_keep_their_handling():
    import click

    res = CliRunner().invoke(_command(KeyboardInterrupt()), [])
    assert res.exit_code == 1 and "Aborted" in res.output  # click's own handling, as before
    res = CliRunner().invoke(_command(click.UsageError("bad usage")), [])
    assert res.exit_code == 2 and "Usage:" in res.output



def test_a_failure_of_the_arithmetic_is_internal_not_bad_input(tmp_path):
    """numpy's LinAlgError subclasses ValueError; it is an engine failure (exit 70), never the user's input
    (2)."""
    import numpy as np

    res = CliRunner().invoke(_command(np.linalg.LinAlgError("SVD did not converge")), ["-o", str(tmp_path)])
    assert res.exit_code == 70
    assert res.output.startswith("dualmech: internal error: LinAlgError: SVD did not converge")
