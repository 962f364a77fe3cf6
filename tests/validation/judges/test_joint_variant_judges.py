"""The two judges on the slider crank's joint variants (issue 15), each built from ``case.joints`` alone.

Pinocchio closes the universal joint at P3 with the point constraint and the holonomic condition
``e·k4 = 0`` (its multiplier is the joint's moment); MuJoCo builds it as two hinges in the tree and cuts
the loop at P2 (the moment comes out of its RNE).  Neither reads the in-house answers, and they share no
step of the joint, so their agreement checks it.  Relative differences are the validation matrix's
(``validation/compare/differences.py``): per unit group the scale is the largest ``|reference| / c``,
``c = 1/|transmission|`` for reactions in drive-torque mode.  The universal joint's moment is also held
to its own scale (``UNIVERSAL_MOMENT_AGREEMENT``): it is ~1e-6 of the moment group's.
"""

from __future__ import annotations

import copy
from dataclasses import replace
from functools import lru_cache

import numpy as np
import pytest
from numpy.testing import assert_allclose

from dualmech.core.table import REACTION_COLUMNS, ResultTable
from dualmech.models.case import Case, case_from_dict, load_case
from dualmech.models.mechanism import crank_pin, slider_line
from dualmech.validation.compare.differences import condition_factor, relative_differences, unit_scales
from dualmech.validation.tolerances import (
    SIM_REACTIONS,
    SIM_STROKE,
    UNIVERSAL_MOMENT_AGREEMENT,
    UNIVERSAL_MOMENT_DIRECTION,
    VARIANT_JUDGES_KINEMATICS,
    VARIANT_JUDGES_REACTIONS,
)

pytest.importorskip("pinocchio")
pytest.importorskip("mujoco")

from dualmech.validation.judges.mujoco_slider_crank import closure as mujoco_closure  # noqa: E402
from dualmech.validation.judges.mujoco_slider_crank import engine as mujoco_engine  # noqa: E402
from dualmech.validation.judges.mujoco_slider_crank import sim as mujoco_sim  # noqa: E402
from dualmech.validation.judges.pinocchio_slider_crank import engine as pinocchio_engine  # noqa: E402
from dualmech.verbs import validate  # noqa: E402

PRESETS = ("thesis/a4-30-s1-3.5", "thesis/a4-20-alpha-232")
VARIANTS = (("rod_slider", "universal"),), (("crank", "revolute"),), (("crank", "revolute"),
                                                                      ("rod_slider", "universal"))
KINEMATICS = ("S4", "S4_dot", "S4_ddot")
MOMENT = ("j3_mx", "j3_my", "j3_mz")
CASES = [(p, v, m) for p in PRESETS for v in VARIANTS for m in ("torque", "force")]
UNIVERSAL = [c for c in CASES if ("rod_slider", "universal") in c[1]]


def variant_case(preset: str, joints: tuple[tuple[str, str], ...], mode: str) -> Case:
    """``preset`` with ``[joints]`` set; force mode with a slider load and gravity off every axis."""
    raw = copy.deepcopy(load_case(preset).raw)
    raw["joints"] = dict(joints)
    raw["name"] = "-".join([raw["name"], mode, *(v for _, v in joints)])
    if mode == "force":
        raw["loads"] = {"slider_force": -500.0, "gravity": [0.0, -386.4, 100.0]}
    return case_from_dict(raw)


@lru_cache(maxsize=None)
def judged(preset: str, joints: tuple[tuple[str, str], ...],
           mode: str) -> tuple[Case, ResultTable, ResultTable]:
    """The case and its MuJoCo rigid and Pinocchio tables."""
    case = variant_case(preset, joints, mode)
    return case, mujoco_engine.solve_case(case), pinocchio_engine.solve_case(case)


def moments(table: ResultTable) -> np.ndarray:
    """``(j3_mx, j3_my, j3_mz)``, shape (n, 3)."""
    return np.column_stack([table[c] for c in MOMENT])


def moment_disagreement(case: Case, reference: ResultTable, judge: ResultTable) -> np.ndarray:
    """Per ok row, ``|j3_m judge - reference| / (max|j3_m reference| c)`` (n_ok,)."""
    ok = (reference.status == "ok") & (judge.status == "ok")
    c = condition_factor(reference, case.loads.mode, "j3_mx")[ok]
    ref = moments(reference)[ok]
    return np.max(np.abs(moments(judge)[ok] - ref), axis=1) / (np.max(np.abs(ref)) * c)


def off_axis(case: Case, table: ResultTable) -> np.ndarray:
    """Per ok row, ``max(|a_r·j3_m|, |k4·j3_m|) / (s_moment c)`` with ``a_r = u x k4 / |u x k4|`` from the
    table's own pose (``docs/conventions.md``), shape (n_ok,)."""
    ok = table.status == "ok"
    g = case.geometry
    foot, k4 = slider_line(g.slider_offset, g.slider_twist)
    p2 = crank_pin(g.crank_length, np.radians(table["theta1_deg"][ok]), table["S1"][ok])
    u = (foot - table["S4"][ok][:, None] * k4 - p2) / g.rod_length
    a_r = np.cross(u, k4)
    a_r /= np.linalg.norm(a_r, axis=1)[:, None]
    m = moments(table)[ok]
    scale = unit_scales(table, table, case.loads.mode, REACTION_COLUMNS)["moment"]
    c = condition_factor(table, case.loads.mode, "j3_mx")[ok]
    return np.maximum(np.abs(np.einsum("ij,ij->i", m, a_r)), np.abs(m @ k4)) / (scale * c)


def worst(rel: dict[str, np.ndarray], columns: tuple[str, ...]) -> float:
    return max(float(np.nanmax(rel[c])) for c in columns)


@pytest.mark.parametrize("preset, joints, mode", CASES)
def test_the_judges_agree_on_the_joint_variants(preset, joints, mode) -> None:
    case, mj, pn = judged(preset, joints, mode)
    np.testing.assert_array_equal(pn.status, mj.status)
    assert np.count_nonzero(mj.status == "ok") > 300  # the comparison covers the revolution
    rel = relative_differences(mj, pn, mode, KINEMATICS + REACTION_COLUMNS)
    assert_allclose(worst(rel, KINEMATICS), 0.0, rtol=0, atol=VARIANT_JUDGES_KINEMATICS.value)
    assert_allclose(worst(rel, REACTION_COLUMNS), 0.0, rtol=0, atol=VARIANT_JUDGES_REACTIONS.value)
    if ("rod_slider", "universal") in joints:
        assert_allclose(moment_disagreement(case, mj, pn), 0.0, rtol=0, atol=UNIVERSAL_MOMENT_AGREEMENT.value)


@pytest.mark.parametrize("preset, joints, mode", UNIVERSAL)
def test_the_universal_joint_transmits_a_moment_along_n_only(preset, joints, mode) -> None:
    case, mj, pn = judged(preset, joints, mode)
    for table in (mj, pn):
        scale = unit_scales(table, table, mode, REACTION_COLUMNS)["moment"]
        assert np.nanmax(np.abs(moments(table))) > 1e-7 * scale  # a moment, not two zeros
        assert_allclose(off_axis(case, table), 0.0, rtol=0, atol=UNIVERSAL_MOMENT_DIRECTION.value)


@pytest.mark.parametrize("joints", [(), (("crank", "revolute"),)])
def test_a_ball_joint_at_the_slider_carries_no_moment(joints) -> None:
    case = variant_case(PRESETS[0], joints, "force")
    engines = (mujoco_engine, pinocchio_engine, mujoco_sim)
    for table in (engine.solve_case(case) for engine in engines):
        ok = table.status == "ok"
        assert ok.sum() > 300
        assert_allclose(moments(table)[ok], 0.0, rtol=0, atol=0)  # exactly: no moment row exists


@pytest.mark.parametrize("mode", ["torque", "force"])
def test_the_simulation_judge_follows_the_universal_joint(mode) -> None:
    case, mj, _ = judged(PRESETS[0], VARIANTS[2], mode)
    sim = mujoco_sim.solve_case(case)
    assert np.count_nonzero(sim.status == "ok") > 300
    rel = relative_differences(mj, sim, mode, ("S4",) + REACTION_COLUMNS)
    assert_allclose(worst(rel, ("S4",)), 0.0, rtol=0, atol=SIM_STROKE.value)
    assert_allclose(worst(rel, REACTION_COLUMNS), 0.0, rtol=0, atol=SIM_REACTIONS.value)
    assert_allclose(moment_disagreement(case, mj, sim), 0.0, rtol=0, atol=SIM_REACTIONS.value)


def test_the_models_have_the_variants_joints() -> None:
    case = variant_case(PRESETS[0], VARIANTS[2], "torque")
    pm = pinocchio_engine.build_model(case)
    assert (pm.model.nq, pm.model.nv, pm.nc, pm.universal) == (6, 5, 1, True)  # no axial slide
    lp = mujoco_closure.build(case)
    names = [lp.model.joint(j).name for j in range(lp.model.njnt)]
    assert names == ["crank_angle", "slider_stroke", "rod_k4", "rod_cross"]
    assert lp.model.nu == 2  # crank-angle servo and slider-load motor: no axial servo
    mujoco_closure.set_crank(lp, 0.3, 0.0)
    mujoco_closure.crude_guess(lp)
    assert mujoco_closure.close_loop(lp)[0]  # (also updates the frames)
    axes = lp.data.xaxis[[lp.model.joint("rod_k4").id, lp.model.joint("rod_cross").id]]
    k4 = lp.k4
    assert_allclose(axes[0], k4, rtol=0, atol=1e-15)  # slider side: k4
    u = mujoco_closure.rod_axis(lp)
    assert_allclose(axes[1], np.cross(u, k4) / np.linalg.norm(np.cross(u, k4)), rtol=0, atol=1e-12)


def test_a_wrong_sign_of_the_universal_moment_fails_both_checks() -> None:
    case, mj, pn = judged(PRESETS[0], VARIANTS[0], "torque")
    flipped = replace(pn, columns={**pn.columns, **{c: -pn[c] for c in MOMENT}})
    assert np.nanmax(moment_disagreement(case, mj, flipped)) > 1.0
    rel = relative_differences(mj, flipped, "torque", MOMENT)
    assert worst(rel, MOMENT) > 100 * VARIANT_JUDGES_REACTIONS.value  # the matrix's group check too


def test_a_rod_side_axis_off_a_r_fails_the_direction_and_the_agreement(monkeypatch) -> None:
    real = mujoco_closure.case_to_mjcf

    def wrong_axis(case, settings=None):  # the fault: the rod-side hinge along the rod's z, not a_r
        return real(case, settings).replace('name="rod_cross" type="hinge" pos="50.0 0 0" axis="0 1 0"',
                                            'name="rod_cross" type="hinge" pos="50.0 0 0" axis="0 0 1"')

    case = variant_case(PRESETS[0], VARIANTS[0], "force")
    pn = pinocchio_engine.solve_case(case)
    monkeypatch.setattr(mujoco_closure, "case_to_mjcf", wrong_axis)
    assert "axis=\"0 0 1\"" in mujoco_closure.case_to_mjcf(case)  # the fault is in the model
    mj = mujoco_engine.solve_case(case)
    assert np.any(mj.status != pn.status)  # the wrong joint does not even close where the right one does
    assert np.max(off_axis(case, mj)) > 1e3 * UNIVERSAL_MOMENT_DIRECTION.value  # where it closes
    assert np.max(moment_disagreement(case, pn, mj)) > 1e3 * UNIVERSAL_MOMENT_AGREEMENT.value


def test_the_gate_fails_when_one_judge_flips_the_universal_moment(tmp_path, monkeypatch) -> None:
    real = pinocchio_engine.to_table

    def flipped(case, sol, meta=None):  # the fault: j3_m of the slider on the rod, not of the rod on it
        table = real(case, sol, meta)
        return replace(table, columns={**table.columns, **{c: -table[c] for c in MOMENT}})

    monkeypatch.setattr(pinocchio_engine, "to_table", flipped)
    run = validate("joints", tmp_path / "run", engines=("dualmech", "pinocchio"), jobs=1)
    assert run.verdict == "FAIL"
    failed = {(c.case, c.quantity) for c in run.comparison.checks if not c.passed}
    assert failed and all("universal" in case and q in MOMENT for case, q in failed)
