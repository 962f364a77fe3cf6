"""The public Python API (issue 16): ``dualmech.models.load_case / solve``, ``dualmech.validation.validate``,
the table's conversions, and the README's example, run as printed."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import dualmech.core
import dualmech.models
import dualmech.validation
from dualmech.core.status import ASSEMBLED
from dualmech.core.table import COLUMNS, NUMERIC_COLUMNS, ResultTable
from dualmech.validation.tolerances import MATRIX_KINEMATICS

ROOT = Path(__file__).resolve().parents[1]
PRESET = "thesis/a4-30-s1-3"
#: One case, the in-house reference judged by Pinocchio (docs/matrix-format.md, "A minimal matrix").
ONE_CASE_MATRIX = 'name = "one-case"\nbase = "thesis/ideal"\nengines = ["dualmech", "pinocchio"]\n'


def readme_example() -> str:
    """The ``python`` block of the README's "Python API" section."""
    text = (ROOT / "README.md").read_text()
    found = re.search(r"^## Python API\n.*?^```python\n(.*?)^```", text, re.S | re.M)
    assert found, "README.md: no ```python block under '## Python API'"
    return found.group(1)


def test_readme_example_runs_as_printed(tmp_path, monkeypatch, capsys) -> None:
    monkeypatch.chdir(tmp_path)  # its outdir "runs/api" is relative
    names: dict = {}
    exec(compile(readme_example(), "README.md", "exec"), names)
    assert isinstance(names["table"], ResultTable) and names["table"].engine == "pinocchio"
    assert names["run"].verdict == "PASS"
    assert capsys.readouterr().out.startswith("PASS 360 ")


def test_solve_pinocchio_agrees_with_dualmech_on_s4() -> None:
    """Two engines through the public names: S4 within 1e-9 of a2 (MATRIX_KINEMATICS) on every row."""
    case = dualmech.models.load_case(PRESET)
    own = dualmech.models.solve(case, engine="dualmech")
    judge = dualmech.models.solve(case, engine="pinocchio")
    assert (own.engine, judge.engine) == ("dualmech", "pinocchio")  # the engine argument is honoured
    assert len(own) == len(judge) == case.motion.angles_deg.shape[0]
    assert_array_equal(judge.status, own.status)
    rows = np.isin(own.status.astype(str), list(ASSEMBLED))
    assert rows.all()  # this preset assembles everywhere: every row is compared
    a2 = case.geometry.rod_length
    assert_allclose(judge["S4"][rows], own["S4"][rows], rtol=0.0, atol=MATRIX_KINEMATICS.value * a2)


def test_solve_is_one_function_in_both_packages() -> None:
    assert dualmech.models.solve is dualmech.validation.solve
    with pytest.raises(ValueError, match=r"^engine: expected one of dualmech, pinocchio, mujoco, mujoco-sim, "
                                         r"got 'adams'$"):
        dualmech.models.solve(dualmech.models.load_case(PRESET), engine="adams")


@pytest.mark.parametrize(("tolerances", "verdict"),
                         [("", "PASS"), ("[tolerances]\nkinematics = 0.0\n", "FAIL")])
def test_validate_one_case_matrix(tmp_path, tolerances: str, verdict: str) -> None:
    """The default tolerances pass; a zero kinematics tolerance (Pinocchio differs by round-off) must fail."""
    matrix = tmp_path / "matrix.toml"
    matrix.write_text(ONE_CASE_MATRIX + tolerances)
    run = dualmech.validation.validate(matrix, outdir=tmp_path / "run", jobs=1)
    assert isinstance(run, dualmech.validation.ValidationRun)
    assert run.verdict == verdict
    assert list(run.results) == ["torque_base"]
    assert set(run.results["torque_base"]) == {"dualmech", "pinocchio"}
    assert any(c.engine == "pinocchio" and c.quantity == "S4" for c in run.comparison.checks)
    assert (tmp_path / "run" / "run.json").is_file()


def test_validate_refuses_an_unknown_engine_in_one_line(tmp_path) -> None:
    with pytest.raises(ValueError, match=r"engines") as err:
        dualmech.validation.validate("thesis/ideal", outdir=tmp_path / "run", engines=["dualmech", "adams"])
    assert "\n" not in str(err.value)


def test_importing_the_packages_imports_no_engine() -> None:
    """In a fresh interpreter: ``import dualmech.models`` (and validation, core) load no judge or plotting."""
    heavy = ("pinocchio", "mujoco", "matplotlib", "pandas", "polars")
    code = ("import sys, dualmech.core, dualmech.models, dualmech.validation\n"
            f"print(' '.join(m for m in {heavy!r} if m in sys.modules))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == ""


def test_public_names_are_exported() -> None:
    for package in (dualmech.core, dualmech.models, dualmech.validation):
        assert package.__all__, package.__name__
        for name in package.__all__:
            assert getattr(package, name) is not None, f"{package.__name__}.{name}"
    with pytest.raises(AttributeError):
        dualmech.models.no_such_name  # noqa: B018


@pytest.fixture(scope="module")
def table() -> ResultTable:
    return dualmech.models.solve(dualmech.models.load_case(PRESET), engine="dualmech")


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
    pytest.importorskip("pandas")
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


def test_validate_linkages_is_the_linkage_gate_from_python(tmp_path, monkeypatch) -> None:
    pytest.importorskip("pinocchio")
    run = dualmech.validation.validate_linkages("rssr", tmp_path / "run", engines=["dualmech", "pinocchio"])
    assert run.verdict == "PASS" and (tmp_path / "run" / "summary.json").is_file()
    assert set(run.tables["rssr-crank-rocker"]) == {"dualmech", "pinocchio"}
    # the same gate fails when the judge's answer is off (a deliberate fault: the output angle 1e-6 deg off)
    from dualmech.validation.linkages import engines

    real = engines.solve_case

    def shifted(engine, kind, case):
        table = real(engine, kind, case)
        if engine == "pinocchio":
            table.columns["phi4_deg"] += 1e-6
        return table

    monkeypatch.setattr(engines, "solve_case", shifted)
    monkeypatch.setattr("dualmech.validation.linkages.run.solve_case", shifted)
    assert dualmech.validation.validate_linkages("rssr", tmp_path / "bad", engines=["dualmech", "pinocchio"]
                                                 ).verdict == "FAIL"
