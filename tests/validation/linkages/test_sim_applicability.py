"""The simulated judge drives the input through every angle of a case, so it solves only cases whose loop
closes at all of them; elsewhere it is "not applicable" and the rigid judges still check every row."""

from __future__ import annotations

from pathlib import Path

import pytest

from dualmech.models.linkages import CASES, linkage_case
from dualmech.validation import engines
from dualmech.validation.linkages import matrix
from dualmech.validation.linkages.matrix import load_linkage_matrix
from dualmech.validation.linkages.run import run_linkages

pytest.importorskip("mujoco")


def _partial(tmp_path: Path) -> Path:
    """The bundled RSSR with a longer input crank: the coupler cannot reach at 142..202 deg; every 6 deg (ten
    rows in the gap, 51 outside it: the runs of a third of the bundled rows cost a third)."""
    text = (Path(CASES) / "rssr.toml").read_text()
    assert "input_crank = 0.1 " in text and "step = 2.0 }" in text
    path = tmp_path / "partial.toml"
    path.write_text(text.replace("input_crank = 0.1 ", "input_crank = 0.3 ")
                    .replace("step = 2.0 }", "step = 6.0 }"))
    return path


def test_the_simulation_solves_only_cases_that_close_at_every_angle(tmp_path) -> None:
    assert engines.solves("mujoco-sim", "rssr", linkage_case("rssr"))
    assert engines.solves("mujoco-sim", "rccc", linkage_case("rccc"))
    partial = linkage_case(_partial(tmp_path))
    assert not engines.solves("mujoco-sim", "rssr", partial)
    assert engines.solves("pinocchio", "rssr", partial) and engines.solves("mujoco", "rssr", partial)


def test_a_partly_assembling_case_passes_on_the_rigid_judges(tmp_path, monkeypatch) -> None:
    run = run_linkages(load_linkage_matrix(_partial(tmp_path)))  # a Path, as the Python API allows
    assert run.comparison.verdict == "PASS"
    judged = {c.engine for c in run.comparison.checks if c.n_compared}
    assert {"pinocchio", "mujoco"} <= judged and "mujoco-sim" not in judged
    # the fault this rule prevents: the servo pushes the input into the gap, and the simulation's rows
    # there have no in-house counterpart
    monkeypatch.setattr(matrix, "solves", lambda engine, kind, case: kind in engines.ENGINES[engine])
    assert run_linkages(load_linkage_matrix(str(_partial(tmp_path)))).comparison.verdict == "FAIL"
