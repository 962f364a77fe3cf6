"""The Exudyn judge in the pipeline (issue 33): registered for every kind, run only where a matrix names it
(``OPT_IN``), held to its own Richardson-derived tolerances by each kind's gate; the bundled matrices
``five-engines`` (the RSSR, the RCCC, two loop tables) and ``five-engines-slider-crank`` (the slider crank
and its joint variants; here on a quarter turn, the whole turn in CI's own step) pass, and a fault in the
Exudyn judge's table of any kind fails them."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest

import dualmech
from dualmech.models.linkages import linkage_case, read_linkage
from dualmech.validation.engines import DEFAULT_ENGINES, ENGINES, solves
from dualmech.validation.matrix import load_matrix, parse_matrix
from dualmech.validation.matrix.parse import matrix_path
from dualmech.validation.tolerances import EXUDYN_KINEMATICS, EXUDYN_REACTIONS
from tests.engine_faults import fault_engine
from tests.fuzz_harness import toml_text

pytest.importorskip("exudyn")
pytest.importorskip("pinocchio")
pytest.importorskip("mujoco")


def test_the_exudyn_judge_runs_only_where_a_matrix_names_it() -> None:
    assert "exudyn" in ENGINES and "exudyn" not in DEFAULT_ENGINES
    assert set(ENGINES["exudyn"]) == set(ENGINES["dualmech"])  # every kind
    assert load_matrix("rscr").engines == DEFAULT_ENGINES
    assert "exudyn" in load_matrix("five-engines").engines
    assert "exudyn" not in parse_matrix({"name": "m", "base": "thesis/ideal"}).engines
    named = parse_matrix({"name": "m", "base": "thesis/ideal", "engines": ["dualmech", "exudyn"]})
    assert named.engines == ("dualmech", "exudyn")
    assert "exudyn" in load_matrix("five-engines-slider-crank").engines


def test_the_five_engine_matrix_passes_with_exudyn_at_its_own_tolerances(tmp_path: Path) -> None:
    run = dualmech.validate("five-engines", tmp_path / "run")
    assert str(run.verdict) == "PASS", run.comparison.failures()
    checks = [c for c in run.comparison.checks if c.engine == "exudyn"]
    rows = {"rscr": 36, "rsrc": 36, "rssr-crank-rocker": 180, "rccc-example": 120}  # every row ok
    assert {c.case for c in checks} == set(rows)
    held = {c.tolerance.name: c.tolerance.value for c in checks if c.quantity not in ("status", "engine")}
    assert held == {"EXUDYN_KINEMATICS": EXUDYN_KINEMATICS.value, "EXUDYN_REACTIONS": EXUDYN_REACTIONS.value}
    assert all(c.n_compared == rows[c.case] for c in checks if c.quantity != "engine")


#: The bundled slider crank matrix's line that the test below narrows to a quarter turn.
SLIDER_CRANK_SET = 'set = { "simulation.steps_per_degree" = 32 }'


def test_the_five_engine_slider_crank_matrix_passes_on_a_quarter_turn(tmp_path: Path) -> None:
    """The bundled matrix, its crank angles narrowed to 0-90 degrees: the Exudyn judge takes 10-30 s a case
    over the whole turn.  The whole turn is CI's step ``dualmech validate five-engines-slider-crank``."""
    text = matrix_path("five-engines-slider-crank").read_text()
    assert SLIDER_CRANK_SET in text
    matrix = tmp_path / "five-engines-slider-crank.toml"
    matrix.write_text(text.replace(SLIDER_CRANK_SET, SLIDER_CRANK_SET[:-1] + ', "motion.angles_deg" = '
                                   '{ start = 0.0, stop = 90.0, step = 2.0 } }'))
    run = dualmech.validate(matrix, tmp_path / "run")
    assert str(run.verdict) == "PASS", run.comparison.failures()
    checks = [c for c in run.comparison.checks if c.engine == "exudyn"]
    assert len({c.case for c in checks}) == 6  # three designs in both load modes
    assert {(c.n_compared, c.n_excluded) for c in checks if c.quantity == "S4"} == {(45, 0)}  # 0, 2 .. 88 deg
    held = {c.tolerance.name for c in checks if c.quantity in ("S4", "j1_fx")}
    assert held == {"EXUDYN_KINEMATICS", "EXUDYN_REACTIONS"}


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


@pytest.mark.parametrize("kind, source, column", [("rssr", "rssr", "phi4_deg"), ("rccc", "rccc", "s4")])
def test_a_fault_in_the_exudyn_judge_of_a_linkage_fails_the_run(kind: str, source: str, column: str,
                                                                tmp_path: Path,
                                                                monkeypatch: pytest.MonkeyPatch) -> None:
    """Deliberate fault: the Exudyn judge's RSSR output angle off by 1e-4 deg (1.7e-6 rad), the RCCC's
    output slide by 1e-6 of its length (both over its bar of 2e-8 of their peaks); on a coarse grid."""
    def shifted(table):
        step = 1e-4 if column == "phi4_deg" else 1e-6 * float(abs(table[column][0]) + 1.0)
        return replace(table, columns={**table.columns, column: table.columns[column] + step})

    fault_engine(monkeypatch, "exudyn", shifted, (kind,))
    data = read_linkage(source)
    data["motion"]["angles_deg"] = {"start": 0.0, "stop": 360.0, "step": 30.0}
    case = tmp_path / f"{kind}.toml"
    case.write_text(toml_text(data))
    matrix = tmp_path / "m.toml"
    matrix.write_text(f'name = "m"\nlinkages = ["{case.name}"]\nengines = ["dualmech", "exudyn"]\n')
    run = dualmech.validate(matrix, tmp_path / "run", jobs=1)
    assert str(run.verdict) == "FAIL"
    assert {(c.engine, c.quantity) for c in run.comparison.failures()} == {("exudyn", column)}


def test_a_fault_in_the_exudyn_judge_of_the_slider_crank_fails_the_run(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Deliberate fault: the Exudyn judge's slider load 1e-6 of its value off (a sign-preserving scale)."""
    def scaled(table):
        return replace(table, columns={**table.columns, "slider_load": table["slider_load"] * (1.0 + 1e-6)})

    fault_engine(monkeypatch, "exudyn", scaled, ("slider-crank",))
    matrix = tmp_path / "m.toml"
    matrix.write_text('name = "m"\nbase = "thesis/ideal"\nengines = ["dualmech", "exudyn"]\n'
                      'set = { "motion.angles_deg" = { start = 0.0, stop = 60.0, step = 5.0 } }\n')
    run = dualmech.validate(matrix, tmp_path / "run", jobs=1)
    assert str(run.verdict) == "FAIL"
    assert {(c.engine, c.quantity) for c in run.comparison.failures()} == {("exudyn", "slider_load")}


def test_the_exudyn_judge_drives_the_first_joint_only() -> None:
    data = read_linkage("rsrc")
    data["drive"]["joint"] = 3
    assert not solves("exudyn", "loop", linkage_case(data))
    assert solves("exudyn", "loop", linkage_case("rsrc"))
    with pytest.raises(ValueError, match=r"the Exudyn judge drives the first joint only"):
        dualmech.solve(data, engine="exudyn")
