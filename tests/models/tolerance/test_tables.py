"""The tolerance plan of the table kinds (models/tolerance/tables.py): keys, outputs, sensitivities, counts.

Oracles: an in-line slider crank as a loop table whose output range is 2 a1 exactly (a linear case: its
derivatives are 2 and 0, its Monte Carlo spread twice the sampled a1's); a quasi-static RSSR, whose loads are
homogeneous of degree 1 in the given output torque (Euler: d peak / d T = peak / T); and central differences
of the public ``dualmech.solve`` at two steps for every table kind.
"""

import copy
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

import dualmech
from dualmech.models.inputs import CaseError, key_text
from dualmech.models.linkages import read_linkage
from dualmech.models.tolerance.plan import TableCase, in_house, plan_of, study_case
from dualmech.models.tolerance.sampling import sample_chunk
from dualmech.models.tolerance.spec import SpecError, spec_from_dict
from dualmech.models.tolerance.summary import summarize
from dualmech.models.tolerance.tables import case_keys, design_table, peak_name, peak_rows

INLINE = Path(__file__).with_name("data") / "inline_rssp.toml"


def _spec(**tolerances: dict):
    return spec_from_dict({"tolerances": dict(tolerances)})


def _nominal(case: TableCase):
    return in_house(case.record)(case.record)


def test_the_keys_are_the_case_tables_numbers_rows_by_their_index():
    """Every stated number, rows of an array of tables 1-based; not the row or branch integers, the words,
    the arrays (start poses, gravity) nor the drive's positions."""
    keys = case_keys(study_case("rscr").raw)
    assert keys[:7] == ("joint[1].a", "joint[2].a", "joint[3].alpha_deg", "joint[3].a", "joint[4].s",
                        "joint[4].alpha_deg", "joint[4].a")
    assert "drive.speed" in keys and "body[3].mass" in keys and "load[1].value" in keys
    fixed = ("drive.joint", "drive.positions", "load[1].joint", "mechanism")
    assert not any(k.startswith(fixed) for k in keys)
    rssr = case_keys(read_linkage("rssr"))
    assert "geometry.coupler" in rssr and "loads.output_torque" in rssr and "motion.crank_rpm" in rssr
    assert "mechanism.branch" not in rssr and not any("angles_deg" in k for k in rssr)


@pytest.mark.parametrize("case, key, valid", [
    ("rssr", "geometry.nope", "geometry.input_crank, geometry.input_offset, geometry.coupler, "),
    ("rscr", "joint[9].a", "joint[1, 2, 3, 4].a, joint[3, 4].alpha_deg, joint[4].s, drive.speed, "),
    ("rccc", "joint[1].a", "geometry.input_offset, geometry.input_link, "),
])
def test_an_unknown_key_is_one_line_naming_the_valid_ones(case, key, valid):
    study = study_case(case)
    with pytest.raises(SpecError) as err:
        plan_of(study).nominal_values(study, _spec(**{key: {"dist": "normal", "sd": 1e-3}}))
    message = str(err.value)
    assert "\n" not in message
    assert message.startswith(f"tolerances.{key_text(key)}: not a key that can vary (valid: ")
    assert valid in message


def test_a_sampled_design_is_the_case_table_with_the_keys_set():
    study = study_case("rscr")
    plan = plan_of(study)
    spec = _spec(**{"joint[2].a": {"dist": "normal", "sd": 1e-3},
                    "body[1].mass": {"dist": "normal", "sd": 0.01}})
    assert_allclose(plan.nominal_values(study, spec), [0.12, study.raw["body"][0]["mass"]], rtol=0, atol=0)
    record = plan.design(study, spec, np.array([0.125, 0.5]), "d")
    assert record.name == "d" and record.bodies[0].mass == 0.5
    assert study.raw["joint"][1]["a"] == 0.12  # the nominal table is not changed
    with pytest.raises(CaseError, match=r"^d \(sampled from the SPEC\): body\[1\]\.mass: .*-0\.5"):
        plan.design(study, spec, np.array([0.125, -0.5]), "d")


def test_outputs_are_the_output_range_and_every_load_of_the_table_spec_with_units():
    study = study_case("rssr")
    plan = plan_of(study)
    assert plan.outputs(study.record) == (
        "range_phi4_deg", "peak_j1_force", "peak_j1_moment", "peak_j2_force", "peak_j3_force",
        "peak_j4_force", "peak_j4_moment", "peak_drive_torque", "peak_output_torque")
    assert plan.units(study) == {"range_phi4_deg": "deg", **dict.fromkeys(
        ("peak_j1_force", "peak_j2_force", "peak_j3_force", "peak_j4_force"), "N"), **dict.fromkeys(
        ("peak_j1_moment", "peak_j4_moment", "peak_drive_torque", "peak_output_torque"), "N·m")}
    assert peak_name("joint3 |m|") == "peak_joint3_moment" and peak_name("|effort_s4|") == "peak_effort_s4"


def test_the_outputs_are_the_tables_extremes():
    """Oracle: the RSSR's table read directly: the output angle's max - min, each joint force's largest
    magnitude over the ok rows, the drive torque's largest |value|."""
    study = study_case("rssr")
    table = _nominal(study)
    out = plan_of(study).table_outputs([table], study.record)
    phi = table["phi4_deg"]
    assert_allclose(out["range_phi4_deg"], [phi.max() - phi.min()], rtol=1e-15)
    force = np.sqrt(table["j3_fx"] ** 2 + table["j3_fy"] ** 2 + table["j3_fz"] ** 2)
    assert_allclose(out["peak_j3_force"], [force.max()], rtol=1e-15)
    assert_allclose(out["peak_drive_torque"], [np.abs(table["drive_torque"]).max()], rtol=1e-15)
    assert out["status"].tolist() == ["ok"] and out["assembled_fraction"].tolist() == [1.0]


def test_an_angle_range_across_a_half_turn_is_not_a_full_turn():
    """The output angle is taken continuous along the positions: a rocker swinging across +-180 deg (its
    values wrapped into -180..180) has its own swing as range (seen failing with the wrapped values)."""
    study = study_case("rssr")
    table = _nominal(study)
    phi = table["phi4_deg"]
    shifted = (phi - phi.mean() + 180.0 + 180.0) % 360.0 - 180.0  # the same swing, centred on 180 deg
    assert shifted.max() - shifted.min() > 300.0  # wrapped: it looks like almost a full turn
    turned = copy.copy(table)
    object.__setattr__(turned, "columns", {**table.columns, "phi4_deg": shifted})
    out = plan_of(study).table_outputs([turned], study.record)
    assert_allclose(out["range_phi4_deg"], [phi.max() - phi.min()], rtol=1e-12)


def test_linear_case_derivatives_and_monte_carlo_spread_are_exact():
    """Oracle: over this grid the in-line slider crank's output range is 2 a1 exactly: d/d a1 = 2,
    d/d a2 = 0, and every sampled design's range is twice its a1, so the Monte Carlo mean and standard
    deviation are twice the sampled a1's, and the linear propagation gives 2 sd."""
    study = study_case(INLINE)
    plan = plan_of(study)
    spec = _spec(**{"joint[1].a": {"dist": "normal", "sd": 2e-4},
                    "joint[2].a": {"dist": "normal", "sd": 1e-3}})
    sens = plan.sensitivities(study, spec, _nominal(study))
    assert sens.positions_deg["range_s4"] == [90.0, 270.0]
    assert_allclose(sens.values["range_s4"]["joint[1].a"], 2.0, rtol=1e-9)
    assert_allclose(sens.values["range_s4"]["joint[2].a"], 0.0, atol=1e-9)
    x = sample_chunk(spec, plan.nominal_values(study, spec), 64, 3, 0)
    samples = plan.analyse(study, spec, x, 0)
    assert_allclose(samples["range_s4"], 2.0 * x[:, 0], rtol=1e-12)
    stats = summarize(spec, sens.nominal_outputs, x, samples, sens, plan.groups(study.record))
    assert_allclose(stats["outputs"]["range_s4"]["mean"], 2.0 * x[:, 0].mean(), rtol=1e-12)
    assert_allclose(stats["outputs"]["range_s4"]["std"], 2.0 * x[:, 0].std(ddof=1), rtol=1e-9)
    assert_allclose(stats["linear_std"]["range_s4"], 2.0 * 2e-4, rtol=1e-9)
    assert_allclose(stats["linear_mean"]["range_s4"], 0.1, rtol=1e-12)


def _quasi_static_rssr() -> TableCase:
    data = copy.deepcopy(read_linkage("rssr"))
    data["motion"].update(crank_rpm=0.0, crank_accel=0.0)
    data["loads"]["gravity"] = [0.0, 0.0, 0.0]
    return study_case(data)


def test_loads_homogeneous_in_the_given_torque_have_the_derivative_euler_gives():
    """Oracle: at rest and without gravity every load of the RSSR is linear in the given output torque T,
    so d peak / d T = peak / T (Euler), and a sampled design's peak is its T times the nominal's ratio."""
    study = _quasi_static_rssr()
    plan = plan_of(study)
    spec = _spec(**{"loads.output_torque": {"dist": "normal", "sd": 0.1}})
    sens = plan.sensitivities(study, spec, _nominal(study))
    loads = [n for n in plan.outputs(study.record) if n.startswith("peak_")]
    for name in loads:
        euler = sens.nominal_outputs[name] / -4.0
        assert_allclose(sens.values[name]["loads.output_torque"], euler, rtol=1e-8, err_msg=name)
    x = sample_chunk(spec, plan.nominal_values(study, spec), 32, 1, 0)
    samples = plan.analyse(study, spec, x, 0)
    for name in loads:
        assert_allclose(samples[name], sens.nominal_outputs[name] * x[:, 0] / -4.0, rtol=1e-10, err_msg=name)


@pytest.mark.parametrize("case, key, output", [
    ("rssr", "geometry.coupler", "peak_j2_force"), ("rssr", "geometry.frame_twist_deg", "range_phi4_deg"),
    ("rccc", "geometry.output_link", "peak_j4_moment"), ("rscr", "joint[2].a", "peak_joint3_force"),
    ("rscr", "joint[3].alpha_deg", "range_theta4"), ("rsrc", "body[3].mass", "peak_effort_theta1"),
])
def test_a_sensitivity_agrees_with_central_differences_of_dualmech_solve_at_two_steps(case, key, output):
    """Oracle: the public ``dualmech.solve`` of the case table with the key moved by +-h and +-h/2
    (h = 1e-4 of its value), the output read as a user would (the largest magnitude over the ok rows, the
    range over the rows); the plain central differences at the two steps bound their own error."""
    study = study_case(case)
    plan = plan_of(study)
    spec = _spec(**{key: {"dist": "normal", "sd": 1e-3}})
    g = plan.sensitivities(study, spec, _nominal(study)).values[output][key]
    x0 = plan.nominal_values(study, spec)[0]

    def solved(value: float) -> float:
        table = dualmech.solve(design_table(study, spec, np.array([value]), "fd"))
        return float(plan.table_outputs([table], study.record)[output][0])

    h = 1e-4 * abs(x0)
    d1, d2 = ((solved(x0 + s) - solved(x0 - s)) / (2 * s) for s in (h, h / 2))
    assert abs(g - d2) <= abs(d1 - d2) + 1e-7 * abs(g), (g, d1, d2)


def test_the_derivatives_are_taken_at_the_rows_of_the_nominal_peaks():
    study = study_case("rscr")
    table = _nominal(study)
    rows = peak_rows(table, study.record)
    force = np.sqrt(sum(table[f"joint1_f{a}"] ** 2 for a in "xyz"))
    assert rows["peak_joint1_force"] == (int(np.argmax(force)),)
    assert rows["range_theta4"] == (int(np.argmax(table["theta4"])), int(np.argmin(table["theta4"])))


def test_designs_that_do_not_assemble_are_counted_never_dropped():
    """An RSSR whose coupler is too short assembles over part of the cycle (partial), one far too long at
    no position; a loop table whose start pose does not close (the engine's one-line refusal) assembles at
    no position on its branch: every design keeps its row, with its fraction and status."""
    study = study_case("rssr")
    spec = _spec(**{"geometry.coupler": {"dist": "normal", "sd": 1e-3}})
    out = plan_of(study).analyse(study, spec, np.array([[0.4], [0.1], [0.8]]), 0)
    assert out["status"].tolist() == ["ok", "partial", "no_assembly"]
    assert 0.0 < out["assembled_fraction"][1] < 1.0 and out["assembled_fraction"][2] == 0.0
    assert np.isfinite(out["range_phi4_deg"][1]) and np.isnan(out["peak_j1_force"][2])
    loop = study_case("rsrc")
    spec = _spec(**{"joint[2].a": {"dist": "normal", "sd": 1e-3}})
    out = plan_of(loop).analyse(loop, spec, np.array([[0.2], [0.06]]), 0)
    assert out["status"].tolist() == ["ok", "no_assembly"]
    assert out["assembled_fraction"].tolist() == [1.0, 0.0]
    assert all(np.isnan(out[n][1]) for n in plan_of(loop).outputs(loop.record))


def _as_loop_table(case) -> dict:
    """The slider crank ``case`` as a loop case table (the preset's joints, drive, bodies and load, the
    bodies by their mass, centre and inertia: fixed, as the case's are under the keys varied below)."""
    from dualmech.models.loop.presets import slider_crank_table

    m = slider_crank_table(case)
    step = float(np.diff(case.motion.angles_deg)[0])
    positions = {"start": float(case.motion.angles_deg[0]), "stop": float(case.motion.angles_deg[-1]) + step,
                 "step": step}
    return {"name": f"{case.name}-table", "units": case.units, "mechanism": {"kind": "loop"},
            "gravity": case.loads.gravity.tolist(),
            "joint": [{"type": j.type, "alpha_deg": np.degrees(j.alpha), "a": j.a, "s": j.s}
                      for j in m.joints],
            "drive": {"joint": 1, "positions": positions, "speed": m.drive.speed, "accel": m.drive.accel,
                      "axial_shift": m.drive.axial_shift},
            "body": [{"mass": b.mass, "com": b.com.tolist(), "inertia": b.inertia.tolist()}
                     for b in m.bodies],
            "load": [{"joint": 4, "coordinate": "s", "value": m.loads[0].value}]}


def test_a_slider_crank_as_a_loop_table_has_its_complex_step_sensitivities():
    """Oracle: the slider crank's exact (complex-step) derivatives of the same design. The first design,
    its slider guide twisted off the crank plane (262 deg, where the stroke's twist derivative is not 0),
    solved as a slider crank and as a loop table: the offset a4 is joint 4's a, the twist its alpha, the
    slider force minus joint 4's effort along its axis."""
    from dualmech.models.case import load_case

    case = load_case(Path(__file__).parents[3] / "examples" / "first-design.toml")
    case = case.with_values({"geometry.slider_twist_deg": 262.0})
    loop = study_case(_as_loop_table(case))
    keys = {"geometry.slider_offset": ("joint[4].a", 1.0),
            "geometry.slider_twist_deg": ("joint[4].alpha_deg", 1.0),
            "loads.slider_force": ("load[1].value", -1.0)}
    sd = {"geometry.slider_offset": 1e-3, "geometry.slider_twist_deg": 0.5, "loads.slider_force": 5.0}
    exact = plan_of(case).sensitivities(case, _spec(**{k: {"dist": "normal", "sd": sd[k]} for k in keys}),
                                        in_house(case)(case))
    spec = _spec(**{key: {"dist": "normal", "sd": sd[k]} for k, (key, _) in keys.items()})
    differences = plan_of(loop).sensitivities(loop, spec, _nominal(loop))
    outputs = {"stroke": "range_s4", "peak_j1_force": "peak_joint1_force",
               "peak_j2_force": "peak_joint2_force", "peak_j3_force": "peak_joint3_force",
               "peak_j4_force": "peak_joint4_force",
               "peak_j1_moment": "peak_joint1_moment", "peak_drive_torque": "peak_effort_theta1"}
    for ours, theirs in outputs.items():
        assert_allclose(differences.nominal_outputs[theirs], exact.nominal_outputs[ours], rtol=1e-12)
        for k, (key, sign) in keys.items():
            want = exact.values[ours][k]
            scale = max(abs(v) for v in exact.values[ours].values())
            assert_allclose(sign * differences.values[theirs][key], want, rtol=1e-7, atol=1e-9 * scale,
                            err_msg=f"d {ours} / d {k}")


def test_every_kind_names_its_tolerance_plan():
    """The kind table names each kind's plan (no kind is left without a study); the table kinds share one."""
    from dualmech.models.kinds import KIND_HOMES, SLIDER_CRANK, resolve
    from dualmech.models.tolerance.plan import TolerancePlan
    from dualmech.models.tolerance.tables import PLAN

    plans = {kind: resolve(home.tolerance) for kind, home in KIND_HOMES.items()}
    assert all(isinstance(p, TolerancePlan) for p in plans.values())
    assert {k for k, p in plans.items() if p is PLAN} == set(KIND_HOMES) - {SLIDER_CRANK}


def test_a_designs_branch_jumps_no_assembly_and_dead_centres_are_recorded():
    """The 7R with two keys moved to where its followed branch ends inside the cycle: the design is partial,
    and its counts are those of its table solved by ``dualmech solve`` (its words counted directly)."""
    study = study_case("7r")
    plan = plan_of(study)
    spec = _spec(**{"joint[3].a": {"dist": "normal", "sd": 2e-3},
                    "joint[5].alpha_deg": {"dist": "normal", "sd": 0.5}})
    x = np.array([[0.2511796295897352, 94.78462696593039]])
    out = plan.analyse(study, spec, x, 0)
    words = np.asarray(dualmech.solve(design_table(study, spec, x[0], "d")).status, dtype=str)
    assert (words == "branch_jump").sum() > 0 and (words == "no_assembly").sum() > 0  # the case is as meant
    assert out["status"].tolist() == ["partial"]
    assert out["branch_jumps"].tolist() == [(words == "branch_jump").sum()]
    assert out["failed_positions"].tolist() == [np.isin(words, ["branch_jump", "not_converged",
                                                                "not_finite"]).sum()]
    assert out["dead_centres"].tolist() == [(words == "dead_centre").sum()]
    assembled = np.isin(words, ["ok", "dead_centre", "assembly_limit"]).mean()
    assert_allclose(out["assembled_fraction"], [assembled], rtol=1e-15)
