"""The command line on a loop table (``[mechanism] kind = "loop"``): ``cases`` and ``case-path`` list the
bundled ones, ``solve`` writes every engine's table, ``validate`` runs every engine that solves it and
passes, and fails when one engine's table is wrong (a sign flipped: the gate's proof); the simulated judge
of a table driven at its last joint refuses in one line (``simulate``: tests/cli/test_simulate_loop.py)."""

from __future__ import annotations

import csv
import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from dualmech.cli import main
from dualmech.models.linkages import linkage_case, table_spec
from dualmech.models.loop.table import solve_loop_table
from dualmech.validation.exit_codes import EXIT_BAD_INPUT
from tests.engine_faults import fault_engine

#: The bundled loop tables and their files' folder.
LOOPS = ("rscr", "rsrc", "7r")


def _copy(name: str, tmp_path: Path) -> Path:
    """The bundled case ``name`` copied (by ``case-path``) into ``tmp_path`` under another name."""
    result = CliRunner().invoke(main, ["case-path", name])
    assert result.exit_code == 0
    source = Path(result.output.strip())
    assert source.parent.name == "cases" and source.parent.parent.name == "loop"
    path = tmp_path / f"my-{name}.toml"
    path.write_text(source.read_text().replace(f'name = "{name}"', f'name = "my-{name}"'))
    return path


def test_cases_lists_the_loop_tables() -> None:
    result = CliRunner().invoke(main, ["cases"])
    kinds = {line.split()[0]: line.split()[1] for line in result.output.strip().splitlines()}
    assert {kinds[name] for name in LOOPS} == {"loop"}


@pytest.mark.parametrize("name", LOOPS)
def test_solve_writes_the_loop_table(name: str, tmp_path: Path) -> None:
    """``solve`` of a copied case file: the CSV's columns are the spec's then ``status``, its numbers the
    in-house engine's to full precision."""
    path, out = _copy(name, tmp_path), tmp_path / "out.csv"
    result = CliRunner().invoke(main, ["solve", str(path), "-o", str(out)])
    assert result.exit_code == 0, result.output
    with out.open() as fh:
        rows = list(csv.DictReader(fh))
    assert f"dualmech: my-{name}, {len(rows)} positions: {len(rows)} ok" in result.output
    case = linkage_case(str(path))
    spec = table_spec("loop", case)
    assert list(rows[0]) == [*spec.columns, "status"]
    expected = solve_loop_table(case)
    for column in spec.columns:
        np.testing.assert_array_equal([float(r[column]) for r in rows], expected[column], err_msg=column)
    assert {r["status"] for r in rows} == {"ok"}


def test_solve_by_a_judge_and_the_simulated_judge_refused() -> None:
    result = CliRunner().invoke(main, ["solve", "rsrc", "--engine", "pinocchio"])
    assert result.exit_code == 0 and result.stdout.startswith("theta1_deg,theta1,")
    assert "pinocchio: rsrc, 36 positions: 36 ok" in result.stderr


def test_the_simulated_judge_refuses_a_drive_at_the_last_joint(tmp_path: Path) -> None:
    """The simulation cuts the loop inside the ground, whose half hangs from the last joint: a table driven
    there is refused in one line naming the reason (the rigid judges take it)."""
    text = _copy("rscr", tmp_path).read_text()
    path = tmp_path / "last.toml"  # driven at joint 4, the load moved from joint 4 to joint 1
    path.write_text(text.replace("[drive]\njoint = 1", "[drive]\njoint = 4")
                    .replace("[[load]]\njoint = 4", "[[load]]\njoint = 1"))
    refused = CliRunner().invoke(main, ["solve", str(path), "--engine", "mujoco-sim"])
    assert refused.exit_code == EXIT_BAD_INPUT and refused.output.count("\n") == 1, refused.output
    assert "engine: 'mujoco-sim' does not solve this LOOP case (valid: dualmech, pinocchio, mujoco; the " \
           "simulation cuts the loop inside the ground" in refused.output


def test_validate_a_loop_table_passes(tmp_path: Path) -> None:
    """Every engine runs on a loop table and passes, the simulated judge too; the run folder holds each
    engine's table, the summary names the input of the worst row."""
    path, run = _copy("rscr", tmp_path), tmp_path / "run"
    result = CliRunner().invoke(main, ["validate", str(path), "-o", str(run)])
    assert result.exit_code == 0, result.output
    summary = json.loads((run / "summary.json").read_text())
    assert summary["verdict"] == "PASS"
    assert summary["cases"][0]["engines"] == ["dualmech", "pinocchio", "mujoco", "mujoco-sim"]
    assert summary["cases"][0]["key"] == "theta1_deg"
    worst = summary["worst"]
    assert set(worst) == {"pinocchio", "mujoco", "mujoco-sim"} and all(w["passed"] for w in worst.values())
    assert worst["mujoco"]["input"] == "theta1" and worst["mujoco"]["input_unit"] == "deg"
    # the key is the drive in degrees (rad and back: within 1e-12 deg of the file's 10 deg grid)
    assert np.abs(worst["mujoco"]["at"] - np.arange(0.0, 360.0, 10.0)).min() < 1e-12
    assert {p.name for p in (run / "tables" / "my-rscr").iterdir()} == {"dualmech.csv", "pinocchio.csv",
                                                                       "mujoco.csv", "mujoco-sim.csv"}
    report = (run / "report.md").read_text()
    assert "my-rscr: theta4 from every engine" in report and "the input \\(theta1 \\[deg\\]\\)" in report


@pytest.mark.parametrize("engine", ["mujoco", "mujoco-sim"])
def test_a_sign_flipped_in_one_engine_fails_validate(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                     engine: str) -> None:
    """The gate's proof: one judge's joint-2 force x flipped in sign (a slip a table writer could make) fails
    ``validate`` with exit 1, on that column and no other."""
    def flipped(table):
        return replace(table, columns={**table.columns, "joint2_fx": -table["joint2_fx"]})

    fault_engine(monkeypatch, engine, flipped)
    run = tmp_path / "run"
    result = CliRunner().invoke(main, ["validate", "rsrc", "-o", str(run), "--jobs", "1"])
    assert result.exit_code == 1, result.output
    summary = json.loads((run / "summary.json").read_text())
    failed = [(c["engine"], c["quantity"]) for c in summary["checks"] if not c["passed"]]
    assert summary["verdict"] == "FAIL" and failed == [(engine, "joint2_fx")]
    assert "max rel" in next(c["detail"] for c in summary["checks"] if not c["passed"])


def test_the_bundled_loop_matrix_sweeps_a_joint_row(tmp_path: Path) -> None:
    """``validate loops``: the three tables and the RSCR with its coupler (joint 2's a) at 0.10 and 0.14 m."""
    run = tmp_path / "run"
    result = CliRunner().invoke(main, ["validate", "loops", "-o", str(run)])
    assert result.exit_code == 0, result.output
    summary = json.loads((run / "summary.json").read_text())
    assert [c["id"] for c in summary["cases"]] == ["rscr", "rsrc", "7r", "rscr-joint_2_.a=0.1",
                                                   "rscr-joint_2_.a=0.14"]
    swept = np.genfromtxt(run / "tables" / "rscr-joint_2_.a=0.1" / "dualmech.csv", delimiter=",", names=True)
    base = np.genfromtxt(run / "tables" / "rscr" / "dualmech.csv", delimiter=",", names=True)
    assert np.abs(swept["theta4"] - base["theta4"]).max() > 1e-3  # another mechanism, not the base again
