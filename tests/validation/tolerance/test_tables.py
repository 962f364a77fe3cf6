"""A tolerance study of the table kinds run and judged (validation/tolerance/study.py, spot_checks.py): the
RSSR, the RCCC and loop tables through the same study as the slider crank."""

import csv
import json

import numpy as np
import pytest
from numpy.testing import assert_allclose

from dualmech.models.tolerance.plan import in_house, plan_of, study_case
from dualmech.models.tolerance.spec import spec_from_dict
from dualmech.models.tolerance.study import StudyInput
from dualmech.validation.tolerance.spot_checks import run_spot_checks, spot_check
from dualmech.validation.tolerance.study import run_study


def _study(case: str, tolerances: dict, n: int, seed: int = 0) -> StudyInput:
    return StudyInput(study_case(case), spec_from_dict({"tolerances": tolerances}), n, seed)


@pytest.mark.parametrize("case, tolerances", [
    ("rccc", {"geometry.coupler_twist_deg": {"dist": "normal", "sd": 0.2}}),
    ("rscr", {"joint[2].a": {"dist": "normal", "sd": 5e-4},
              "joint[4].alpha_deg": {"dist": "normal", "sd": 0.3}}),
])
def test_a_table_kinds_study_is_judged_and_its_sensitivities_checked(tmp_path, case, tolerances):
    """Every sampled design the judges re-solve agrees with the in-house engine (the generated judges of a
    loop table; the RSSR's and RCCC's preset judges), and the central-difference sensitivities agree with
    the solver's differences at a step a thousand times smaller."""
    pytest.importorskip("pinocchio")
    pytest.importorskip("mujoco")
    study = _study(case, tolerances, 12)
    summary, x, samples = run_study(study, "both", tmp_path / "out", judge_samples=1)
    assert summary["kind"] == {"rccc": "rccc", "rscr": "loop"}[case]
    assert [s["engine"] for s in summary["judges"]] == ["pinocchio", "mujoco"]
    assert summary["judges_passed"], summary["judges"]
    assert summary["sensitivity_check"]["passed"], summary["sensitivity_check"]
    assert list(summary["nominal"]) == list(plan_of(study.case).outputs(study.case.record))
    with (tmp_path / "out" / "samples.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 12 and list(rows[0])[1:1 + len(tolerances)] == list(tolerances)
    assert_allclose([float(r[k]) for r in rows for k in tolerances], x.ravel(), rtol=0, atol=0)


def test_designs_that_do_not_assemble_are_counted_in_the_samples_and_the_yield(tmp_path):
    """A coupler tolerance so wide that some RSSRs assemble over part of the cycle or not at all: each keeps
    its row in samples.csv with its status and fraction, and the yield counts them."""
    study = _study("rssr", {"geometry.coupler": {"dist": "uniform", "low": -0.3, "high": 0.45}}, 40, seed=2)
    summary, _, samples = run_study(study, "mc", tmp_path / "out", judge_samples=0)
    status = samples["status"].astype(str)
    counts = {w: int((status == w).sum()) for w in ("ok", "partial", "no_assembly")}
    assert counts["partial"] > 0 and counts["no_assembly"] > 0 and sum(counts.values()) == 40
    assert summary["yield"]["ok"] == counts["ok"] and summary["yield"]["n"] == 40
    assert summary["outputs"]["peak_j1_force"]["n"] == counts["ok"]
    frac = samples["assembled_fraction"]
    assert np.all((frac > 0) & (frac < 1) == (status == "partial"))
    with (tmp_path / "out" / "samples.csv").open() as fh:
        assert [r["status"] for r in csv.DictReader(fh)] == status.tolist()


def test_a_judge_disagreeing_on_a_table_design_fails_its_spot_check():
    """Deliberate fault: Pinocchio handed the design with its coupler 1e-6 longer (the reference is not)."""
    pytest.importorskip("pinocchio")
    from dualmech.validation import engines

    case = study_case("rssr")
    plan = plan_of(case)
    spec = spec_from_dict({"tolerances": {"geometry.coupler": {"dist": "normal", "sd": 1e-3}}})
    design = plan.design(case, spec, np.array([0.4001]), "design-0000000")
    moved = plan.design(case, spec, np.array([0.4001 * (1 + 1e-6)]), "design-0000000")
    reference = in_house(design)(design)
    assert spot_check(design, reference, "pinocchio", engines.run_engine("pinocchio", design)).passed
    check = spot_check(design, reference, "pinocchio", engines.run_engine("pinocchio", moved))
    assert not check.passed and check.worst_ratio > 1 and check.failures
    assert set(check.outputs) == set(plan.outputs(design))
    assert run_spot_checks([design], judges=("pinocchio",))[0].passed


def test_the_summary_names_the_kind_units_and_sensitivity_method(tmp_path):
    study = _study("rsrc", {"body[3].mass": {"dist": "normal", "sd": 0.05}}, 1)
    summary, _, _ = run_study(study, "linear", tmp_path / "out", judge_samples=0)
    stored = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert stored["kind"] == "loop" and stored["mode"] == "loop"
    method = "central differences of the solver, Richardson, step 0.001"
    assert stored["sensitivity_method"].startswith(method)
    assert stored["units"] == plan_of(study.case).units(study.case)
    assert stored["round_off"] == {"peak_joint2_moment": pytest.approx(0.0, abs=1e-12)}  # a ball: no moment


def test_sensitivities_off_by_1e_3_fail_the_check(tmp_path, monkeypatch):
    """Deliberate fault: the loop table's derivative of its output range by a joint's twist comes out 1e-3
    too large; the check (differences at a step a thousand times smaller) names it."""
    from dataclasses import replace

    import dualmech.models.tolerance.tables as tables

    real = tables.PLAN.sensitivities

    def off(case, spec, table):
        sens = real(case, spec, table)
        values = {n: dict(v) for n, v in sens.values.items()}
        values["range_theta4"]["joint[4].alpha_deg"] *= 1.001
        return replace(sens, values=values)

    monkeypatch.setattr(tables, "PLAN", replace(tables.PLAN, sensitivities=off))
    study = _study("rscr", {"joint[4].alpha_deg": {"dist": "normal", "sd": 0.3}}, 1)
    summary, _, _ = run_study(study, "linear", tmp_path / "out", judge_samples=0)
    check = summary["sensitivity_check"]
    assert not check["passed"] and (check["output"], check["key"]) == ("range_theta4", "joint[4].alpha_deg")


def test_a_table_kinds_samples_are_the_same_in_worker_processes(tmp_path):
    """The chunks' workers rebuild the loop table's case from its table: two processes give the samples
    one gives, bit for bit (300 designs: two chunks)."""
    tolerances = {"joint[2].a": {"dist": "normal", "sd": 5e-4},
                  "joint[4].alpha_deg": {"dist": "normal", "sd": 0.3}}
    _, x1, one = run_study(_study("rscr", tolerances, 300, seed=4), "mc", tmp_path / "one", judge_samples=0)
    _, x2, two = run_study(_study("rscr", tolerances, 300, seed=4), "mc", tmp_path / "two", jobs=2,
                           judge_samples=0)
    assert (tmp_path / "one" / "samples.csv").read_bytes() == (tmp_path / "two" / "samples.csv").read_bytes()
    assert np.array_equal(x1, x2) and all(np.array_equal(one[k], two[k]) for k in one)
