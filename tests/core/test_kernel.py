"""The compiled kernel against the batched numpy solver: one algorithm, two implementations.

Statuses must be identical row by row and every number agree to round-off: kinematics to
``KERNEL_VS_NUMPY_KINEMATICS``, reactions to ``KERNEL_VS_NUMPY_REACTIONS`` (both relative to
the case's scale, reactions condition-scaled by ``1/|t|`` in torque mode, exactly as the
validation compares engines), on every preset, on seeded random geometries, and near the
edges of assembly and the dead centres.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose, assert_array_equal

from dualmech.core.table import REACTION_COLUMNS, ResultTable
from dualmech.core.thresholds import JOINT_LOCK_CONDITION
from dualmech.models.case import Case, load_case, preset_names, with_loads
from dualmech.models.slider_crank import analysis as slider_crank
from dualmech.models.slider_crank import kernel as slider_crank_kernel
from dualmech.validation.compare import relative_differences
from tests.tolerances import (
    KERNEL_VS_NUMPY_AT_LIMIT,
    KERNEL_VS_NUMPY_KINEMATICS,
    KERNEL_VS_NUMPY_REACTIONS,
    NEWTON_EULER_ROUND_OFF,
)

KINEMATICS = ("S4", "S4_dot", "S4_ddot", "transmission")
BASE = load_case("a4-30-s1-3.5")


def _numpy_table(case: Case) -> ResultTable:
    """The batched numpy implementation of the same algorithm: the kernel's oracle."""
    return slider_crank.to_table(slider_crank.analyze(case))


def assert_kernel_agrees(case: Case) -> ResultTable:
    """Kernel and numpy solver on ``case``: identical statuses and NaN patterns, numbers to round-off."""
    ref, got = _numpy_table(case), slider_crank_kernel.solve_case(case)
    differ = np.flatnonzero(got.status != ref.status)
    assert differ.size == 0, (
        f"{case.name}: statuses differ at theta1 = {ref['theta1_deg'][differ][:5]}: "
        f"kernel {got.status[differ][:5]}, numpy {ref.status[differ][:5]}"
    )
    for name, col in ref.columns.items():
        assert np.array_equal(np.isnan(got[name]), np.isnan(col)), f"{case.name}: NaN pattern of {name}"
    g, m = case.geometry, case.motion
    floors = {
        "S4": g.rod_length,
        "S4_dot": g.crank_length * abs(m.speed),  # S4 may be constant: at least
        "S4_ddot": g.crank_length * (m.speed**2 + abs(m.accel)),
        "transmission": 1.0,
    }  # the crank pin's
    # near the edge of assembly the closure condition c amplifies round-off: S4 by 1/c, its rates by
    # 1/c^2 and 1/c^3, reactions by 1/c^3 (core/assembly.py); the differences are weighed by c^k
    c = np.where(np.isnan(ref["closure_condition"]), 1.0, ref["closure_condition"])
    limit = ref.status == "assembly_limit"  # S4 only, where even c^k does not bound it (sqrt(r) at c = 0)
    assert_allclose(got["S4"][limit], ref["S4"][limit], rtol=0, atol=KERNEL_VS_NUMPY_AT_LIMIT * g.rod_length)
    for q, k in zip(KINEMATICS, (1, 2, 3, 1)):
        scale = max(np.nanmax(np.abs(ref[q]), initial=0.0), floors[q])
        weighed = np.abs(got[q] - ref[q])[~limit] * c[~limit] ** k / scale
        assert_allclose(
            weighed[~np.isnan(weighed)],
            0.0,
            rtol=0,
            atol=KERNEL_VS_NUMPY_KINEMATICS,
            err_msg=f"{case.name}: {q}",
        )
    mode = "torque" if case.loads.drive_torque is not None else "force"
    for q, r in relative_differences(ref, got, mode, REACTION_COLUMNS).items():
        weighed = r * c**3
        assert_allclose(
            weighed[~np.isnan(weighed)],
            0.0,
            rtol=0,
            atol=KERNEL_VS_NUMPY_REACTIONS,
            err_msg=f"{case.name}: {q}",
        )
    assert got.meta["messages"] == ref.meta["messages"]
    ok = ref.status == "ok"  # both give the reactions, and so their Newton-Euler residual, there
    assert_allclose(got.meta["dynamics_residual"][ok], ref.meta["dynamics_residual"][ok], rtol=0,
                    atol=NEWTON_EULER_ROUND_OFF, err_msg=f"{case.name}: dynamics_residual")
    for q in ("S1", "theta1_deg"):
        assert_allclose(got[q], ref[q], rtol=0, atol=KERNEL_VS_NUMPY_KINEMATICS, equal_nan=True, err_msg=q)
    # c itself is as well conditioned as S4 away from the edge; at c ~ 0 it carries sqrt(r) like S4
    assert_allclose(
        got["closure_condition"],
        ref["closure_condition"],
        rtol=0,
        atol=KERNEL_VS_NUMPY_AT_LIMIT,
        equal_nan=True,
        err_msg="closure_condition",
    )
    return got


@pytest.mark.parametrize("name", preset_names())
def test_every_preset(name: str) -> None:
    assert_kernel_agrees(load_case(name))


@pytest.mark.parametrize("name", ["thesis/a4-30-s1-3.5", "thesis/a4-20-alpha-232", "thesis/ideal"])
def test_universal_joint_at_the_slider(name: str) -> None:
    """The rod's spin set by a universal joint: the kernel's own code path (core.universal's twin)."""
    case = load_case(name).with_values({"joints.rod_slider": "universal"})
    table = assert_kernel_agrees(case)
    assert np.nanmax(np.abs(table["j3_mx"])) > 0.0 or case.is_planar


@pytest.mark.parametrize("twist", [185.0, 199.0, 270.0])
@pytest.mark.parametrize("torque_mode", [False, True])
def test_universal_joint_lock(twist: float, torque_mode: bool) -> None:
    """a4 = a1: at theta1 = 180 deg the crank pin lies on the slider line and the rod along it (the CI
    failure of a seed at twist 185/199 deg: an unflagged singular row, decided by round-off). Both
    implementations flag ``joint_lock`` there and only within the band, the pose given (the band
    spans 0.6 deg of crank angle at twist 185, 33 deg in the plane, where the pin runs along the line)."""
    case = BASE.with_values({
        "geometry.slider_offset": 12.0, "geometry.slider_twist_deg": twist, "geometry.crank_axial_shift": 0.0,
        "motion.angles_deg": {"start": 150.0, "stop": 210.0, "step": 0.25}, "joints.rod_slider": "universal"})
    loads = {"drive_torque": 100.0, "slider_force": None} if torque_mode else {}
    table = assert_kernel_agrees(with_loads(case, **loads) if loads else case)
    lock = table.status == "joint_lock"
    assert lock[np.flatnonzero(table["theta1_deg"] == 180.0)].all()
    assert_array_equal(lock, table["closure_condition"] >= JOINT_LOCK_CONDITION.value)
    assert np.isfinite(table["S4"][lock]).all() and np.isnan(table["S4_dot"][lock]).all()
    assert not lock.all()


@settings(max_examples=30, deadline=None, derandomize=True)
@given(
    a4=st.floats(-25.0, 45.0),
    twist=st.one_of(
        st.floats(185.0, 355.0), st.floats(5.0, 175.0), st.sampled_from([181.0, 359.0, 0.0, 180.0])
    ),
    s1=st.floats(-12.0, 12.0),
    amp=st.floats(0.0, 6.0),
    cycles=st.sampled_from([0.0, 1.0, 2.0, 3.0]),
    torque_mode=st.booleans(),
    rod_slider=st.sampled_from(["ball", "universal"]),
)
def test_random_geometries(
    a4: float, twist: float, s1: float, amp: float, cycles: float, torque_mode: bool, rod_slider: str
) -> None:
    """Both twist signs, near 180/360 degrees, offsets leaving some angles unassemblable, both load modes,
    both joints at the slider."""
    case = BASE.with_values(
        {
            "geometry.slider_offset": a4,
            "geometry.slider_twist_deg": twist,
            "geometry.crank_axial_shift": s1,
            "motion.axial_amplitude": amp,
            "motion.axial_cycles": cycles,
            "motion.angles_deg": {"start": 0.0, "stop": 360.0, "step": 3.0},
            "joints.rod_slider": rod_slider,
        }
    )
    loads = (
        {"drive_torque": 100.0, "slider_force": None}
        if torque_mode
        else {"drive_torque": None, "slider_force": 250.0}
    )
    assert_kernel_agrees(with_loads(case, **loads))


@pytest.mark.parametrize("offset", [38.0 - 1e-9, 38.0, 38.0 + 1e-9, 38.0 - 1e-4, 38.0 + 1e-3])
def test_near_the_edge_of_assembly(offset: float) -> None:
    """a1 + a4 = a2 at theta1 = 0 (planar): the rod turns normal to the slider line there."""
    case = BASE.with_values(
        {
            "geometry.slider_offset": offset,
            "geometry.slider_twist_deg": 270.0,
            "geometry.crank_axial_shift": 0.0,
            "motion.angles_deg": {"start": -2.0, "stop": 2.0, "step": 0.01},
        }
    )
    got = assert_kernel_agrees(case)
    assert {"assembly_limit"} <= set(got.status) or offset > 38.0, "the band around the edge was not reached"


def test_near_dead_centres() -> None:
    """The ideal slider crank in torque mode, crank angles within 1e-7 degrees of its dead centres."""
    ideal = with_loads(load_case("ideal"), drive_torque=100.0, slider_force=None)
    words = set()
    for centre in (90.0, 270.0):
        case = ideal.with_values(
            {"motion.angles_deg": {"start": centre - 1e-6, "stop": centre + 1e-6, "step": 1e-7}}
        )
        words |= set(assert_kernel_agrees(case).status)
    assert {"dead_centre", "ok"} <= words


def test_many_cases_in_one_chunk_equal_one_at_a_time() -> None:
    """Positions of different cases share a chunk (and threads) without mixing their geometry."""
    rng = np.random.default_rng(7)
    cases = [
        BASE.with_values(
            {
                "geometry.slider_offset": float(rng.uniform(0, 30)),
                "geometry.slider_twist_deg": float(rng.uniform(240, 300)),
                "motion.angles_deg": {"start": 0.0, "stop": 360.0, "step": 0.5},
            }
        )
        for _ in range(6)
    ]
    cranks = [c.own_crank_states() for c in cases]
    together = slider_crank_kernel.analyze_chunk(cases, cranks)
    start = 0
    for case in cases:
        alone = slider_crank_kernel.solve_case(case)
        n = len(alone)
        for name, col in alone.columns.items():
            assert_allclose(together.columns[name][start : start + n], col, rtol=0, atol=0, equal_nan=True)
        start += n


def test_many_cases_in_chunks_are_each_case_alone() -> None:
    """``solve_cases`` (chunks of several cases, their columns copied once and shared by their tables) gives
    every case's table bit for bit as ``solve_case`` alone: the same columns, statuses and messages."""
    cases = [BASE.with_values({"geometry.slider_offset": a4, "geometry.crank_axial_shift": s1,
                               "motion.angles_deg": {"start": 0.0, "stop": 360.0, "step": step}})
             for a4, s1, step in [(0.0, 0.0, 7.0), (38.5, 1.0, 5.0), (20.0, -3.0, 3.0), (45.0, 2.0, 11.0),
                                  (10.0, 9.0, 2.0)]]
    many = slider_crank_kernel.solve_cases(cases, chunk_positions=150)
    for case, got in zip(cases, many, strict=True):
        alone = slider_crank_kernel.solve_case(case)
        assert got.case == alone.case and got.meta["messages"] == alone.meta["messages"]
        assert_array_equal(got.status, alone.status)
        for name in alone.columns:
            assert_array_equal(got[name], alone[name], err_msg=name)


def test_cases_at_given_crank_states_are_the_numpy_solver_there() -> None:
    """``solve_cases(..., cranks=)`` (the dead-centre bisection and the stroke's Newton in
    models/slider_crank/stroke.py):
    each case at its own scattered crank states (no grid: the warm starts meet arbitrary steps), unit speed,
    as the numpy solver gives them there, statuses identical; the case's own motion would be a fault."""
    from dualmech.core.motion import CrankState

    rng = np.random.default_rng(7)
    cases = [BASE.with_values({"geometry.slider_offset": a4, "geometry.crank_axial_shift": s1})
             for a4, s1 in [(0.0, 0.0), (30.0, 3.5), (38.5, 1.0)]]
    cranks = []
    for n in (5, 40, 17):
        theta = np.sort(rng.uniform(0.0, 2.0 * np.pi, n))
        cranks.append(CrankState(theta, np.full(n, 1.0), np.ones(n), np.zeros(n), np.zeros(n), np.zeros(n)))
    tables = slider_crank_kernel.solve_cases(cases, cranks=cranks)
    for case, crank, got in zip(cases, cranks, tables, strict=True):
        ref = slider_crank.to_table(slider_crank.analyze(case, crank))
        assert_array_equal(got.status, ref.status)
        assert_allclose(got["theta1_deg"], np.degrees(crank.theta), rtol=1e-15)
        for name in ("S4", "S4_dot", "S4_ddot", "transmission"):
            assert_allclose(got[name], ref[name], rtol=0, atol=KERNEL_VS_NUMPY_KINEMATICS * np.nanmax(np.abs(
                ref[name])), equal_nan=True, err_msg=name)


@pytest.mark.parametrize("values, window, direct", [
    ({}, (0.0, 2.0), 0.9),
    ({"geometry.slider_offset": 38.5, "geometry.crank_axial_shift": 1.0}, (15.5, 17.5), 0.0),  # an edge
    ({"joints.rod_slider": "universal"}, (100.0, 102.0), 0.9),
    ({"geometry.slider_offset": 10.0, "geometry.crank_axial_shift": 2.0, "geometry.slider_twist_deg": 250.0,
      "motion.crank_accel": 40.0, "motion.axial_amplitude": 1.5, "motion.axial_cycles": 2.0,
      "loads.gravity": [0.0, -386.4, 0.0]}, (40.0, 42.0), 0.9),  # the selftest matrix's: S1 law, crank accel
])
def test_fine_grids_start_closed_from_a_second_order_prediction(values: dict, window: tuple,
                                                                direct: float) -> None:
    """Why: on a grid of 10^6 positions a revolution each position took one Newton step (two loop
    evaluations and a factorization more than needed); the prediction to second order in the crank angle
    from the previous position's rates (slider_crank_nb.FINE_SPAN) is already closed there. Same answers
    and statuses as the numpy solver, which starts every position cold, also at an edge of assembly (where
    the rates grow without bound and Newton still steps); elsewhere a fraction ``direct`` of the positions
    take no Newton step (a first-order start is seen taking one everywhere, a second order in time instead
    of in the angle too where the crank accelerates)."""
    case = BASE.with_values({**values, "motion.angles_deg": {"start": window[0], "stop": window[1],
                                                             "step": 1e-4}})
    got = assert_kernel_agrees(case)
    steps = got.meta["iterations"][got.status == "ok"]
    assert np.mean(steps == 0) >= direct, np.bincount(steps)
