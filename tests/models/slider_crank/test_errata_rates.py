"""Errata E4-E7 of docs/errata.md, the velocity and acceleration analysis (thesis sections 2.7-2.8): the
velocity equations (37)-(43), the accelerations (38a)-(42a), the joint-rate vectors (30)-(31) and (28a),
each evaluated against exact rates (8th-order differences of the exact closed position) or the in-house
solver.  A test fails if our claim about the printed text were wrong.

Transcriptions of the printed equations and the independent oracles are in
``tests/models/slider_crank/thesis_oracles.py``.
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from dualmech.models.case import load_case
from dualmech.models.slider_crank.analysis import analyze
from tests.models.slider_crank import thesis_oracles as th
from tests.models.slider_crank.errata_example import GRID, PLANAR, SPATIAL_S1, SPATIAL_TWIST, W1, ry, rz, vee
from tests.tolerances import (
    COMPLEX_STEP,
    ERRATA_ROUND_OFF,
    HIGH_ORDER_DIFFERENCE,
    PRINTED_IS_WRONG,
)


def _away_from_dead_centres(q: np.ndarray) -> np.ndarray:
    """The printed (41), (42), (40a), (41a) divide by sin(theta2), zero at the dead centres."""
    return np.abs(np.sin(q[:, 0])) > 0.05


# ============================================================================ E4 velocity analysis (37)-(43)


def _rates(shape):
    q, d1, d2 = th.angle_derivatives(shape, GRID)
    return q, d1 * W1, d2 * W1**2


@pytest.mark.parametrize("shape", [PLANAR, SPATIAL_S1, SPATIAL_TWIST])
def test_e4_slider_rate_43_is_exact(shape):
    q, qd, _ = _rates(shape)
    a1 = shape[1]
    printed = th.printed_rates(q, W1, 0.0, a1, shape[2])[:, 4]
    assert_allclose(printed, qd[:, 4], rtol=0, atol=HIGH_ORDER_DIFFERENCE * a1 * W1)


def test_e4_joint_rates_39_42_hold_only_in_the_planar_case():
    q, qd, _ = _rates(PLANAR)
    ok = _away_from_dead_centres(q)
    assert_allclose(
        th.printed_rates(q, W1, 0.0, 12.0, 50.0)[ok, :4], qd[ok, :4], rtol=0, atol=HIGH_ORDER_DIFFERENCE * W1
    )
    for shape, floors in ((SPATIAL_S1, [1e-3, 0.1, 1e-3, 0.1]), (SPATIAL_TWIST, [0.05, 1.0, 0.02, 1.0])):
        q, qd, _ = _rates(shape)
        ok = _away_from_dead_centres(q)
        err = np.abs(th.printed_rates(q, W1, 0.0, 12.0, 50.0)[ok, :4] - qd[ok, :4]).max(0) / W1
        assert np.all(err > floors), err  # measured (1.9e-3, 0.31, 3.2e-3, 0.31) and (0.16, 2.9, 0.054, 2.8)


def test_e4_system_38_row_6_contradicts_37f():
    """Printed (38) row 6 right side is -th1d a1 s(th2) - S1d c(eta2).

    (37f) says -th1d a1 s(th2) s(eta2) - ...
    """
    q, qd, _ = _rates(PLANAR)
    a, b = th.system38(q, W1, 0.0, 12.0, 50.0)
    x = qd[:, [0, 2, 1, 3, 4]]
    r = np.einsum("nij,nj->ni", a, x) - b
    assert_allclose(r[:, :5], 0.0, rtol=0, atol=HIGH_ORDER_DIFFERENCE * 12 * W1)
    assert_allclose(r[:, 5], W1 * 12.0 * np.sin(q[:, 0]), rtol=0, atol=HIGH_ORDER_DIFFERENCE * 12 * W1)
    assert_allclose(
        th.eq37_residuals(q, qd, W1, 0.0, 12.0, 50.0), 0.0, rtol=0, atol=HIGH_ORDER_DIFFERENCE * 50 * W1
    )
    # the least-squares solution of the printed 6x5 system invents eta rates in a planar mechanism
    sol = np.linalg.lstsq(a[20], b[20], rcond=None)[0]
    assert abs(sol[2]) > 1.0  # measured -6.06 rad/s where eta2_dot = 0


@pytest.mark.parametrize("shape", [SPATIAL_S1, SPATIAL_TWIST])
def test_e4_equations_37_fail_in_spatial_cases(shape):
    q, qd, _ = _rates(shape)
    r = np.abs(th.eq37_residuals(q, qd, W1, 0.0, 12.0, 50.0)).max(0)
    scale = np.array([W1, 12 * W1, W1, 12 * W1, W1, 12 * W1])
    assert r[1] < HIGH_ORDER_DIFFERENCE * scale[1]  # (37b): the rod's length rate, right
    # the rest: measured >= 2e-3 (S1 = 3.5), >= 0.16 (alpha4 = 232)
    assert np.all(np.delete(r / scale, 1) > PRINTED_IS_WRONG)


# ============================================================================ E5 accelerations (38a)-(42a)


@pytest.mark.parametrize("shape", [PLANAR, SPATIAL_S1, SPATIAL_TWIST])
def test_e5_slider_acceleration_42a_is_the_derivative_of_43(shape):
    q, qd, qdd = _rates(shape)
    printed = th.printed_accels(q, qd, W1, 0.0, 0.0, 0.0, 12.0, 50.0)[:, 4]
    assert_allclose(printed, qdd[:, 4], rtol=0, atol=HIGH_ORDER_DIFFERENCE * 12 * W1**2)


def test_e5_joint_accelerations_hold_only_in_the_planar_case():
    q, qd, qdd = _rates(PLANAR)
    ok = _away_from_dead_centres(q)
    printed = th.printed_accels(q, qd, W1, 0.0, 0.0, 0.0, 12.0, 50.0)
    assert_allclose(printed[ok, :4], qdd[ok, :4], rtol=0, atol=HIGH_ORDER_DIFFERENCE * W1**2)
    q, qd, qdd = _rates(SPATIAL_TWIST)
    ok = _away_from_dead_centres(q)
    err = np.abs(th.printed_accels(q, qd, W1, 0.0, 0.0, 0.0, 12.0, 50.0)[ok, :4] - qdd[ok, :4]).max(0) / W1**2
    assert np.all(err > [0.05, 1.0, 0.05, 1.0]), err  # measured (0.18, 68, 0.13, 68)


def test_e5_thesis_pipeline_gets_the_slider_acceleration_wrong_in_spatial_cases():
    """(42a) is exact given exact rates, but the thesis feeds it the rates of (39)-(42)."""
    case = load_case("a4-20-alpha-232").with_values(
        {"motion.angles_deg": {"start": 0.0, "stop": 360.0, "step": 2.0}}
    )
    an = analyze(case)
    kin = th.kinematics(case, an.crank.theta)
    assert_allclose(an.rates.q_ddot[:, 0], kin["S4dd"], rtol=0, atol=HIGH_ORDER_DIFFERENCE * 12 * W1**2)
    q = th.thesis_angles(an.crank.theta, *SPATIAL_TWIST)
    pipeline = th.printed_accels(q, th.printed_rates(q, W1, 0.0, 12.0, 50.0), W1, 0.0, 0.0, 0.0, 12.0, 50.0)[
        :, 4
    ]
    ok = _away_from_dead_centres(q)
    assert np.abs(pipeline - an.rates.q_ddot[:, 0])[ok].max() > 0.1 * 12 * W1**2  # measured 0.24
    q = th.thesis_angles(an.crank.theta, *PLANAR)
    kin = th.kinematics(load_case("a4-20-alpha-232").with_values({
        "geometry.slider_offset": 30.0, "geometry.slider_twist_deg": 270.0,
        "motion.angles_deg": {"start": 0.0, "stop": 360.0, "step": 2.0}}), an.crank.theta)
    pipeline = th.printed_accels(q, th.printed_rates(q, W1, 0.0, 12.0, 50.0), W1, 0.0, 0.0, 0.0, 12.0, 50.0)[
        :, 4
    ]
    assert_allclose(pipeline, kin["S4dd"], rtol=0, atol=ERRATA_ROUND_OFF * 1e3 * 12 * W1**2)


# ============================================================================ E6 joint-rate vectors (30)-(31)


def _relative_angular_velocity(shape, joint):
    """vee(dL/dt L^T) of the Z-Y part of eq. (2) (joint 2) or (3) (joint 3), by finite differences."""
    i = 0 if joint == 2 else 2

    def flat(t):
        q = th.thesis_angles(t, *shape)
        return (rz(q[:, i]) @ ry(q[:, i + 1])).reshape(-1, 9)
    mat, dmat, _ = th.derivatives(flat, GRID)
    mat, dmat = mat.reshape(-1, 3, 3), dmat.reshape(-1, 3, 3) * W1
    return vee(dmat @ np.swapaxes(mat, 1, 2))


def test_e6_printed_joint_rates_30_31_miss_the_turned_eta_axis():
    q, qd, _ = _rates(SPATIAL_TWIST)
    for joint, i in ((2, 0), (3, 2)):
        exact = _relative_angular_velocity(SPATIAL_TWIST, joint)
        zero = np.zeros_like(q[:, i])
        printed = np.stack([zero, qd[:, i + 1], qd[:, i]], -1)
        corrected = np.stack([-qd[:, i + 1] * np.sin(q[:, i]), qd[:, i + 1] * np.cos(q[:, i]), qd[:, i]], -1)
        assert_allclose(corrected, exact, rtol=0, atol=HIGH_ORDER_DIFFERENCE * W1)
        assert np.abs(printed - exact).max() > 0.2 * W1  # measured 0.25 (joint 2) and 1.07 (joint 3)


def test_e6_zy_rod_velocity_without_its_spin_is_the_in_house_rod_velocity():
    case = load_case("a4-20-alpha-232").with_values(
        {"motion.angles_deg": {"start": 0.0, "stop": 360.0, "step": 2.0}}
    )
    an = analyze(case)
    q, qd, _ = _rates(SPATIAL_TWIST)
    rel = np.stack([-qd[:, 1] * np.sin(q[:, 0]), qd[:, 1] * np.cos(q[:, 0]), qd[:, 0]], -1)
    omega = np.einsum("nij,nj->ni", rz(GRID), rel) + np.array([0, 0, W1])
    u = (an.p3 - an.p2) / 50.0
    perp = omega - np.einsum("ni,ni->n", omega, u)[:, None] * u
    assert_allclose(perp, an.motions[1].omega, rtol=0, atol=HIGH_ORDER_DIFFERENCE * W1)


# ============================================================================ E7 eq. (28a)


def test_e7_28a_prints_s1_for_the_amplitude():
    amp, alpha, w, wd = 2.0, 2.0, 3.0, 0.7
    th1 = np.linspace(0.1, 6.0, 25)
    h = 1e-30
    s1_of_t = lambda t: amp * np.sin(alpha * (th1 + w * t + 0.5 * wd * t**2))  # noqa: E731  eq. (28)
    exact = s1_of_t(1j * h).imag / h
    printed = alpha * s1_of_t(0.0) * np.cos(alpha * th1) * w
    corrected = alpha * amp * np.cos(alpha * th1) * w
    assert_allclose(corrected, exact, rtol=0, atol=COMPLEX_STEP * amp * alpha * w)
    assert np.abs(printed - exact).max() > 1.0
    motion = load_case("ideal").with_values({"motion.axial_amplitude": amp, "motion.axial_cycles": alpha,
                                             "motion.crank_accel": wd}).motion
    state = motion.state(0.0, np.degrees(th1))
    speed = motion.speed
    assert_allclose(
        state.s_dot,
        alpha * amp * np.cos(alpha * th1) * speed,
        rtol=0,
        atol=COMPLEX_STEP * amp * alpha * speed,
    )
    dd = amp * alpha * (np.cos(alpha * th1) * wd - alpha * np.sin(alpha * th1) * speed**2)  # (28b), right
    assert_allclose(state.s_ddot, dd, rtol=0, atol=COMPLEX_STEP * amp * alpha**2 * speed**2)
