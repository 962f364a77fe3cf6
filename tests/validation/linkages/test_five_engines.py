"""The Exudyn judge in the pipeline (issue 33): registered for loop tables, run only where a matrix names it
(``OPT_IN``), held to its own Richardson-derived tolerances by the linkages' gate; the bundled matrix
``five-engines`` passes, and a fault in the Exudyn judge's table fails it."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest

import dualmech
from dualmech.models.linkages import linkage_case, read_linkage
from dualmech.validation.engines import DEFAULT_ENGINES, ENGINES, solves
from dualmech.validation.linkages.matrix import load_linkage_matrix
from dualmech.validation.matrix import MatrixError, parse_matrix
from dualmech.validation.tolerances import EXUDYN_KINEMATICS, EXUDYN_REACTIONS
from tests.validation.engine_faults import fault_engine

pytest.importorskip("exudyn")
pytest.importorskip("pinocchio")
pytest.importorskip("mujoco")


def test_the_exudyn_judge_runs_only_where_a_matrix_names_it() -> None:
    assert "exudyn" in ENGINES and "exudyn" not in DEFAULT_ENGINES
    assert load_linkage_matrix("rscr").engines == DEFAULT_ENGINES
    assert "exudyn" in load_linkage_matrix("five-engines").engines
    refused = r"^engines: 'exudyn' does not solve a slider crank \(valid: dualmech, pinocchio, mujoco, "
    with pytest.raises(MatrixError, match=refused + "mujoco-sim; it judges loop tables"):
        parse_matrix({"name": "m", "base": "thesis/ideal", "engines": ["dualmech", "exudyn"]})


def test_the_five_engine_matrix_passes_with_exudyn_at_its_own_tolerances(tmp_path: Path) -> None:
    run = dualmech.validate("five-engines", tmp_path / "run")
    assert str(run.verdict) == "PASS", run.comparison.failures()
    checks = [c for c in run.comparison.checks if c.engine == "exudyn"]
    assert {c.case for c in checks} == {"rscr", "rsrc"}
    held = {c.tolerance.name: c.tolerance.value for c in checks if c.quantity not in ("status", "engine")}
    assert held == {"EXUDYN_KINEMATICS": EXUDYN_KINEMATICS.value, "EXUDYN_REACTIONS": EXUDYN_REACTIONS.value}
    assert all(c.n_compared == 36 for c in checks if c.quantity != "engine")


def test_a_fault_in_the_exudyn_judge_fails_the_run(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Deliberate fault: the Exudyn judge's ``theta4`` off by 1e-6 rad (1.6e-7 of a turn, over 8x its bar
    relative to the angles' peak, at most 2 pi)."""
    def shifted(table):
        return replace(table, columns={**table.columns, "theta4": table.columns["theta4"] + 1e-6})

    fault_engine(monkeypatch, "exudyn", shifted, ("loop",))
    matrix = tmp_path / "m.toml"
    matrix.write_text('name = "m"\nlinkages = ["rscr"]\nengines = ["dualmech", "exudyn"]\n')
    run = dualmech.validate(matrix, tmp_path / "run", jobs=1)
    assert str(run.verdict) == "FAIL"
    assert [(c.engine, c.quantity) for c in run.comparison.failures()] == [("exudyn", "theta4")]


def test_the_exudyn_judge_drives_the_first_joint_only() -> None:
    data = read_linkage("rsrc")
    data["drive"]["joint"] = 3
    assert not solves("exudyn", "loop", linkage_case(data))
    assert solves("exudyn", "loop", linkage_case("rsrc"))
    with pytest.raises(ValueError, match=r"the Exudyn judge drives the first joint only"):
        dualmech.solve(data, engine="exudyn")
