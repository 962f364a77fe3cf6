"""The package face (issue 30): ``import dualmech`` gives the documented names; a case is built in code with
the TOML loader's checks; the verbs check their arguments in one line; the table's conversions; the
README's Python blocks run as printed."""

from __future__ import annotations

import dataclasses
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import dualmech
from dualmech.core.status import ASSEMBLED
from dualmech.core.table import COLUMNS, NUMERIC_COLUMNS, ResultTable
from dualmech.models.catalogue import load_mechanism
from dualmech.validation.tolerances import MATRIX_KINEMATICS

ROOT = Path(__file__).resolve().parents[1]
PRESET = "thesis/a4-30-s1-3"
#: One case, the in-house reference judged by Pinocchio (docs/matrix-format.md, "A minimal matrix").
#: A SPEC of one loop-table key (a joint row, as a matrix addresses it).
ONE_KEY_SPEC = {"tolerances": {"joint[2].a": {"dist": "normal", "sd": 5e-4}}}
ONE_CASE_MATRIX = 'name = "one-case"\nbase = "thesis/ideal"\nengines = ["dualmech", "pinocchio"]\n'
#: A small SI design built in code (the README's "Your first design").
SI_TABLES = {
    "units": "m-kg-s",
    "geometry": {"crank_length": 0.05, "rod_length": 0.2, "slider_offset": 0.01, "slider_twist_deg": 270.0,
                 "crank_axial_shift": 0.0},
    "motion": {"crank_rpm": 600.0, "angles_deg": {"start": 0.0, "stop": 360.0, "step": 2.0}},
    "bodies": {"crank_radius": 0.01, "rod_radius": 0.005, "slider_side": 0.02, "density": 7850.0},
    "loads": {"drive_torque": 2.0},
}


def readme_python_blocks() -> list[str]:
    """Every ``python`` block of the README, in order."""
    blocks = re.findall(r"^```python\n(.*?)^```", (ROOT / "README.md").read_text(), re.S | re.M)
    assert blocks, "README.md: no ```python block"
    return blocks


def test_readme_python_runs_as_printed(tmp_path, monkeypatch, capsys) -> None:
    """Every Python block of the README, in one namespace and a fresh folder (their outdirs are relative)."""
    monkeypatch.chdir(tmp_path)
    names: dict = {}
    for block in readme_python_blocks():
        exec(compile(block, "README.md", "exec"), names)
    assert isinstance(names["table"], ResultTable)
    assert names["run"].verdict == "PASS"


def test_version_is_the_installed_distribution() -> None:
    from importlib.metadata import version

    assert dualmech.__version__ == version("dualmech")
    assert re.fullmatch(r"\d+\.\d+\.\d+\S*", dualmech.__version__)


def test_the_face_has_every_documented_name() -> None:
    """``__all__`` of the face is what its docstring lists, each a real object, and an unknown name fails."""
    listed = set(re.findall(r"^(\w[\w, ]*)\n    ", dualmech.__doc__.split("Names\n-----\n")[1], re.M))
    documented = {n.strip() for line in listed for n in line.split(",")}
    assert documented | {"__version__"} == set(dualmech.__all__)
    for name in dualmech.__all__:
        assert getattr(dualmech, name) is not None, name
    assert set(dualmech.__all__) <= set(dir(dualmech))
    with pytest.raises(AttributeError, match="no attribute 'no_such_name'"):
        dualmech.no_such_name  # noqa: B018


def test_a_case_built_in_code_is_the_case_of_the_same_file(tmp_path) -> None:
    """``dualmech.Case(...)`` with a file's tables gives the same case as loading that file."""
    import tomllib

    path = ROOT / "models" / "cases" / "thesis" / "a4-30-s1-3.toml"
    tables = tomllib.loads(path.read_text())
    built = dualmech.Case(**tables)
    loaded = dualmech.load_case(path)
    assert built.name == loaded.name and built.raw == loaded.raw
    assert built.geometry == loaded.geometry and built.joints == loaded.joints
    assert built.bodies.crank.mass == loaded.bodies.crank.mass
    assert dualmech.case_from_dict(tables).raw == loaded.raw
    a, b = dualmech.solve(built), dualmech.solve(loaded)
    assert_array_equal(a["S4"], b["S4"])


def test_a_case_in_code_is_checked_as_a_file_is() -> None:
    tables = {**SI_TABLES, "geometry": {**SI_TABLES["geometry"], "crank_length": -0.05}}
    with pytest.raises(dualmech.CaseError, match=r"^geometry\.crank_length: .*-0\.05") as err:
        dualmech.Case("bad", **tables)
    assert "\n" not in str(err.value)
    with pytest.raises(dualmech.CaseError, match=r"^geometry\.crank_lenght: unknown key"):
        dualmech.Case("typo", **{**SI_TABLES, "geometry": {**SI_TABLES["geometry"], "crank_lenght": 1}})
    with pytest.raises(TypeError, match=r"with_values"):
        dataclasses.replace(dualmech.Case("ok", **SI_TABLES), name="other")


def test_a_sweep_in_python_needs_no_file(tmp_path, monkeypatch) -> None:
    """The face's example: the stroke grows with the offset a4 (docs/findings.md), from four cases in code."""
    monkeypatch.chdir(tmp_path)
    base = dualmech.load_case("thesis/ideal")
    strokes = []
    for a4 in (0.0, 10.0, 20.0, 30.0):
        s4 = dualmech.solve(base.with_values({"geometry.slider_offset": a4}))["S4"]
        strokes.append(np.nanmax(s4) - np.nanmin(s4))
    assert_allclose(strokes[0], 24.0, rtol=1e-12)  # 2 a1: the in-line crank's stroke
    assert np.all(np.diff(strokes) > 0)
    assert list(tmp_path.iterdir()) == []


def test_solve_takes_a_preset_a_file_or_a_table() -> None:
    by_name = dualmech.solve("thesis/ideal")
    by_file = dualmech.solve(ROOT / "models" / "cases" / "thesis" / "ideal.toml")
    by_case = dualmech.solve(dualmech.load_case("thesis/ideal"))
    by_table = dualmech.solve({"name": "si", **SI_TABLES})
    assert_array_equal(by_name["S4"], by_case["S4"])
    assert_array_equal(by_file["S4"], by_case["S4"])
    assert len(by_table) == 180


@pytest.mark.parametrize(("call", "error", "message"), [
    (lambda: dualmech.solve(None), TypeError, r"^case: expected a dualmech\.Case.*got None$"),
    (lambda: dualmech.solve(3.5), TypeError, r"^case: expected .*got 3\.5$"),
    (lambda: dualmech.solve("no-such-preset"), ValueError, r"^case: 'no-such-preset' is neither"),
    (lambda: dualmech.solve("thesis/ideal", engine=3), TypeError, r"^engine: expected an engine name"),
    (lambda: dualmech.solve("thesis/ideal", engine="adams"), ValueError,
     r"^engine: expected one of dualmech, pinocchio, mujoco, mujoco-sim, exudyn, got 'adams'$"),
    (lambda: dualmech.validate("thesis/ideal", engines=["dualmech", "adams"]), ValueError,
     r"^engines: 'adams' is not an engine \(valid: dualmech, pinocchio, mujoco, mujoco-sim, exudyn\)$"),
    (lambda: dualmech.validate("thesis/ideal", engines=[1, 2]), TypeError,
     r"^engines: expected engine names"),
    (lambda: dualmech.validate("thesis/ideal", jobs="2"), TypeError,
     r"^jobs: expected a whole number from 1 to 1024, got '2'$"),
    (lambda: dualmech.validate("thesis/ideal", jobs=0), ValueError,
     r"^jobs: expected a whole number from 1 to 1024"),
    (lambda: dualmech.validate("thesis/ideal", jobs=2**31 - 1), ValueError,
     r"^jobs: expected a whole number from 1 to 1024, got 2147483647$"),
    (lambda: dualmech.validate(42), TypeError, r"^source: expected a matrix or case file"),
    (lambda: dualmech.validate("thesis/ideal", resume="yes"), TypeError, r"^resume: expected True or False"),
    (lambda: dualmech.simulate(42, 1.0), TypeError, r"^case: expected a dualmech\.Case"),
    (lambda: dualmech.simulate("rssr", 1.0, slider_load=5.0), ValueError,
     r"^slider_load: a rssr case has no slider \(valid options: torque, psi0"),
    (lambda: dualmech.tolerance_study("thesis/ideal", 7), TypeError, r"^spec: expected a tolerance SPEC"),
    (lambda: dualmech.tolerance_study(load_mechanism("rssr"), ONE_KEY_SPEC), dualmech.CaseError,
     r"^case: the tolerance study of a rssr case needs its case table"),
    (lambda: dualmech.tolerance_study("rssr", ONE_KEY_SPEC), ValueError,
     r"^tolerances.'joint\[2\].a': not a key that can vary \(valid: geometry.input_crank, "),
    (lambda: dualmech.load_case(None), TypeError, r"^source: expected a case file path or a preset name"),
    (lambda: dualmech.load_case("thesis/ideal").with_values(3), TypeError, r"^updates: expected a dict"),
    (lambda: dualmech.load_case("thesis/ideal").with_values({1: 2}), TypeError, r"^updates: expected a dict"),
])
def test_the_verbs_check_their_arguments_in_one_line(tmp_path, monkeypatch, call, error, message) -> None:
    monkeypatch.chdir(tmp_path)
    with pytest.raises(error, match=message) as err:
        call()
    assert "\n" not in str(err.value)
    assert list(tmp_path.iterdir()) == []  # refused before any folder is made


def test_validate_takes_engines_as_the_command_line_does(tmp_path) -> None:
    """A comma-separated string is the list the command line's ``--engines`` gives."""
    run = dualmech.validate("thesis/ideal", tmp_path / "run", engines="dualmech, pinocchio", jobs=1)
    assert run.matrix.engines == ("dualmech", "pinocchio") and run.verdict == "PASS"


def test_validate_a_case_built_in_code(tmp_path) -> None:
    case = dualmech.Case("si-design", **SI_TABLES)
    run = dualmech.validate(case, tmp_path / "run", engines=["dualmech", "pinocchio"], jobs=1)
    assert run.verdict == "PASS" and run.matrix.name == "si-design"
    assert_array_equal(run.results["torque_design"]["dualmech"]["S4"], dualmech.solve(case)["S4"])


def test_solve_pinocchio_agrees_with_dualmech_on_s4() -> None:
    """Two engines through the public names: S4 within 1e-9 of a2 (MATRIX_KINEMATICS) on every row."""
    case = dualmech.load_case(PRESET)
    own = dualmech.solve(case, engine="dualmech")
    judge = dualmech.solve(case, engine="pinocchio")
    assert (own.engine, judge.engine) == ("dualmech", "pinocchio")  # the engine argument is honoured
    assert len(own) == len(judge) == case.motion.angles_deg.shape[0]
    assert_array_equal(judge.status, own.status)
    rows = np.isin(own.status.astype(str), list(ASSEMBLED))
    assert rows.all()  # this preset assembles everywhere: every row is compared
    a2 = case.geometry.rod_length
    assert_allclose(judge["S4"][rows], own["S4"][rows], rtol=0.0, atol=MATRIX_KINEMATICS.value * a2)


@pytest.mark.parametrize(("tolerances", "verdict"),
                         [("", "PASS"), ("[tolerances]\nkinematics = 0.0\n", "FAIL")])
def test_validate_one_case_matrix(tmp_path, tolerances: str, verdict: str) -> None:
    """The default tolerances pass; a zero kinematics tolerance (Pinocchio differs by round-off) must fail."""
    matrix = tmp_path / "matrix.toml"
    matrix.write_text(ONE_CASE_MATRIX + tolerances)
    run = dualmech.validate(matrix, outdir=tmp_path / "run", jobs=1)
    assert isinstance(run, dualmech.ValidationRun)
    assert run.verdict == verdict
    assert list(run.results) == ["torque_base"]
    assert set(run.results["torque_base"]) == {"dualmech", "pinocchio"}
    assert any(c.engine == "pinocchio" and c.quantity == "S4" for c in run.comparison.checks)
    assert (tmp_path / "run" / "run.json").is_file()


def test_importing_the_face_imports_no_engine() -> None:
    """In a fresh interpreter: ``import dualmech`` loads no judge, plotting or compiler, and solving with the
    in-house engine loads no judge."""
    heavy = ("pinocchio", "mujoco", "matplotlib", "pandas", "polars", "numba")
    code = ("import sys, dualmech\n"
            f"print(' '.join(m for m in {heavy!r} if m in sys.modules))\n"
            "dualmech.solve('thesis/ideal')\n"
            f"print(' '.join(m for m in {heavy[:3]!r} if m in sys.modules))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split("\n")[:2] == ["", ""]


def test_validating_a_slider_crank_loads_no_linkage_machinery(tmp_path: Path) -> None:
    """In a fresh interpreter: validating a slider-crank design imports neither the other kinds' forward
    dynamics nor scipy's splines (~1 s of the main job's start).  Seen failing before the fix: ``open_run``
    and ``run_and_compare`` imported the linkages' run (and with it scipy) for every source."""
    code = ("import sys, dualmech\n"
            f"run = dualmech.validate('thesis/ideal', {str(tmp_path / 'run')!r},"
            " engines='dualmech,pinocchio', jobs=1)\n"
            "assert str(run.verdict) == 'PASS'\n"
            "print(' '.join(m for m in ('dualmech.models.linkages.forward_dynamics', 'scipy.interpolate')"
            " if m in sys.modules))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.splitlines()[-1] == ""


@pytest.fixture(scope="module")
def table() -> ResultTable:
    return dualmech.solve(dualmech.load_case(PRESET), engine="dualmech")


def test_to_numpy_is_a_structured_array_of_every_column(table: ResultTable) -> None:
    arr = table.to_numpy()
    assert arr.shape == (len(table),)
    assert arr.dtype.names == COLUMNS
    for c in NUMERIC_COLUMNS:
        assert arr.dtype[c] == np.float64
        assert_array_equal(arr[c], table[c], err_msg=c)  # NaN rows stay NaN
    assert_array_equal(arr["status"], table.status.astype(str))
    rng = np.random.default_rng(16)
    i = int(rng.integers(len(table)))
    assert arr[i]["S4"] == table["S4"][i] and arr[i]["status"] == table.status[i]


def test_to_pandas(table: ResultTable) -> None:
    df = table.to_pandas()
    assert tuple(df.columns) == COLUMNS and len(df) == len(table)
    assert_array_equal(df["S4"].to_numpy(), table["S4"])
    assert_array_equal(df["status"].to_numpy(dtype=str), table.status.astype(str))


def test_to_polars(table: ResultTable) -> None:
    pytest.importorskip("polars")
    df = table.to_polars()
    assert tuple(df.columns) == COLUMNS and df.height == len(table)
    assert_array_equal(df["S4"].to_numpy(), table["S4"])
    assert df["status"].to_list() == [str(s) for s in table.status]


@pytest.mark.parametrize(("method", "package"), [("to_pandas", "pandas"), ("to_polars", "polars")])
def test_a_missing_dataframe_library_is_named_in_one_line(table: ResultTable, monkeypatch, method: str,
                                                          package: str) -> None:
    monkeypatch.setitem(sys.modules, package, None)  # makes `import package` raise ImportError
    with pytest.raises(ImportError, match=rf"^ResultTable\.{method}: needs {package}, which is not installed "
                                          rf"\(pip install {package}\)$"):
        getattr(table, method)()


def test_validate_of_a_linkage_is_its_kinds_gate(tmp_path, monkeypatch) -> None:
    run = dualmech.validate("rssr", tmp_path / "run", engines=["dualmech", "pinocchio"])
    assert run.verdict == "PASS" and run.write_report().verdict == "PASS"
    assert (tmp_path / "run" / "summary.json").is_file()
    assert set(run.results["rssr-crank-rocker"]) == {"dualmech", "pinocchio"}
    # the same gate fails when the judge's answer is off (a deliberate fault: the output angle 1e-6 deg off)
    from tests.engine_faults import fault_engine

    def shifted(table):
        table.columns["phi4_deg"] += 1e-6
        return table

    fault_engine(monkeypatch, "pinocchio", shifted, ("rssr",))  # in this process: jobs=1
    bad = dualmech.validate("rssr", tmp_path / "bad", engines=["dualmech", "pinocchio"], jobs=1)
    assert bad.verdict == "FAIL"


def test_a_tolerance_study_takes_every_kind(tmp_path) -> None:
    """A loop table by its bundled name, its SPEC naming a joint row: the study runs as the slider crank's
    (it refused every kind but the slider crank), its summary naming the kind and its outputs."""
    study = dualmech.tolerance_study("rscr", ONE_KEY_SPEC, n=4, method="both", outdir=tmp_path / "study",
                                     judge_samples=0)
    assert study.passed and study.summary["kind"] == "loop" and study.summary["yield"]["ok"] == 4
    assert study.x.shape == (4, 1) and list(study.summary["sensitivity"]["range_theta4"]) == ["joint[2].a"]


@pytest.mark.parametrize(("judges", "check", "passed"), [
    ([{"passed": True}], None, True),
    ([{"passed": True}], {"passed": True}, True),
    ([{"passed": True}, {"passed": False}], {"passed": True}, False),
    ([], {"passed": False}, False),
])
def test_a_tolerance_study_passes_as_the_command_exits_0(tmp_path, judges, check, passed) -> None:
    """``ToleranceStudy.passed`` is ``dualmech tolerance``'s exit rule: every spot check agreed and the
    sensitivities agree with central differences (or were not checked)."""
    summary = {"judges": judges, "sensitivity_check": check}
    assert dualmech.ToleranceStudy(tmp_path, summary, None, None, []).passed is passed


@pytest.mark.parametrize(("source", "kind"), [("thesis/ideal", "Simulation"), ("rssr", "LinkageSimulation"),
                                              ("rscr", "LoopSimulation")])
def test_simulate_takes_every_kind(source: str, kind: str) -> None:
    """``dualmech.simulate`` integrates any kind's case by its own forward dynamics (it took a slider crank
    ``Case`` only; a linkage needed ``dualmech.models.linkages.forward_dynamics``): the same numbers as that
    module's ``simulate``, which its own tests hold to energy balance and to the in-house solver."""
    from dualmech.models.kinds import KIND_HOMES, case_from_data, kind_of, resolve
    from dualmech.models.linkages import is_linkage, read_linkage

    sim = dualmech.simulate(source, 0.02, samples=5)
    assert type(sim).__name__ == kind
    case = case_from_data(read_linkage(source)) if is_linkage(source) else dualmech.load_case(source)
    direct = resolve(KIND_HOMES[kind_of(case)].simulator)(case, 0.02, samples=5)
    assert sim.to_csv() == direct.to_csv()
