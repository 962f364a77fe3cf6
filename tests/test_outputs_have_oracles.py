"""Every output of every engine, columns and metadata alike, is compared with an oracle in some test.

:data:`ORACLES` lists, per engine, each output it produces (a column, ``meta:<key>`` of its table, or
``info:<key>`` of a simulation) and the test that compares it with an oracle: a closed form
(``tests/oracles.py``, ``tests/newton_euler_oracle.py``), finite differences, another engine, or a
physical identity (power balance, Newton-Euler).  :func:`test_every_output_is_listed` fails when an engine
gains or loses an output (list it here with its oracle test), :func:`test_every_listed_test_exists` when a
listed test is renamed or removed.  The oracle tests below (and those of
``tests/validation/judges/test_judge_meta.py`` and ``tests/validation/test_linkage_outputs.py``) are
those of outputs no other test read (issue 30: the compiled engine's ``meta["dynamics_residual"]`` was wrong
on every case and no test read it).

Library-dependent engines (Pinocchio, MuJoCo) are declared dependencies: imported, not skipped.
"""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from dualmech.core.table import REACTION_COLUMNS, ResultTable
from dualmech.models.angle_ranges import format_angle_ranges, no_assembly_ranges
from dualmech.models.case import Case, load_case, with_loads
from dualmech.models.linkages import linkage_case, rccc, rssr, solve_linkage, table_spec
from dualmech.models.loop.preset_dynamics import simulate as simulate_linkage
from dualmech.models.slider_crank import analysis as slider_crank
from dualmech.models.slider_crank import dynamics_coefficients as dc
from dualmech.models.slider_crank import forward_dynamics as fd
from dualmech.models.slider_crank import kernel as slider_crank_kernel
from dualmech.validation.engines import run_engine
from dualmech.validation.engines import solve_linkage as solve_linkage_by
from dualmech.validation.tolerances import SIM_STROKE
from tests.oracles import assembly_margin, slider_line
from tests.tolerances import S4_VS_CLOSED_FORM

ROOT = Path(__file__).resolve().parent.parent

# ---------------------------------------------------------------------------------------- the inventory

HERE = "tests/test_outputs_have_oracles.py::"
KERNEL = "tests/core/test_kernel.py::test_every_preset"
SLIDER_CRANK = "tests/models/slider_crank/test_slider_crank.py::"
CLOSED_FORM = SLIDER_CRANK + "test_every_bundled_case_matches_closed_form"
CRANK = HERE + "test_crank_columns_are_the_prescribed_motion"
POSE = HERE + "test_transmission_and_residual_are_the_tables_own_pose"
CONDITION = "tests/validation/test_engine_statuses.py::test_closure_condition_matches_the_closed_form"
STATUSES = "tests/validation/test_engine_statuses.py::test_planar_edge_of_assembly"
CLASSIFIED = SLIDER_CRANK + "test_wild_random_geometries_are_classified_right"
MESSAGES = HERE + "test_messages_count_the_closed_form_no_assembly_rows"
NEWTON_EULER = "tests/models/slider_crank/test_dynamics_residual.py::test_reported_residual_is_the_oracles"
JUDGE_META = "tests/validation/judges/test_judge_meta.py::"
VERSIONS = JUDGE_META + "test_library_versions_are_the_loaded_libraries"
ITERATIONS = HERE + "test_in_house_iterations_are_the_other_implementations"


def _columns(kinematics: str, reactions: str, loads: str, transmission: str, **more: str) -> dict[str, str]:
    """Every :data:`NUMERIC_COLUMNS` name and ``status`` of a slider-crank table, with its oracle test."""
    out = {"theta1_deg": CRANK, "S1": CRANK, "S4": kinematics, "S4_dot": kinematics, "S4_ddot": kinematics,
           **{c: reactions for c in REACTION_COLUMNS}, "slider_load": loads, "drive_torque": loads,
           "transmission": transmission, "residual": POSE, "closure_condition": CONDITION, "status": STATUSES}
    return out | more


PINOCCHIO_VS_INHOUSE = ("tests/validation/judges/pinocchio_slider_crank/test_vs_inhouse.py::"
                        "test_pinocchio_agrees_with_the_inhouse_solver")
PINOCCHIO = "tests/validation/judges/pinocchio_slider_crank/test_dynamics.py::"
POWER = "tests/core/test_reactions.py::test_power_balance"
MUJOCO_JUDGE = "tests/validation/judges/mujoco_slider_crank/"
SIM_STEP = MUJOCO_JUDGE + "test_sim.py::test_a_case_sets_the_simulation_step"
MUJOCO = MUJOCO_JUDGE + "test_engine.py::"
MUJOCO_SIM = MUJOCO_JUDGE + "test_sim.py::test_simulation_agrees_with_the_inhouse_solver"
SIM_SETTINGS = JUDGE_META + "test_mujoco_sim_settings_and_servo_lag"
FORWARD = "tests/models/slider_crank/test_forward_dynamics.py::"
IFTOMM = "tests/models/slider_crank/test_iftomm.py::"
ALONG = FORWARD + "test_outputs_along_the_trajectory_are_the_solvers_at_the_simulated_states"
INFO = HERE + "test_simulation_info_is_what_ran"
LINKAGE_SIM = "tests/models/loop/test_preset_dynamics.py::"
LINKAGE_OUTPUTS = "tests/validation/test_linkage_outputs.py::"
LINKAGE_META = LINKAGE_OUTPUTS + "test_linkage_meta"
LINKAGE_RESIDUALS = LINKAGE_OUTPUTS + "test_linkage_residuals_of_every_rigid_engine"
INDEPENDENCE = "tests/validation/judges/presets/test_judge_independence.py::"
LINKAGE_SIM_TABLE = LINKAGE_OUTPUTS + "test_linkage_simulation_tables"
#: The RSSR's and RCCC's in-house engine (the loop engine on their preset tables): every column and word
#: against the closed form, whose own tests (RSSR, RCCC) hold it to finite differences, power balance and a
#: poor start.
PRESET = "tests/models/loop/test_preset_engine.py::test_the_in_house_table_is_the_closed_forms"

#: The in-house engines' meta.
IN_HOUSE_META = {"meta:iterations": ITERATIONS, "meta:dynamics_residual": NEWTON_EULER,
                 "meta:messages": MESSAGES}
#: engine -> output -> the test comparing it with an oracle.
ORACLES: dict[str, dict[str, str]] = {
    "dualmech": _columns(CLOSED_FORM, NEWTON_EULER, POWER, KERNEL, **IN_HOUSE_META),
    "dualmech-numpy": _columns(CLOSED_FORM, NEWTON_EULER, POWER, KERNEL, **IN_HOUSE_META,
                               closure_condition=KERNEL, status=CLASSIFIED),
    "pinocchio": _columns(PINOCCHIO_VS_INHOUSE,
                          PINOCCHIO + "test_every_body_is_in_newton_euler_balance",
                          PINOCCHIO + "test_power_balance",
                          PINOCCHIO_VS_INHOUSE,
                          **{"meta:pinocchio_version": VERSIONS, "meta:messages": MESSAGES,
                             **{f"meta:{k}": JUDGE_META + "test_pinocchio_meta" for k in (
                                 "newton_iterations_max", "newton_iterations_mean", "ls_residual_max",
                                 "seconds")}}),
    "mujoco": _columns(MUJOCO + "test_slider_motion_matches_the_closed_form",
                       MUJOCO + "test_every_body_obeys_newton_euler",
                       MUJOCO + "test_power_of_the_loads_is_the_rate_of_kinetic_energy",
                       MUJOCO + "test_rigid_path_agrees_with_the_inhouse_solver",
                       **{"meta:mujoco": VERSIONS, "meta:messages": MESSAGES,
                          "meta:newton_iterations": JUDGE_META + "test_mujoco_iterations"}),
    "mujoco-sim": _columns(MUJOCO_SIM, MUJOCO_SIM, MUJOCO_SIM, MUJOCO_SIM,
                           **{"meta:mujoco": VERSIONS, "meta:messages": MESSAGES,
                              "meta:timestep": SIM_STEP, "meta:steps_per_degree": SIM_STEP,
                              "meta:runin_steps": SIM_SETTINGS, "meta:servo_kp": SIM_SETTINGS,
                              "meta:servo_kv": SIM_SETTINGS, "meta:L_ref": SIM_SETTINGS,
                              "meta:max_theta_lag": SIM_SETTINGS}),
    "simulate": {
        "t": IFTOMM + "test_simulation_agrees_with_the_independent_oracle",
        "psi": IFTOMM + "test_simulation_agrees_with_the_independent_oracle",
        "theta1_deg": IFTOMM + "test_simulation_agrees_with_the_independent_oracle",
        "psi_dot": IFTOMM + "test_total_energy_stays_the_published_value_for_5_s",
        "psi_ddot": IFTOMM + "test_initial_crank_acceleration_is_the_published_one",
        **{c: ALONG for c in ("S1", "S4", "S4_dot", "S4_ddot", "transmission", *REACTION_COLUMNS)},
        "torque_applied": FORWARD + "test_inverse_dynamics_along_the_trajectory_reproduces_the_loads",
        "slider_load_applied": FORWARD + "test_inverse_dynamics_along_the_trajectory_reproduces_the_loads",
        **{c: FORWARD + "test_work_energy_with_gravity_damping_slider_spring_and_axial_motion"
           for c in ("kinetic_energy", "potential_energy", "work_drive", "work_slider", "dissipated")},
        **{f"info:{k}": INFO for k in ("method", "rtol", "atol", "nfev", "coefficients", "table_size",
                                       "interpolation_error", "message")},
    },
    **{kind: {"theta1_deg": LINKAGE_META, **{c: PRESET for c in spec.pose + spec.rates + spec.reactions},
              "output_torque": PRESET, "drive_torque": PRESET, "status": PRESET,
              "residual": LINKAGE_RESIDUALS, "dynamics_residual": LINKAGE_RESIDUALS,
              "meta:iterations": LINKAGE_META, "meta:messages": LINKAGE_META, "meta:branch": LINKAGE_META}
       for kind, spec in (("rssr", rssr.SPEC), ("rccc", rccc.SPEC))},
    "linkage-simulate": {
        **{c: LINKAGE_SIM + "test_the_simulated_table_is_the_solved_one_at_each_simulated_state"
           for c in ("theta1_deg", "psi", "psi_dot", "psi_ddot", "torque_applied", "output_torque_applied")},
        **{c: LINKAGE_SIM + "test_work_energy_balance_under_a_drive_torque"
           for c in ("t", "kinetic_energy", "potential_energy", "work_drive", "work_output", "dissipated")},
    },
}


def _rigid_linkage_judges() -> dict[str, dict[str, str]]:
    """The RSSR's and RCCC's rigid judges (Pinocchio, MuJoCo): their compared columns and statuses against
    the in-house engine through the gate, their residuals and starts by tests of their own."""
    out = {}
    for kind, spec, verdict in (("rssr", rssr.SPEC, "tests/validation/judges/presets/test_rssr_judges.py::"
                                 "test_bundled_case_agrees"),
                                ("rccc", rccc.SPEC, "tests/validation/judges/presets/test_rccc_judges.py::"
                                 "test_judges_agree")):
        for judge in ("pinocchio", "mujoco"):
            out[f"{kind}-{judge}"] = {
                **{c: verdict for c in (*spec.kinematics, *spec.forces, *spec.moments, "status")},
                **{c: LINKAGE_RESIDUALS for c in ("theta1_deg", "residual", "dynamics_residual")},
                "meta:restarts": (INDEPENDENCE
                                  + "test_the_crude_start_closes_each_branch_at_the_first_attempt"),
                "meta:iterations": INDEPENDENCE + "test_judges_ignore_the_in_house_starts"}
    return out


ORACLES |= _rigid_linkage_judges()
EXUDYN_PRESETS = "tests/validation/judges/presets/"
EXUDYN_LINKAGE = EXUDYN_PRESETS + "test_engines.py::test_the_exudyn_judge_agrees_with_the_in_house_engine"
ORACLES |= {f"{kind}-exudyn": {c: EXUDYN_LINKAGE for c in (*spec.columns, "status", "meta:restarts")}
            for kind, spec in (("rssr", rssr.SPEC), ("rccc", rccc.SPEC))}
EXUDYN_AGREES = EXUDYN_PRESETS + "test_slider_crank.py::test_the_judge_agrees_with_the_in_house_engine"
EXUDYN_POSE = EXUDYN_PRESETS + "test_slider_crank.py::test_transmission_and_condition_are_its_own_pose"
EXUDYN_GAP = EXUDYN_PRESETS + "test_slider_crank.py::test_the_rows_past_a_gap_are_a_run_of_their_own"
ORACLES["exudyn"] = _columns(EXUDYN_AGREES, EXUDYN_AGREES, EXUDYN_AGREES, EXUDYN_POSE,
                             theta1_deg=EXUDYN_AGREES, S1=EXUDYN_AGREES, residual=EXUDYN_POSE,
                             closure_condition=EXUDYN_POSE, status=EXUDYN_AGREES,
                             **{"meta:restarts": EXUDYN_GAP, "meta:messages": EXUDYN_GAP})
ORACLES |= {f"{kind}-mujoco-sim": {**{c: LINKAGE_SIM_TABLE for c in (*spec.columns, "status")},
                                  **{f"meta:{k}": LINKAGE_SIM_TABLE for k in (
                                      "mujoco", "timestep", "steps_per_degree", "runin_steps", "servo_kp",
                                      "servo_kv", "max_lag")}}
            for kind, spec in (("rssr", rssr.SPEC), ("rccc", rccc.SPEC))}
ORACLES["rssr-simulate"] = ORACLES["linkage-simulate"] | {
    c: LINKAGE_SIM + "test_the_simulated_table_is_the_solved_one_at_each_simulated_state"
    for c in rssr.COLUMNS if c != "theta1_deg"} | {"status": ORACLES["rssr"]["status"]}
ORACLES["rccc-simulate"] = ORACLES["linkage-simulate"] | {
    c: LINKAGE_SIM + "test_the_simulated_table_is_the_solved_one_at_each_simulated_state"
    for c in rccc.COLUMNS if c != "theta1_deg"} | {"status": ORACLES["rccc"]["status"]}
del ORACLES["linkage-simulate"]


def _loop_engines() -> dict[str, dict[str, str]]:
    """Every engine of a loop table on the bundled RSCR (``loop-<engine>``): the pose against the closed form
    of its ball link, the in-house rates against finite differences and its drive torque against virtual
    work, every column and status of each engine against the others through the gate, the key by the table's
    settling."""
    loops = "tests/validation/test_loop_tables.py::"
    spec = table_spec("loop", linkage_case("rscr"))
    agree = loops + "test_every_engine_agrees_with_the_others"
    condition = "tests/models/loop/test_condition.py::test_the_condition_of_a_pose_is_the_chains"
    out = {}
    for engine in ("dualmech", "pinocchio", "mujoco"):
        rates = loops + "test_rates_match_finite_differences" if engine == "dualmech" else agree
        out[f"loop-{engine}"] = {
            spec.key: "tests/models/loop/test_columns.py::test_a_table_is_settled_by_its_words",
            **{c: loops + "test_the_pose_is_the_closed_form_of_the_ball_link" for c in spec.pose},
            "closure_condition": condition,
            **{c: rates for c in spec.rates}, **{c: agree for c in (*spec.forces, *spec.moments, "status")},
            **{c: loops + "test_residuals_and_iterations_are_reported"
               for c in ("residual", "dynamics_residual", "meta:iterations")}}
    virtual_work = loops + "test_the_solved_drive_effort_is_the_virtual_work_of_the_loads"
    out["loop-dualmech"]["effort_theta1"] = virtual_work
    gaps = "tests/models/loop/test_table.py::test_a_gap_is_named_by_its_drive_angles"
    out["loop-dualmech"]["meta:messages"] = gaps
    return out


ORACLES |= _loop_engines()

#: A small case in torque mode (mujoco-sim then gives L_ref too).
SMALL = load_case("thesis/a4-30-s1-3.5").with_values({"motion.angles_deg": {"start": 0.0, "stop": 360.0,
                                                                            "step": 30.0}})


def _outputs(engine: str) -> set[str]:
    """The outputs ``engine`` produces on :data:`SMALL` (or a bundled linkage case)."""
    if engine in ("rssr", "rccc"):
        table = solve_linkage(engine)
        return set(table.columns) | {"status"} | {f"meta:{k}" for k in table.meta}
    if engine.startswith("loop-"):
        table = solve_linkage_by("rscr", engine.split("-", 1)[1])
        return set(table.columns) | {"status"} | {f"meta:{k}" for k in table.meta}
    if engine.endswith(("-pinocchio", "-mujoco", "-mujoco-sim", "-exudyn")):
        kind, judge = engine.split("-", 1)
        table = solve_linkage_by(kind, judge)
        return set(table.columns) | {"status"} | {f"meta:{k}" for k in table.meta}
    if engine.endswith("-simulate"):
        sim = simulate_linkage(linkage_case(engine.split("-")[0]), 0.05, samples=3)
        return set(sim.columns()) | {"status"}
    if engine == "simulate":
        sim = fd.simulate(SMALL, 0.05, samples=3)
        return set(sim.columns()) | {f"info:{k}" for k in sim.info}
    if engine == "exudyn":  # it integrates through the angles: 60 degrees of them, not a turn
        table = run_engine(engine, SMALL.with_values({"motion.angles_deg": {"start": 0.0, "stop": 60.0,
                                                                            "step": 30.0}}))
    else:
        table = (slider_crank.to_table(slider_crank.analyze(SMALL)) if engine == "dualmech-numpy"
                 else run_engine(engine, SMALL))
    return set(table.columns) | {"status"} | {f"meta:{k}" for k in table.meta}


@pytest.mark.parametrize("engine", list(ORACLES))
def test_every_output_is_listed(engine: str) -> None:
    """The outputs an engine produces are exactly those listed with an oracle test."""
    got, listed = _outputs(engine), set(ORACLES[engine])
    assert got == listed, f"{engine}: not listed {sorted(got - listed)}, absent {sorted(listed - got)}"


def test_every_listed_test_exists() -> None:
    """Each listed oracle test is a test function of its file (a rename or removal fails here)."""
    defined: dict[str, set[str]] = {}
    for test in {t for outputs in ORACLES.values() for t in outputs.values()}:
        path, name = test.split("::")
        if path not in defined:
            tree = ast.parse((ROOT / path).read_text())
            defined[path] = {n.name for n in tree.body if isinstance(n, ast.FunctionDef)}
        assert name in defined[path], test


# ---------------------------------------------------------------------------------- the oracle tests


@pytest.mark.parametrize("engine", ["dualmech", "pinocchio", "mujoco", "mujoco-sim"])
def test_crank_columns_are_the_prescribed_motion(engine: str) -> None:
    """``theta1_deg`` and ``S1``: the case's angles and the axial law by hand, S1 = S1_0 + A sin(k theta1)
    (the simulation's S1 is where its axial servo holds the crank, within its lag)."""
    case = SMALL.with_values({"motion.axial_amplitude": 1.5, "motion.axial_cycles": 2.0})
    table = run_engine(engine, case)
    theta = np.arange(0.0, 360.0, 30.0)
    assert_allclose(table["theta1_deg"], theta, rtol=0, atol=1e-12)
    s1 = case.geometry.crank_axial_shift + 1.5 * np.sin(2.0 * np.radians(theta))
    tol = SIM_STROKE.value if engine == "mujoco-sim" else S4_VS_CLOSED_FORM  # the simulation: its servo's lag
    assert_allclose(table["S1"], s1, rtol=0, atol=tol * case.geometry.rod_length)


def _pose(case: Case, table: ResultTable) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Crank pin ``P2``, slider pin ``P3`` and the hub ``(0, 0, S1)`` of the table's columns, ``(n, 3)``."""
    g = case.geometry
    theta = np.radians(table["theta1_deg"])
    s1 = table["S1"]
    p2 = np.stack([g.crank_length * np.cos(theta), g.crank_length * np.sin(theta), s1], 1)
    foot, k4 = slider_line(g.slider_offset, np.radians(g.slider_twist_deg))
    p3 = foot - table["S4"][:, None] * k4
    return p2, p3, np.stack([0 * s1, 0 * s1, s1], 1)


@pytest.mark.parametrize("engine", ["dualmech", "dualmech-numpy", "pinocchio", "mujoco", "mujoco-sim"])
def test_transmission_and_residual_are_the_tables_own_pose(engine: str) -> None:
    """``transmission`` is ``z . ((P2 - hub) x u) / a1`` of the table's own pose, and ``residual`` bounds the
    pose's loop gap ``| |P3 - P2| - a2 | / a2`` (each engine's closure residual is over ``a2``; the
    simulation's crank and slider lag their commanded motion, within ``SIM_STROKE``)."""
    case = with_loads(SMALL, drive_torque=None, slider_force=50.0)
    table = (slider_crank.to_table(slider_crank.analyze(case)) if engine == "dualmech-numpy"
             else run_engine(engine, case))
    ok = table.status == "ok"
    assert ok.all()
    p2, p3, hub = _pose(case, table)
    a1, a2 = case.geometry.crank_length, case.geometry.rod_length
    u = (p3 - p2) / np.linalg.norm(p3 - p2, axis=1)[:, None]
    lag = SIM_STROKE.value if engine == "mujoco-sim" else 0.0  # its servos' lag and soft loop
    transmission = np.cross(p2 - hub, u)[:, 2] / a1
    assert_allclose(table["transmission"], transmission, rtol=0, atol=S4_VS_CLOSED_FORM + lag)
    gap = np.abs(np.linalg.norm(p3 - p2, axis=1) - a2) / a2
    assert np.all(gap <= table["residual"] + lag + S4_VS_CLOSED_FORM), (gap, table["residual"])


@pytest.mark.parametrize("engine", ["dualmech", "dualmech-numpy", "pinocchio", "mujoco", "mujoco-sim"])
def test_messages_count_the_closed_form_no_assembly_rows(engine: str) -> None:
    """a4 = 45 in (a1 = 12, a2 = 50): the rows where the rod cannot reach the slider line by the closed form
    (``tests/oracles.assembly_margin``) are the ones the message names: the in-house engines' ranges, the
    judges' counts."""
    case = SMALL.with_values({"geometry.slider_offset": 45.0, "geometry.crank_axial_shift": 0.0,
                              "motion.angles_deg": {"start": 0.0, "stop": 360.0, "step": 5.0}})
    table = (slider_crank.to_table(slider_crank.analyze(case)) if engine == "dualmech-numpy"
             else run_engine(engine, case))
    theta = table["theta1_deg"]
    cannot = assembly_margin(case, np.radians(theta)) < 0
    assert cannot.any() and not cannot.all()
    (message,) = [m for m in table.meta["messages"] if m.startswith("no_assembly")]
    if engine.startswith("dualmech"):
        assert format_angle_ranges(no_assembly_ranges(theta, cannot)) in message, message
    else:
        assert f"no_assembly: {cannot.sum()} positions" in message, message


def test_in_house_iterations_are_the_other_implementations() -> None:
    """On a grid coarser than ``WARM_SPAN`` (2 deg) every position starts cold in both in-house
    implementations, so their Newton iteration counts are the same, row by row; on a fine grid the compiled
    one starts warm and takes fewer, never more than the cold count."""
    coarse = SMALL.with_values({"motion.angles_deg": {"start": 0.0, "stop": 360.0, "step": 3.0}})
    for case in (coarse, coarse.with_values({"joints.rod_slider": "universal"})):
        numpy_table = slider_crank.to_table(slider_crank.analyze(case))
        np.testing.assert_array_equal(slider_crank_kernel.solve_case(case).meta["iterations"],
                                      numpy_table.meta["iterations"])
    fine = SMALL.with_values({"motion.angles_deg": {"start": 0.0, "stop": 360.0, "step": 0.5}})
    warm = slider_crank_kernel.solve_case(fine).meta["iterations"]
    cold = slider_crank.to_table(slider_crank.analyze(fine)).meta["iterations"]
    assert np.all(warm <= cold) and warm.sum() < cold.sum()


def test_simulation_info_is_what_ran(monkeypatch: pytest.MonkeyPatch) -> None:
    """``method``, ``rtol``, ``atol``: the arguments; ``nfev``: the right-hand-side calls counted by a wrapped
    equation of motion; ``message``: scipy's message of a finished integration; ``coefficients``,
    ``table_size``: a
    trigonometric table whose size the samples at ``2 pi j / size`` confirm (the interpolant reproduces them,
    equal to the direct coefficients there); ``interpolation_error``: a bound on the table's error against
    direct coefficients at random angles, and within the asked tolerance."""
    case = load_case("thesis/ideal")
    model = dc.coefficient_model(case, 1e-12)
    calls = []
    rhs = fd._EquationOfMotion.__call__

    def counted(self, t, y):
        calls.append(t)
        return rhs(self, t, y)

    monkeypatch.setattr(fd._EquationOfMotion, "__call__", counted)
    sim = fd.simulate(case, 0.2, samples=5, method="RK45", rtol=1e-9, atol=1e-10, model=model)
    info = sim.info
    assert (info["method"], info["rtol"], info["atol"]) == ("RK45", 1e-9, 1e-10)
    assert info["message"] == "The solver successfully reached the end of the integration interval."
    assert info["nfev"] == len(calls) - 5  # and one call a sample for the trajectory's accelerations
    sim = fd.simulate(case, 0.2, samples=5)
    info = sim.info
    assert info["coefficients"] == "table" and info["table_size"] == model.size
    n = info["table_size"]
    grid = 2 * np.pi * np.arange(n) / n
    direct = dc.coefficients(case, grid).stacked()
    scale = np.abs(direct).max(axis=1, keepdims=True)
    scale[scale == 0.0] = 1.0  # gravity's term of a case without gravity
    assert_allclose(model(grid) / scale, direct / scale, rtol=0, atol=1e-13)
    rng = np.random.default_rng(30)
    theta = rng.uniform(0.0, 2 * np.pi, 50)
    direct = dc.coefficients(case, theta).stacked()
    error = np.max(np.abs(model(theta) - direct) / scale)
    assert error <= info["interpolation_error"] + 1e-15 and info["interpolation_error"] <= 1e-12
