"""The Exudyn judge generated from a loop table against the in-house engine on the same table.

Both engines get the same table (the bundled ``rscr``, ``rsrc`` and ``7r``, the RSSR and RCCC as tables with
the ``start`` values a user writes: the Pinocchio judge's presets; two slider cranks with the drive torque
given) and each closes the loop on its own.  Each
column is compared over the peak of its unit group (``TableSpec.unit_group``; a group zero at every row on
its rates' scale, as the gate's ``zero_group_scale``) on the rows both call ``ok``: kinematics within
``EXUDYN_KINEMATICS``, efforts and wrenches within ``EXUDYN_REACTIONS`` (2e-8 each: the judge's own
Richardson estimate is at most 8e-9 on these tables, the measured difference at most 6.6e-9).  The bars are
its own error, so its estimate is held to them too.  Faults in the reaction conversion (a multiplier's sign,
the frame pairing of a revolute joint's rows, a moment taken about the wrong point) fail the comparison.
"""

from __future__ import annotations

import ast
import dataclasses
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

exudyn = pytest.importorskip("exudyn")

from dualmech.models.linkages import linkage_case, read_linkage  # noqa: E402
from dualmech.models.loop.columns import loop_spec  # noqa: E402
from dualmech.models.loop.description import LoopMechanism  # noqa: E402
from dualmech.models.loop.table import solve_loop_table  # noqa: E402
from dualmech.models.tables import LinkageTable  # noqa: E402
from dualmech.validation.compare.tables import zero_group_scale  # noqa: E402
from dualmech.validation.judges.exudyn_loop import continuation, engine, readout  # noqa: E402
from dualmech.validation.judges.exudyn_loop.table import solve_table  # noqa: E402
from dualmech.validation.tolerances import EXUDYN_KINEMATICS, EXUDYN_REACTIONS  # noqa: E402
from tests.models.loop.test_random_tables import random_table  # noqa: E402
from tests.validation.judges.pinocchio_loop.test_pinocchio_loop import IN_HOUSE, _preset  # noqa: E402

PACKAGE = "dualmech.validation.judges.exudyn_loop"
JUDGE = Path(__file__).parents[4] / "validation" / "judges" / "exudyn_loop"
#: The user tables of tests/validation/data (written without start values).
TABLES = Path(__file__).parents[2] / "data"
#: Unit groups of the reactions; every other group is kinematics.
REACTION_GROUPS = ("force", "moment")


def _table(name: str, rows: int | slice | None = None) -> LoopMechanism:
    """A bundled loop table or one of the Pinocchio judge's presets, its positions ``rows`` (the first
    ``rows`` if a number)."""
    mechanism = linkage_case(read_linkage(name)) if name in ("rscr", "rsrc", "7r") else _preset(name)
    if rows is None:
        return mechanism
    chosen = mechanism.drive.positions[slice(rows) if isinstance(rows, int) else rows]
    return dataclasses.replace(mechanism, drive=dataclasses.replace(mechanism.drive, positions=chosen))


def _user_table(name: str, step: float, joint_start: dict[int, list[float]] | None = None,
                **positions: float) -> LoopMechanism:
    """A user table of :data:`TABLES` at drive positions ``step`` degrees apart (``positions``: other
    ``start``, ``stop``), ``start`` values given to the joints (0-based) of ``joint_start``."""
    data = read_linkage(TABLES / f"{name}.toml")
    data["drive"]["positions"] = {**data["drive"]["positions"], "step": step, **positions}
    for k, values in (joint_start or {}).items():
        data["joint"][k]["start"] = values
    return linkage_case(data)


def worst_by_group(mine: LinkageTable, reference: LinkageTable, mechanism: LoopMechanism,
                   values: dict[str, np.ndarray] | None = None) -> dict[str, float]:
    """The largest ``|mine - reference|`` of each unit group over the group's peak (module docstring) on
    the rows both call ``ok``; ``values``: other columns in place of the differences (the judge's error
    estimates)."""
    spec = loop_spec(mechanism)
    ok = (np.asarray(mine.status) == "ok") & (np.asarray(reference.status) == "ok")
    assert ok.any()
    groups: dict[str, list[str]] = {}
    for column in spec.kinematics + spec.forces + spec.moments:
        if column != spec.key and (values is None or column in values):  # no estimate of a derived column
            groups.setdefault(spec.unit_group(column), []).append(column)
    out = {}
    for group, columns in groups.items():
        peak = max(float(np.abs(reference[c][ok]).max()) for c in columns)
        scale = peak if peak > 0.0 else zero_group_scale(group, reference, spec)
        worst = 0.0
        for c in columns:
            if values is not None:
                diff = values[c][ok]
            else:
                diff = mine[c][ok] - reference[c][ok]
                if group == "angle":
                    diff = np.remainder(diff + np.pi, 2.0 * np.pi) - np.pi
            worst = max(worst, float(np.abs(diff).max()))
        out[group] = worst / scale
    return out


def _bar(group: str) -> float:
    return (EXUDYN_REACTIONS if group in REACTION_GROUPS else EXUDYN_KINEMATICS).value


@pytest.mark.parametrize("name", ["rscr", "rsrc", "7r", "rssr", "rccc"])
def test_presets_agree_with_the_in_house_engine(name: str) -> None:
    """Same status words, every column within the bars, and the judge's own error estimate too."""
    mechanism = _table(name)
    mine, reference = solve_table(mechanism), solve_loop_table(mechanism)
    np.testing.assert_array_equal(np.asarray(mine.status, str), np.asarray(reference.status, str))
    for group, worst in worst_by_group(mine, reference, mechanism).items():
        assert worst <= _bar(group), (group, worst)
    estimate = mine.meta["richardson"]
    for group, worst in worst_by_group(mine, reference, mechanism, estimate).items():
        assert worst <= _bar(group), ("estimate", group, worst)


@pytest.mark.parametrize(("name", "rows"), [("thesis/ideal", slice(80, 101)),
                                            ("iftomm/spatial-slider-crank", slice(0, 24))])
def test_a_given_drive_effort_agrees_with_the_in_house_engine(name: str, rows: slice) -> None:
    """A drive torque given and the slider's force solved, from two prescribed runs (``given.py``): the
    slider crank through its dead centre at 90 degrees (its P joint; statuses equal there) and the IFToMM
    slider crank (its U joint), within the bars."""
    mechanism = _table(name, rows)
    assert mechanism.drive.effort is not None
    mine, reference = solve_table(mechanism), solve_loop_table(mechanism)
    np.testing.assert_array_equal(np.asarray(mine.status, str), np.asarray(reference.status, str))
    for group, worst in worst_by_group(mine, reference, mechanism).items():
        assert worst <= _bar(group), (group, worst)


@pytest.mark.parametrize("start", [None, -0.17])
def test_a_slider_frame_at_a_half_turn_agrees(start: float | None) -> None:
    """The RSSP's slider link frame is a half-turn at every pose (its P joint's ``theta`` 20 degrees, the
    alphas 80 + 100): Exudyn's ``RotationMatrix2EulerParameters`` put its node 175 degrees off, and the run
    followed neither branch (s4 -0.175 against +0.174 at row 0) or failed its steps; searched or
    started on the other branch, every column within the bars."""
    mechanism = _user_table("rssp", 30.0, None if start is None else {3: [start]})
    mine, reference = solve_table(mechanism), solve_loop_table(mechanism)
    np.testing.assert_array_equal(np.asarray(mine.status, str), np.asarray(reference.status, str))
    assert np.sign(reference["s4"][0]) == (1.0 if start is None else -1.0)
    for group, worst in worst_by_group(mine, reference, mechanism).items():
        assert worst <= _bar(group), (group, worst)


def test_a_negative_drive_rate_agrees() -> None:
    """The RSCR's rows rising while the drive turns backward: the drive passes them from the last, so the run
    goes through them that way (a law through them rising at a negative rate at every row went back and
    forth within each row: 1e-3 of the peak acceleration off); every column within the bars."""
    mechanism = _table("rscr", rows=6)
    mechanism = dataclasses.replace(mechanism, drive=dataclasses.replace(mechanism.drive,
                                                                           speed=-mechanism.drive.speed))
    mine, reference = solve_table(mechanism), solve_loop_table(mechanism)
    np.testing.assert_array_equal(np.asarray(mine.status, str), np.asarray(reference.status, str))
    for group, worst in worst_by_group(mine, reference, mechanism).items():
        assert worst <= _bar(group), (group, worst)


def test_the_closure_follows_the_rrcrc_through_its_lock() -> None:
    """The ``rrcrc`` passes a joint lock at 228.2 degrees (its determinant's sign turns on a smooth path:
    ``tests/validation/test_user_tables.py``); the judge's own walk follows it on to 230 degrees, as the
    in-house engine does, and names 230 as the row after the lock (where its runs are split)."""
    mechanism = _user_table("rrcrc", 10.0, start=180.0, stop=240.0)
    _, words, _, turns = continuation.continuation(mechanism)
    assert list(words) == list(solve_loop_table(mechanism).status) == ["ok"] * 6
    assert turns == [5]


def test_a_table_assembled_from_its_middle_agrees() -> None:
    """The ``rrcrc`` assembles from 125 degrees: no run-in from rest closes before 130, nor across its lock
    at 228.2; the table's motion from 170 and its reversal in time from 220 down to 130 judge the rows up to
    the lock within the bars.  Its one row past the lock (230) no run reaches: ``not_converged``, the judge's
    known failure there (``docs/validation.md``)."""
    mechanism = _user_table("rrcrc", 10.0, start=110.0, stop=250.0)
    mine, reference = solve_table(mechanism), solve_loop_table(mechanism)
    words = list(np.asarray(reference.status, str))
    assert words == ["no_assembly"] * 2 + ["ok"] * 11 + ["no_assembly"], words
    assert list(np.asarray(mine.status, str)) == words[:12] + ["not_converged", "no_assembly"]
    for group, worst in worst_by_group(mine, reference, mechanism).items():
        assert worst <= _bar(group), (group, worst)


def _random(seed: int, topology: str, rows: int) -> LoopMechanism:
    """A random table of tests/models/loop (:func:`random_table`), its first ``rows`` positions."""
    mechanism = random_table(seed, topology)
    drive = dataclasses.replace(mechanism.drive, positions=mechanism.drive.positions[:rows])
    return dataclasses.replace(mechanism, drive=drive)


def test_a_run_that_fails_in_its_run_in_gives_way_to_the_next() -> None:
    """A random RSCR whose long run-in from rest starts 46 degrees back, near an edge of assembly where the
    pose swings faster than the rows' steps allow: that run fails (every row was ``not_converged``), the
    next plan (a shorter run-in) judges every row."""
    mechanism = _random(1, "RSCR", 4)
    mine, reference = solve_table(mechanism), solve_loop_table(mechanism)
    assert list(mine.status) == list(reference.status) == ["ok"] * 4


def test_an_accelerating_drive_is_judged_to_its_estimate() -> None:
    """A random RSSR, six rows, whose drive accelerates (-0.42 rad/s² at -0.23 rad/s): its acceleration was
    1.2e-7 of the peak off, as its Richardson estimate said; with the step shortened for the estimate the
    first row (right after the run-in) was still 7e-8 off under a small estimate, until each run passed a
    lead row before it: every column within the bars, the estimate within a quarter of them."""
    mechanism = _random(4, "RSSR", 6)
    mine, reference = solve_table(mechanism), solve_loop_table(mechanism)
    for group, worst in worst_by_group(mine, reference, mechanism).items():
        assert worst <= _bar(group), (group, worst)
    for group, worst in worst_by_group(mine, reference, mechanism, mine.meta["richardson"]).items():
        assert worst <= _bar(group) / 4, ("estimate", group, worst)


def test_the_closure_keeps_its_rotations_rotations() -> None:
    """A random CSSP's two S rotations, turned step by step, drifted off the rotations by round-off: its
    closure residual grew row by row to 1e-13 of the length, past the closure's tolerance, and the last row
    was ``no_assembly`` where the in-house engine closes it; projected back, it stays at round-off."""
    poses, status, residual, _ = continuation.continuation(random_table(101, "CSSP"))
    assert list(status) == ["ok"] * 16
    assert residual.max() < 1e-14, residual.max()


def _faulty_worst(monkeypatch: pytest.MonkeyPatch, name: str, **faults: object) -> dict[str, float]:
    """The worst relative differences of a short table solved with ``faults`` patched into the readout."""
    mechanism = _table(name, rows=4)
    for attribute, value in faults.items():
        monkeypatch.setattr(readout, attribute, value)
    return worst_by_group(solve_table(mechanism), solve_loop_table(mechanism), mechanism)


def test_a_flipped_multiplier_sign_is_caught(monkeypatch: pytest.MonkeyPatch) -> None:
    """Reading Exudyn's multipliers as the bodies' constraint forces (``+C_q^T lambda``: the static
    solver's sign) turns every reaction around: far beyond the bar."""
    worst = _faulty_worst(monkeypatch, "rscr", CONSTRAINT_SIGN=-readout.CONSTRAINT_SIGN)
    assert min(worst["force"], worst["moment"]) > 1e3 * EXUDYN_REACTIONS.value, worst


def test_a_revolute_row_paired_with_the_wrong_axis_is_caught(monkeypatch: pytest.MonkeyPatch) -> None:
    """A revolute joint's two rotation rows read as ``z0.y1``, ``z0.x1`` (the order of Exudyn's
    documentation for three locked rotations, wrong for two): its moments far beyond the bar."""
    rows = {**readout.ROTATION_ROWS, "R": ((3, 2, 1), (4, 2, 0))}
    worst = _faulty_worst(monkeypatch, "rscr", ROTATION_ROWS=rows)
    assert worst["moment"] > 1e3 * EXUDYN_REACTIONS.value, worst
    assert worst["force"] <= EXUDYN_REACTIONS.value, worst


def test_a_moment_about_the_wrong_point_is_caught(monkeypatch: pytest.MonkeyPatch) -> None:
    """The RSCR's output joint is offset along its axis (``s = 0.02``): its moment about the link frame's
    origin instead of the joint's point is far beyond the bar."""
    worst = _faulty_worst(monkeypatch, "rscr", joint_point=lambda kind, s, frame: frame[:3, 3])
    assert worst["moment"] > 1e3 * EXUDYN_REACTIONS.value, worst


def test_the_judge_searches_the_same_start_as_the_in_house_engine() -> None:
    """Without start values both engines search their own assembly and take the one nearest the zero pose
    (``models/loop/start.py``): the same branch, within the bars."""
    mechanism = _table("rsrc", rows=6)
    mechanism = dataclasses.replace(mechanism, joints=tuple(dataclasses.replace(j, start=())
                                                            for j in mechanism.joints))
    worst = worst_by_group(solve_table(mechanism), solve_loop_table(mechanism), mechanism)
    for group, value in worst.items():
        assert value <= _bar(group), (group, value)


def test_nothing_is_written_to_the_working_directory(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Exudyn writes a ``solution/`` folder by default; the judge turns every output file off."""
    monkeypatch.chdir(tmp_path)
    solve_table(_table("rscr", rows=2))
    assert list(tmp_path.iterdir()) == []


def test_a_failed_run_is_its_rows_status_and_prints_nothing(capfd: pytest.CaptureFixture[str],
                                                             monkeypatch: pytest.MonkeyPatch) -> None:
    """Newton held to a tolerance it cannot reach fails every run: Exudyn's "DYNAMIC SOLVER FAILED" banner
    (printed through ``exudyn.Print`` whatever ``verboseMode``) stays off the console, the rows say
    ``not_converged`` and Exudyn's console flag is as it was."""
    for name in ("NEWTON_TOL", "NEWTON_RETRY", "NEWTON_ABSOLUTE"):
        monkeypatch.setattr(engine, name, 1e-40)
    table = solve_table(_table("rscr", rows=2))
    assert list(table.status) == ["not_converged"] * 2
    assert np.isnan(table["theta4"]).all()
    assert capfd.readouterr().out == ""
    assert exudyn.config.printToConsole


def test_a_drive_at_another_joint_is_refused() -> None:
    mechanism = _table("rscr", rows=2)
    drive = dataclasses.replace(mechanism.drive, joint=3)
    loads = (dataclasses.replace(mechanism.loads[0], joint=0), mechanism.loads[1])
    with pytest.raises(ValueError, match=r"^drive.joint: the Exudyn judge drives joint 1 only"):
        solve_table(dataclasses.replace(mechanism, drive=drive, loads=loads))


def _imported_modules(path: Path) -> set[str]:
    """Every module a source file imports by name (``ast``)."""
    names: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module:
            names.add(node.module)
        elif isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
    return names


def _loaded(module: str) -> set[str]:
    """The ``dualmech`` modules a fresh interpreter holds after importing ``module``."""
    code = f"import sys, {module}; print(' '.join(m for m in sys.modules if m.startswith('dualmech')))"
    return set(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                              check=True).stdout.split())


def test_the_judge_never_imports_the_in_house_engine() -> None:
    """Neither its own imports (read with :mod:`ast`) nor anything they load reach the in-house engine
    (the modules of ``IN_HOUSE``, the Pinocchio judge's list): its engine loads none of them, and its table
    none beyond those the shared result table loads by itself (``models/tables.py`` reaches
    ``core/motion.py`` through the case files' plumbing, as the Pinocchio judge's table does)."""
    for path in JUDGE.glob("*.py"):
        assert not {n for n in _imported_modules(path) if n.startswith(IN_HOUSE)}, path.name
    engine = _loaded(f"{PACKAGE}.engine")
    assert f"{PACKAGE}.model" in engine and not engine & set(IN_HOUSE), sorted(engine & set(IN_HOUSE))
    shared = _loaded("dualmech.models.tables") | _loaded("dualmech.models.loop.columns")
    added = _loaded(f"{PACKAGE}.table") - shared
    assert f"{PACKAGE}.table" in added and not added & set(IN_HOUSE), sorted(added & set(IN_HOUSE))
