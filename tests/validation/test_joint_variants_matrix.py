"""The joint-variant matrix (``validation/matrices/joints.toml``) and the IFToMM case, judged end to end.

Every engine builds its own model from ``case.joints``; the gate must pass on the variants and must fail
when the in-house solver loses the universal joint (it then keeps the ball-ball rod's zero spin while
the judges turn the rod's spin with the joint).
"""

from __future__ import annotations

import numpy as np
import pytest

from dualmech.models.slider_crank import kernel as slider_crank_kernel
from dualmech.verbs import validate

pytest.importorskip("pinocchio")
pytest.importorskip("mujoco")

ENGINES = ("dualmech", "pinocchio", "mujoco")  # the simulation judge: selftest and the CLI matrix run


def _j3_moment_checks(run):
    return [c for c in run.comparison.checks if c.quantity.startswith("j3_m") and "universal" in c.case]


def test_every_variant_passes_both_rigid_judges(tmp_path) -> None:
    run = validate("joints", tmp_path / "run", engines=ENGINES, jobs=1)
    assert run.verdict == "PASS", [c.detail for c in run.comparison.checks if not c.passed][:5]
    moments = _j3_moment_checks(run)
    assert {c.engine for c in moments} == {"pinocchio", "mujoco"}
    assert all(c.n_compared > 0 for c in moments)
    peak = max(float(np.nanmax(np.abs(run.outcome.results[c.case]["dualmech"][c.quantity]))) for c in moments)
    assert peak > 0.0  # the universal joint's moment is compared, not two zeros


def test_the_gate_fails_when_the_solver_loses_the_universal_joint(tmp_path, monkeypatch) -> None:
    real = slider_crank_kernel.case_arrays

    def ball_ball(cases):
        geo, bodies = real(cases)
        geo[:, 4] = 0.0  # the fault: every joint 3 a ball for the in-house kernel
        return geo, bodies

    monkeypatch.setattr(slider_crank_kernel, "case_arrays", ball_ball)
    run = validate("joints", tmp_path / "run", engines=ENGINES, jobs=1)
    assert run.verdict == "FAIL"
    failed = {(c.case, c.engine) for c in run.comparison.checks if not c.passed}
    assert failed and all("universal" in case for case, _ in failed)
    assert {engine for _, engine in failed} == {"pinocchio", "mujoco"}



LOCK_CASE = """
name = "universal-lock"
[joints]
rod_slider = "universal"
[geometry]
crank_length = 12.0
rod_length = 50.0
slider_offset = 12.0
slider_twist_deg = 185.0
crank_axial_shift = 0.0
[motion]
crank_rpm = 50.0
angles_deg = { start = 170.0, stop = 190.0, step = 0.25 }
[bodies]
crank_radius = 1.5
rod_radius = 1.0
slider_side = 3.0
weight_density = 0.28
gravity_constant = 386.4
[loads]
slider_force = 250.0
gravity = [0.0, 0.0, -386.4]
"""


def _validate_lock(tmp_path):
    case = tmp_path / "lock.toml"
    case.write_text(LOCK_CASE)
    return validate(case, tmp_path / "run", engines=ENGINES, jobs=1)


def test_every_rigid_engine_flags_the_universal_joint_lock(tmp_path) -> None:
    # a4 = a1: at theta1 = 180 deg the crank pin is on the slider line, the rod along it (core/status.py)
    run = _validate_lock(tmp_path)
    assert run.verdict == "PASS", [c.detail for c in run.comparison.checks if not c.passed][:5]
    (tables,) = run.outcome.results.values()  # one case (named by its load mode)
    for engine, table in tables.items():
        assert table.status[table["theta1_deg"] == 180.0][0] == "joint_lock", engine
        assert 0 < int((table.status == "joint_lock").sum()) < len(table), engine


def test_the_gate_fails_when_a_judge_misses_the_lock(tmp_path, monkeypatch) -> None:
    from dualmech.validation.judges.mujoco_slider_crank import engine as mujoco_engine

    monkeypatch.setattr(mujoco_engine, "flag_joint_lock", lambda status, condition, universal: status)
    run = _validate_lock(tmp_path)
    failed = {(c.engine, c.quantity) for c in run.comparison.checks if not c.passed}
    assert run.verdict == "FAIL" and ("mujoco", "status") in failed


def test_the_iftomm_case_passes_every_judge(tmp_path) -> None:
    # the benchmark as specified (revolute crank, universal joint at the slider), the simulation judge too
    run = validate("iftomm/spatial-slider-crank", tmp_path / "run", jobs=1)
    assert run.verdict == "PASS", [c.detail for c in run.comparison.checks if not c.passed][:5]
    assert {c.engine for c in run.comparison.checks} >= {"pinocchio", "mujoco", "mujoco-sim"}
