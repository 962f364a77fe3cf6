"""Loop tables the suite has never seen, written as a user would (no ``start`` values, a drive at constant
speed), through ``validate`` on every engine: each must PASS.  Both failed before the searched start's rule
(``models/loop/start.py``) and the scale of a zero group (``zero_group_scale``): the RUSR's Pinocchio judge
closed the other assembly of its U joint (5.8e9 times its tolerance on ``theta2``), the RSSP's closed the
slider on the other side (1.6e10 on ``s4``: its two assemblies differ in the slide's sign alone), and the
RSSP's simulated judge was held to 1e-3 rad/s² absolute on the constant-speed drive's ``theta1_ddot``
(1.6 times its tolerance; 4e-6 of the drive's w²)."""

from __future__ import annotations

import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import dualmech
from dualmech.models.linkages import linkage_case, read_linkage, table_spec
from dualmech.models.loop.table import solve_loop_table
from dualmech.validation.compare.tables import unit_scales, zero_group_scale
from tests.validation.report.test_linkage_report import others, row

TABLES = Path(__file__).parent / "data"

pytest.importorskip("pinocchio")
pytest.importorskip("mujoco")


@pytest.mark.parametrize("name", ["rusr", "rssp"])
def test_a_new_table_without_start_values_passes_on_every_engine(tmp_path: Path, name: str) -> None:
    run = dualmech.validate(TABLES / f"{name}.toml", tmp_path / "run")
    assert str(run.verdict) == "PASS", [c for c in run.comparison.failures()]
    assert {c.engine for c in run.comparison.checks} == {"dualmech", "pinocchio", "mujoco", "mujoco-sim"}


def test_a_zero_group_is_scaled_by_its_rates() -> None:
    """The RSSP's drive turns at constant speed: ``theta1_ddot`` is 0 at every row, so its group's scale is
    the drive speed squared; its slide's acceleration is not zero and keeps its own peak."""
    case = linkage_case(read_linkage(str(TABLES / "rssp.toml")))
    table = solve_loop_table(case)
    spec = table_spec("loop", case)
    assert np.all(table["theta1_ddot"] == 0.0)
    speed = float(np.max(np.abs(table["theta1_dot"])))
    assert speed == 20.0
    scales = unit_scales(table, table, spec, spec.kinematics)
    assert scales["angle_ddot"] == pytest.approx(speed**2, rel=1e-15)
    assert scales["length_ddot"] == pytest.approx(np.max(np.abs(table["s4_ddot"])), rel=1e-15)
    peak_v, peak_l = np.max(np.abs(table["s4_dot"])), np.max(np.abs(table["s4"]))
    assert zero_group_scale("length_ddot", table, spec) == pytest.approx(peak_v**2 / peak_l, rel=1e-15)
    assert zero_group_scale("force", table, spec) == 1.0


def test_a_table_that_assembles_nowhere_fails_in_one_line_and_draws_no_empty_figure(tmp_path: Path) -> None:
    """The RSSP with a rod too short to reach: the in-house search says where it looked and what to check,
    and the report draws no heat map or case figure of nothing (matplotlib warned of singular limits and an
    empty legend on the user's terminal)."""
    text = (TABLES / "rssp.toml").read_text().replace("a = 0.2\n", "a = 0.001\n", 1)
    path = tmp_path / "short.toml"
    path.write_text(text)
    run = dualmech.validate(path, tmp_path / "run", engines="dualmech,mujoco")
    assert str(run.verdict) == "FAIL"
    failed = run.comparison.failures()[0]
    assert failed.engine == "dualmech" and failed.detail.startswith(
        "ValueError: start: no assembled pose found at 8 drive positions (64 random poses each): the loop "
        "may not assemble there (check its lengths and the drive's range)")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        run.write_report()
    assert not list((tmp_path / "run" / "figures").glob("*.png"))


#: The RRCRC's words at 0, 10, ..., 350 deg, by each rigid engine's own continuation: its loop assembles from
#: ~125 deg to ~237 deg.  At 228.2 deg it passes a joint lock: the closure Jacobian's determinant changes sign
#: on a smooth path (every engine's walk through it corrects its secant by ~2 % of the step), which every
#: engine used to take for the end of its branch (``branch_jump`` at 230 deg).
RRCRC_WORDS = ["no_assembly"] * 13 + ["ok"] * 11 + ["no_assembly"] * 12


def test_a_drive_through_a_joint_lock_passes_with_every_engine_following_it(tmp_path: Path) -> None:
    """Before, the run failed twice: the reference's ``branch_jump`` at 230 deg was taken for an engine
    failure, and the simulated judge, started at the edge of the gap, said ``not_converged`` at 130 deg (its
    servo settled 20 deg later).  Then every engine said ``branch_jump`` past the lock at 228.2 deg; now each
    follows its branch through it, and the simulation, as the RSSR's, needs the loop closed at every
    position."""
    run = dualmech.validate(TABLES / "rrcrc.toml", tmp_path / "run")
    assert str(run.verdict) == "PASS", [c for c in run.comparison.failures()]
    tables = run.results["rrcrc"]
    assert set(tables) == {"dualmech", "pinocchio", "mujoco"}  # the simulation: not applicable
    for engine, table in tables.items():
        assert list(table.status) == RRCRC_WORDS, engine
    from dualmech.models.linkages import summary

    assert tables["dualmech"].meta["messages"] == [
        "no_assembly: the loop does not close at theta1 = 0..120, 240..350 deg"]
    closed = [line for line in summary(tables["dualmech"]).splitlines() if line.startswith("worst closure")]
    assert closed and float(closed[0].split(": ")[1]) < 1e-12  # was 0.154: a no_assembly row's least error
    run.write_report()  # the positions without an answer are named beside the peaks, not left out in silence
    markdown = (tmp_path / "run" / "report.md").read_text()
    assert row(markdown, "Peak joint loads", "rrcrc")[-1] == others(np.array(RRCRC_WORDS)) \
        == "no\\_assembly 25"
    with pytest.raises(ValueError, match=r"its drive is servo-driven through every position of the table: "
                                         r"its loop must close \(ok\) at all of them\)$"):
        dualmech.solve(TABLES / "rrcrc.toml", engine="mujoco-sim")


def test_a_reference_that_jumps_where_its_branch_goes_on_fails(tmp_path: Path, monkeypatch) -> None:
    """Deliberate fault: the in-house engine says ``branch_jump`` at 150 deg, where every judge's branch goes
    on: the reference's word differs from every judge's there."""
    from tests.engine_faults import fault_engine

    def jumped(table):
        status = np.asarray(table.status, dtype=object).copy()
        status[15] = "branch_jump"
        row = np.arange(len(status)) == 15
        columns = {c: v if c == "theta1_deg" else np.where(row, np.nan, v) for c, v in table.columns.items()}
        return replace(table, columns=columns, status=status)

    fault_engine(monkeypatch, "dualmech", jumped, ("loop",))
    run = dualmech.validate(TABLES / "rrcrc.toml", tmp_path / "run", engines="dualmech,pinocchio,mujoco",
                            jobs=1)
    assert str(run.verdict) == "FAIL"
    failed = {(c.engine, c.quantity) for c in run.comparison.failures()}
    assert {("pinocchio", "status"), ("mujoco", "status")} <= failed, failed


@pytest.mark.parametrize("engine, row, word, verdict", [("dualmech", 24, "branch_jump", "PASS"),
                                                         ("mujoco", 22, "no_assembly", "FAIL")])
def test_no_assembly_past_the_end_of_the_branch_is_the_same_verdict(tmp_path: Path, monkeypatch,
                                                                     engine: str, row: int, word: str,
                                                                     verdict: str) -> None:
    """Deliberate faults: the reference saying ``branch_jump`` where the MuJoCo judge says ``no_assembly``
    (240 deg, row 24: past the end of a branch one engine finds the loop closed on another assembly, the
    other finds no pose near it) agrees (:data:`~dualmech.validation.compare.tables.BRANCH_GONE`); the judge
    saying ``no_assembly`` at an ``ok`` row (220 deg) fails."""
    from tests.engine_faults import fault_engine

    def faulted(table):
        status = np.asarray(table.status, dtype=object).copy()
        status[row] = word
        at = np.arange(len(status)) == row
        columns = {c: v if c == "theta1_deg" else np.where(at, np.nan, v) for c, v in table.columns.items()}
        return replace(table, columns=columns, status=status)

    fault_engine(monkeypatch, engine, faulted, ("loop",))
    run = dualmech.validate(TABLES / "rrcrc.toml", tmp_path / "run", engines="dualmech,mujoco", jobs=1)
    assert str(run.verdict) == verdict, [c for c in run.comparison.failures()]
