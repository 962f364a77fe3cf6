"""Each numerically checkable erratum of docs/errata.md: the printed equation, evaluated, against an
independent computation.  A test fails if our claim about the printed text were wrong (the printed form
would then pass where we say it fails, or the correction would fail where we say it holds).

Transcriptions of the printed equations and the independent oracles are in ``tests/models/thesis_oracles.py``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.optimize import least_squares as scipy_least_squares

from dualmech.core.dual import Dual, rot_x, rot_y, rot_z
from dualmech.models.case import load_case
from dualmech.models.slider_crank import analyze
from tests.models import thesis_oracles as th
from tests.tolerances import (
    COMPLEX_STEP,
    ERRATA_ROUND_OFF,
    HIGH_ORDER_DIFFERENCE,
    PRINTED_IS_WRONG,
)

W1 = 2 * math.pi * 50 / 60  # thesis example: 50 rpm
PLANAR = (0.0, 12.0, 50.0, 30.0, math.radians(270.0))  # (S1, a1, a2, a4, alpha4)
SPATIAL_S1 = (3.5, 12.0, 50.0, 30.0, math.radians(270.0))
SPATIAL_TWIST = (0.0, 12.0, 50.0, 20.0, math.radians(232.0))
GRID = np.radians(np.arange(0.0, 360.0, 2.0))


def _away_from_dead_centres(q: np.ndarray) -> np.ndarray:
    """The printed (41), (42), (40a), (41a) divide by sin(theta2), zero at the dead centres."""
    return np.abs(np.sin(q[:, 0])) > 0.05


# ============================================================================ E1 matrices (1)-(4)


def test_e1_printed_matrices_place_p2_and_p3():
    rng = np.random.default_rng(1)
    for _ in range(20):
        th1, s1, a1 = rng.uniform(-3, 3), rng.uniform(-5, 5), rng.uniform(1, 20)
        a4, s4 = rng.uniform(-30, 30), rng.uniform(-60, 60)
        al4 = rng.uniform(0, 2 * math.pi)
        assert_allclose(th.frame_origin(th.m1(th1, s1, a1)), [a1 * math.cos(th1), a1 * math.sin(th1), s1],
                        rtol=0, atol=ERRATA_ROUND_OFF * 60)
        m4 = th.m4(s4, al4, a4)
        p3 = -m4[0].T @ th.frame_origin(m4)  # origin of {4} in {1}: M4 maps {1} into {4}
        assert_allclose(p3, np.array([-a4, 0, 0]) - s4 * np.array([0, math.sin(al4), math.cos(al4)]),
                        rtol=0, atol=ERRATA_ROUND_OFF * 60)
        for mat in (th.m1(th1, s1, a1), th.l2(th1, s1, a1), th.l3(th1, s1), m4):
            assert_allclose(mat[0].T @ mat[0], np.eye(3), rtol=0, atol=ERRATA_ROUND_OFF)
            skew = mat[0].T @ mat[1]  # a dual rotation R + eps [p]x R has R^T D skew-symmetric
            assert_allclose(skew + skew.T, 0.0, rtol=0, atol=ERRATA_ROUND_OFF * 60)


def test_e1_printed_matrices_are_the_dual_rotation_products():
    """(1)-(4) equal Z(th + eps S) Y(eta) X(alpha + eps a) built with the in-house dual algebra."""
    rng = np.random.default_rng(2)
    for _ in range(10):
        scale = [1, 3, 5, 1, 1, 20, 1, 1, 20, 1, 10]
        t1, s1, a1, t2, e2, a2, t3, e3, s4, al4, a4 = rng.uniform(-3, 3, 11) * scale

        def dual(th_, s_=0.0):
            return Dual.of(np.array([th_]), np.array([s_]))
        cases = [
            (th.m1(t1, s1, a1), rot_z(dual(t1, s1)) @ rot_x(dual(0.0, a1))),
            (th.l2(t2, e2, a2), rot_z(dual(t2)) @ rot_y(dual(e2)) @ rot_x(dual(0.0, a2))),
            (th.l3(t3, e3), rot_z(dual(t3)) @ rot_y(dual(e3)) @ rot_x(dual(math.pi / 2))),
            (th.m4(s4, al4, a4), rot_z(dual(0.0, s4)) @ rot_x(dual(al4, a4))),
        ]
        for printed, built in cases:
            assert_allclose(printed[0], built.re[0], rtol=0, atol=ERRATA_ROUND_OFF * 20)
            assert_allclose(printed[1], built.du[0], rtol=0, atol=ERRATA_ROUND_OFF * 20)


def test_e1_printed_derivatives_and_operators_are_right():
    """Section 2.5: the printed partial derivatives equal complex-step derivatives and Q times the matrix."""
    rng = np.random.default_rng(3)
    h = 1e-30
    for _ in range(10):
        t2, e2, t3, e3, s4, al4 = rng.uniform(-3, 3, 6)
        a2, a4 = 50.0, rng.uniform(-30, 30)

        def cs(f):
            val = f(1j * h)
            return val[0].imag / h, val[1].imag / h
        pairs = [
            (
                th.dl2_dth2(t2, e2, a2),
                cs(lambda d: th.l2(t2 + d, e2, a2)),
                th.dmul(th.q_theta(), th.l2(t2, e2, a2)),
            ),
            (
                th.dl2_det2(t2, e2, a2),
                cs(lambda d: th.l2(t2, e2 + d, a2)),
                th.dmul(th.q_eta(t2), th.l2(t2, e2, a2)),
            ),
            (th.dl3_dth3(t3, e3), cs(lambda d: th.l3(t3 + d, e3)), th.dmul(th.q_theta(), th.l3(t3, e3))),
            (th.dl3_det3(t3, e3), cs(lambda d: th.l3(t3, e3 + d)), th.dmul(th.q_eta(t3), th.l3(t3, e3))),
            (th.dm4_ds4(al4), cs(lambda d: th.m4(s4 + d, al4, a4)), th.dmul(th.q_s(), th.m4(s4, al4, a4))),
        ]
        for printed, exact, operator in pairs:
            for part in (0, 1):
                assert_allclose(printed[part], exact[part], rtol=0, atol=COMPLEX_STEP * a2)
                assert_allclose(operator[part], exact[part], rtol=0, atol=COMPLEX_STEP * a2)


# ======================================================================== E2 five Z-Y unknowns, E13 eq. (23a)


def _min_closure(geom, starts):
    best = np.inf
    for x0 in starts:
        sol = scipy_least_squares(th.closure_residual, x0, args=geom, xtol=1e-15, ftol=1e-15, gtol=1e-15)
        best = min(best, float(np.linalg.norm(sol.fun)))
    return best


@pytest.mark.parametrize("shape, floor", [(SPATIAL_S1, 0.03), (SPATIAL_TWIST, 0.1)])
def test_e2_zy_unknowns_cannot_close_a_spatial_loop(shape, floor):
    rng = np.random.default_rng(4)
    th1 = math.radians(40.0)
    geom = (th1,) + shape
    x_exact = th.thesis_angles(th1, *shape)[0]
    starts = [x_exact] + [x_exact + rng.normal(size=5) * [0.3, 0.3, 0.3, 0.3, 3.0] for _ in range(7)]
    assert _min_closure(geom, starts) > floor  # global minima (300 starts) 0.0603 and 0.227 of |B - I|
    planar = (th1,) + PLANAR
    assert _min_closure(planar, [th.thesis_angles(th1, *PLANAR)[0]]) < ERRATA_ROUND_OFF


def test_e2_printed_newton_stalls_off_the_mechanism_in_spatial_cases():
    th1 = math.radians(40.0)
    for shape, s4_err in ((SPATIAL_S1, 0.1), (SPATIAL_TWIST, 1.0)):
        x_exact = th.thesis_angles(th1, *shape)[0]
        x, hist = th.thesis_newton(x_exact, (th1,) + shape, 200)
        assert hist[-1] > 0.05 and abs(hist[-1] - hist[-50]) < 1e-9 * hist[-1]  # stalled, not closed
        assert abs(x[4] - x_exact[4]) > s4_err  # measured 0.259 and 3.27 in
    x, hist = th.thesis_newton(
        th.thesis_angles(th1, *PLANAR)[0] + [0.2, 0.1, -0.2, 0.1, 2.0], (th1,) + PLANAR, 6
    )
    assert hist[4] < ERRATA_ROUND_OFF


# ========================================================================= E3 the diagonal device of eq. (22)


def test_e3_diagonal_terms_exclude_rotation_by_pi_roots():
    geom = (math.radians(40.0),) + PLANAR

    def eqs_20_21(x):
        b = th.loop_product(x, *geom)
        return np.array(
            [b[0][1, 0], b[0][2, 0], b[0][2, 1], b[1][1, 0] / 50, b[1][2, 0] / 50, b[1][2, 1] / 50]
        )

    sol = scipy_least_squares(
        eqs_20_21, [1.77, 0.0, 0.67, math.pi, -38.76], xtol=1e-15, ftol=1e-15, gtol=1e-15
    )
    assert np.linalg.norm(sol.fun) < ERRATA_ROUND_OFF  # a root of (20)-(21) ...
    b = th.loop_product(sol.x, *geom)
    # ... that is a rotation by pi, not closure
    assert_allclose(np.diag(b[0]), [1, -1, -1], rtol=0, atol=1e-9)
    _, v22 = th.newton_system(sol.x, *geom, diagonal=True)
    assert np.linalg.norm(v22) > 1.0  # (22) does not vanish there (measured 4.9)
    _, v_true = th.newton_system(th.thesis_angles(geom[0], *PLANAR)[0], *geom, diagonal=True)
    assert np.linalg.norm(v_true) < ERRATA_ROUND_OFF  # and is harmless at the true root


def test_e3_device_keeps_quadratic_convergence():
    geom = (math.radians(40.0),) + PLANAR
    x0 = th.thesis_angles(geom[0], *PLANAR)[0] + [0.2, 0.1, -0.2, 0.1, 2.0]
    for diagonal in (True, False):
        _, hist = th.thesis_newton(x0, geom, 5, diagonal=diagonal)
        assert hist[2] < 1e-5 and hist[3] < 1e-10  # measured 2e-6, 3e-12: error squares each step


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


def _rz(t):
    c, s = np.cos(t), np.sin(t)
    out = np.zeros(t.shape + (3, 3))
    out[..., 0, 0], out[..., 0, 1], out[..., 1, 0], out[..., 1, 1], out[..., 2, 2] = c, -s, s, c, 1
    return out


def _ry(t):
    c, s = np.cos(t), np.sin(t)
    out = np.zeros(t.shape + (3, 3))
    out[..., 0, 0], out[..., 0, 2], out[..., 2, 0], out[..., 2, 2], out[..., 1, 1] = c, s, -s, c, 1
    return out


def _vee(m):
    return 0.5 * np.stack(
        [m[..., 2, 1] - m[..., 1, 2], m[..., 0, 2] - m[..., 2, 0], m[..., 1, 0] - m[..., 0, 1]], -1
    )


def _relative_angular_velocity(shape, joint):
    """vee(dL/dt L^T) of the Z-Y part of eq. (2) (joint 2) or (3) (joint 3), by finite differences."""
    i = 0 if joint == 2 else 2

    def flat(t):
        q = th.thesis_angles(t, *shape)
        return (_rz(q[:, i]) @ _ry(q[:, i + 1])).reshape(-1, 9)
    mat, dmat, _ = th.derivatives(flat, GRID)
    mat, dmat = mat.reshape(-1, 3, 3), dmat.reshape(-1, 3, 3) * W1
    return _vee(dmat @ np.swapaxes(mat, 1, 2))


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
    omega = np.einsum("nij,nj->ni", _rz(GRID), rel) + np.array([0, 0, W1])
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


# ============================================================================ E8 inertia binors (46)-(53)


def _binor(m, g, k2):
    """Printed (46)-(48): m [[S^T/m, I], [diag(K^2), S/m]] with first moment S = m [g i]_x."""
    top = np.hstack([np.array([[0, 0, 0], [0, 0, g], [0, -g, 0]]), np.eye(3)])
    bottom = np.hstack([np.diag(k2), np.array([[0, 0, 0], [0, 0, -g], [0, g, 0]])])
    return m * np.vstack([top, bottom])


def test_e8_binor_structure_is_momentum_about_the_frame_origin():
    rng = np.random.default_rng(8)
    for _ in range(10):
        m, g = rng.uniform(0.1, 2), rng.uniform(-10, 10)
        k2 = rng.uniform(1, 50, 3)
        omega, v_o = rng.normal(size=3), rng.normal(size=3)
        gvec = np.array([g, 0, 0])
        h = _binor(m, g, k2) @ np.concatenate([omega, v_o])
        assert_allclose(h[:3], m * (v_o + np.cross(omega, gvec)), rtol=1e-13, atol=1e-13)  # m v_G
        # J_O w + G x m v_O
        assert_allclose(h[3:], m * k2 * omega + np.cross(gvec, m * v_o), rtol=1e-13, atol=1e-12)


def test_e8_printed_g1_puts_the_crank_mass_centre_outside_the_crank():
    case = load_case("ideal")
    an = analyze(case)
    m1, a1 = case.bodies.crank.mass, case.geometry.crank_length
    v33a = np.array([0, 0, W1, 0, a1 * W1, 0.0])  # (33a), S1 constant
    k2 = np.array([1, 1, 1.0])
    speed_inhouse = np.linalg.norm(an.motions[0].com_vel, axis=1)
    physical = _binor(m1, -a1 / 2, k2) @ v33a  # g1 = -a1/2: the centre of mass between axis and pin
    printed = _binor(m1, +a1 / 2, k2) @ v33a  # section 3.1: g1 = +a1/2 from the pin along i2
    assert_allclose(physical[1] / m1, speed_inhouse, rtol=1e-12)
    assert_allclose(printed[1] / physical[1], 3.0, rtol=1e-12)  # (a1 + g1) / (a1 - a1/2)


def test_e8_backward_rod_momentum_52_has_g2_not_g3():
    rng = np.random.default_rng(9)
    m2, g2, k2 = 0.11, 25.0, np.array([0.5, 833.6, 833.6])
    th3, e3d, t3d, s4d = rng.uniform(-3, 3, 4)
    v36a = np.array([0, -e3d, -t3d, -s4d * math.sin(th3), s4d * math.cos(th3), 0])
    h = _binor(m2, g2, k2) @ v36a
    printed_52 = m2 * np.array([-s4d * math.sin(th3), -g2 * t3d + s4d * math.cos(th3), g2 * e3d,
                                0, -k2[1] * e3d, -k2[2] * t3d + g2 * s4d * math.cos(th3)])
    assert_allclose(h, printed_52, rtol=1e-13, atol=1e-12)


# ========================================================================== E9-E10 D'Alembert (62)-(64), 1F1k


def _regular_rows(an):
    return (an.status == "ok") & (np.abs(an.transmission) >= 0.2)


def test_e9_literal_62_64_break_newtons_third_law():
    case = load_case("ideal")
    an = analyze(case)
    kin = th.kinematics(case, an.crank.theta)
    torque = np.full(len(an.crank.theta), case.loads.drive_torque)
    rows = _regular_rows(an)
    a, b = th.newton_euler_system(case, kin)
    x, r = th.least_squares(a, b, {th.DRIVE_TORQUE_COLUMN: torque})
    scale = np.abs(an.reactions.slider_load[rows]).max()
    assert_allclose(x[rows, 12:15] @ kin["k4"], an.reactions.slider_load[rows], rtol=0, atol=1e-9 * scale)
    a_lit, b_lit = th.newton_euler_system(case, kin, literal=True)
    x_lit, r_lit = th.least_squares(a_lit, b_lit, {th.DRIVE_TORQUE_COLUMN: torque})
    assert np.abs(r_lit[rows]).max() < 1e-9 * scale  # the literal system is solvable ...
    # ... and wrong (15.6 lbf)
    assert np.abs(x_lit[rows, 12:15] @ kin["k4"] - an.reactions.slider_load[rows]).max() > 5.0
    # summed over the three bodies the joint forces do not cancel: ground forces = h2' - h1' - h3'
    (l1, _, _, _), (l2, _, _, _), (l3, _, _, _) = th.momentum_rates(case, kin)
    assert_allclose((x_lit[:, 0:3] + x_lit[:, 12:15])[rows], (l2 - l1 - l3)[rows], rtol=0, atol=1e-9 * scale)
    # physical
    assert_allclose((x[:, 0:3] + x[:, 12:15])[rows], (l1 + l2 + l3)[rows], rtol=0, atol=1e-9 * scale)
    assert np.abs(l1 + l3).max() > 5.0  # so the two differ by 2 (h1' + h3'), not a round-off


@pytest.mark.parametrize("name, floor", [("a4-30-s1-3.5", 0.3), ("a4-20-alpha-232", 1.0)])
def test_e10_prescribing_the_axial_force_overdetermines_spatial_cases(name, floor):
    case = load_case(name)
    an = analyze(case)
    kin = th.kinematics(case, an.crank.theta)
    n = len(an.crank.theta)
    rows = _regular_rows(an)
    a, b = th.newton_euler_system(case, kin)
    torque = np.full(n, case.loads.drive_torque)
    x, r = th.least_squares(a, b, {th.DRIVE_TORQUE_COLUMN: torque})
    scale = np.abs(x[rows]).max()
    assert np.abs(r[rows]).max() < 1e-9 * scale
    assert_allclose(x[rows, th.AXIAL_FORCE_COLUMN], an.reactions.j1_force[rows, 2], rtol=0, atol=1e-9 * scale)
    axial = case.bodies.crank.mass * kin["S1dd"]  # the thesis's 1F1k = m1 S1_ddot
    _, r_thesis = th.least_squares(a, b, {th.DRIVE_TORQUE_COLUMN: torque, th.AXIAL_FORCE_COLUMN: axial})
    # least-squares residual, all rows in lbf (moments / a2); measured 0.760 and 1.745 lbf
    assert np.linalg.norm(r_thesis[rows], axis=1).max() > floor
    planar = load_case("ideal")
    an_p = analyze(planar)
    kin_p = th.kinematics(planar, an_p.crank.theta)
    a_p, b_p = th.newton_euler_system(planar, kin_p)
    _, r_p = th.least_squares(a_p, b_p, {th.DRIVE_TORQUE_COLUMN: torque, th.AXIAL_FORCE_COLUMN: np.zeros(n)})
    assert np.abs(r_p[_regular_rows(an_p)]).max() < 1e-9 * scale


# ============================================================================ E11 expansions (62a)-(64f)


def test_e11_expansions_match_except_62c():
    rng = np.random.default_rng(11)
    for _ in range(10):
        t1, s1, a1, t2, e2, a2, t3, e3 = rng.uniform(-3, 3, 8) * [1, 5, 10, 1, 1, 20, 1, 1]
        f1, t1v, f2, f3 = rng.normal(size=(4, 3))
        fi, fj, fk = f1
        ti, tj, tk = t1v
        p, d = th.dvec(th.dtr(th.m1(t1, s1, a1)), (f1, t1v))
        ct, st = math.cos(t1), math.sin(t1)
        printed_62 = [
            fi * ct + fj * st,
            ti * ct - fi * s1 * st + fj * s1 * ct + tj * st,
            -fj * st + fj * ct,  # (62c) as printed
            -ti * st - fi * s1 * ct + tj * ct - fj * s1 * st + a1 * fk,
            fk,
            fi * a1 * st - fj * a1 * ct + tk,
        ]
        exact_62 = [p[0], d[0], p[1], d[1], p[2], d[2]]
        for k in (0, 1, 3, 4, 5):
            assert_allclose(printed_62[k], exact_62[k], rtol=0, atol=ERRATA_ROUND_OFF * 100)
        assert abs(printed_62[2] - exact_62[2]) > 1e-3 or abs(fi - fj) < 1e-3
        # corrected (62c)
        assert_allclose(-fi * st + fj * ct, exact_62[2], rtol=0, atol=ERRATA_ROUND_OFF * 100)
        p, d = th.dvec(th.dtr(th.l2(t2, e2, a2)), (f2, np.zeros(3)))
        c2, s2, ce, se = math.cos(t2), math.sin(t2), math.cos(e2), math.sin(e2)
        printed_63 = [f2[0] * c2 * ce + f2[1] * s2 * ce - f2[2] * se, 0.0, -f2[0] * s2 + f2[1] * c2,
                      a2 * (f2[0] * c2 * se + f2[1] * s2 * se + f2[2] * ce),
                      f2[0] * c2 * se + f2[1] * s2 * se + f2[2] * ce, a2 * (f2[0] * s2 - f2[1] * c2)]
        assert_allclose(printed_63, [p[0], d[0], p[1], d[1], p[2], d[2]], rtol=0, atol=ERRATA_ROUND_OFF * 100)
        p, d = th.dvec(th.dtr(th.l3(t3, e3)), (f3, np.zeros(3)))
        c3, s3, ce3, se3 = math.cos(t3), math.sin(t3), math.cos(e3), math.sin(e3)
        printed_64 = [
            f3[0] * c3 * ce3 + f3[1] * s3 * ce3 - f3[2] * se3,
            f3[0] * c3 * se3 + f3[1] * s3 * se3 + f3[2] * ce3,
            f3[0] * s3 - f3[1] * c3,
        ]
        assert_allclose(printed_64, p, rtol=0, atol=ERRATA_ROUND_OFF * 10)
        assert_allclose(d, 0.0, rtol=0, atol=0)


# ============================================================================ E12 the elimination (69a)-(69q)


def _random_consistent_crank_rod(rng):
    """Random joint forces and angles, with the inertia terms f chosen so that (62a-f, corrected c) and (63)
    hold."""
    t1, s1, a1, t2, e2, a2 = rng.uniform(-3, 3, 6) * [1, 5, 5, 1, 1, 20] + [0, 0, 8, 0, 0, 30]
    f1, tq, f2, f3 = rng.normal(size=(4, 3))
    p, d = th.dvec(th.dtr(th.m1(t1, s1, a1)), (f1, tq))
    f1p, f1d = -(p + f2), -d  # (62): M^T F1 + F2 + f1 = 0 (F2 has no moment at its own origin)
    p2, d2 = th.dvec(th.dtr(th.l2(t2, e2, a2)), (f2, np.zeros(3)))
    f2p, f2d = -(p2 + f3), -d2  # (63)
    return dict(
        t1=t1,
        s1=s1,
        a1=a1,
        t2=t2,
        e2=e2,
        a2=a2,
        F1=f1,
        T1=tq,
        F2=f2,
        F3=f3,
        f1p=f1p,
        f1d=f1d,
        f2p=f2p,
        f2d=f2d,
    )


def test_e12_elimination_69_reproduces_a_consistent_solution():
    rng = np.random.default_rng(12)
    for _ in range(20):
        v = _random_consistent_crank_rod(rng)
        t1, s1, a1, t2, e2, a2 = (v[k] for k in ("t1", "s1", "a1", "t2", "e2", "a2"))
        f1p, f1d, f2p, f2d = v["f1p"], v["f1d"], v["f2p"], v["f2d"]
        tk, f1k = v["T1"][2], v["F1"][2]
        atol = ERRATA_ROUND_OFF * 1e3
        assert_allclose(-(f1k + f1p[2]), v["F2"][2], rtol=0, atol=atol)  # (69a)
        assert_allclose(-(f2p[1] + f2d[2] / a2), v["F3"][1], rtol=0, atol=atol)  # (69b)
        assert_allclose(f2d[1] / a2 - f2p[2], v["F3"][2], rtol=0, atol=atol)  # (69c)
        f2j = -f1p[1] - (f1d[2] + tk) / a1  # (69g)
        assert_allclose(f2j, v["F2"][1], rtol=0, atol=atol)
        f2i = (f2j * a2 * math.cos(t2) - f2d[2]) / (a2 * math.sin(t2))  # (69h)
        assert_allclose(f2i, v["F2"][0], rtol=0, atol=atol / abs(math.sin(t2)))
        f1i = -(f2i + f1p[0]) * math.cos(t1) - (tk + f1d[2]) * math.sin(t1) / a1  # (69i)
        f1j = -(f2i + f1p[0]) * math.sin(t1) + (tk + f1d[2]) * math.cos(t1) / a1  # (69j)
        assert_allclose([f1i, f1j], v["F1"][:2], rtol=0, atol=atol / abs(math.sin(t2)))
        t1j = f1i * s1 - f1d[0] * math.sin(t1) - (f1k * a1 + f1d[1]) * math.cos(t1)  # (69p)
        t1i = -f1j * s1 - f1d[0] * math.cos(t1) + (f1k * a1 + f1d[1]) * math.sin(t1)  # (69q)
        assert_allclose([t1i, t1j], v["T1"][:2], rtol=0, atol=atol * 10 / abs(math.sin(t2)))


def test_e12_iteration_69i_69k_is_a_no_op():
    """(62a) holds for the output of (69i)-(69j) whatever F2i went in, so (69k) hands back the same F2i."""
    rng = np.random.default_rng(13)
    for _ in range(20):
        t1, a1, f1xp, tk, f1zd = rng.uniform(-3, 3), rng.uniform(1, 20), *rng.normal(size=3)
        f2i = rng.normal() * 100  # any value, right or wrong
        f1i = -(f2i + f1xp) * math.cos(t1) - (tk + f1zd) * math.sin(t1) / a1
        f1j = -(f2i + f1xp) * math.sin(t1) + (tk + f1zd) * math.cos(t1) / a1
        again = -f1i * math.cos(t1) - f1j * math.sin(t1) - f1xp  # (69k)
        assert_allclose(again, f2i, rtol=1e-13, atol=1e-12)


def _printed_59(v, h, hdot):
    """Eq. (59)-(61): f = dH/dt + V x H, written out in components with primary (p) and dual (d) parts."""
    (vp, vd), (hp, hd), (dp, dd) = v, h, hdot
    fp, fd = np.zeros(3), np.zeros(3)
    for x, y, z in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
        fp[x] = dp[x] - vp[z] * hp[y] + vp[y] * hp[z]
        fd[x] = dd[x] - vp[z] * hd[y] - vd[z] * hp[y] + vp[y] * hd[z] + vd[y] * hp[z]
    return fp, fd


def test_e9_dual_euler_form_59_61_is_right():
    """(59)-(61) in a body frame equal the world rate of the dual momentum, carried back into the frame."""
    rng = np.random.default_rng(14)
    coef = rng.normal(size=(6, 3))
    m, gvec, k2 = 0.7, rng.normal(size=3), np.array([2.0, 3.0, 4.0])
    s_mat = m * np.array([[0, -gvec[2], gvec[1]], [gvec[2], 0, -gvec[0]], [-gvec[1], gvec[0], 0]])
    binor = np.block([[s_mat.T, m * np.eye(3)], [m * np.diag(k2), s_mat]])

    def pose(t):
        a, b, cc = (coef[:3] @ np.array([t, t**2, np.sin(t)]))
        rot = _rz(np.array(a)) @ _ry(np.array(b)) @ _rz(np.array(cc))
        return rot, coef[3:] @ np.array([t, t**2, np.cos(t)])

    def flat_pose(ts):
        return np.stack([np.concatenate([pose(t)[0].ravel(), pose(t)[1]]) for t in ts])

    def local_twist(t):
        val, der, _ = th.derivatives(flat_pose, np.array([t]), h=1e-3)
        rot, p = val[0, :9].reshape(3, 3), val[0, 9:]
        rdot, pdot = der[0, :9].reshape(3, 3), der[0, 9:]
        return rot, p, _vee(rot.T @ rdot), rot.T @ pdot  # omega and v_O in body axes

    def local_momentum(ts):
        out = []
        for t in ts:
            _, _, om, vo = local_twist(t)
            out.append(binor @ np.concatenate([om, vo]))
        return np.stack(out)

    def world_momentum(ts):
        out = []
        for t, hl in zip(ts, local_momentum(ts)):
            rot, p, _, _ = local_twist(t)
            hp = rot @ hl[:3]
            out.append(np.concatenate([hp, rot @ hl[3:] + np.cross(p, hp)]))
        return np.stack(out)

    for t0 in (0.3, 1.1):
        rot, p, om, vo = local_twist(t0)
        h_loc, dh_loc, _ = th.derivatives(local_momentum, np.array([t0]), h=1e-3)
        _, dh_world, _ = th.derivatives(world_momentum, np.array([t0]), h=1e-3)
        fp, fd = _printed_59((om, vo), (h_loc[0, :3], h_loc[0, 3:]), (dh_loc[0, :3], dh_loc[0, 3:]))
        wp, wd = dh_world[0, :3], dh_world[0, 3:]
        assert_allclose(fp, rot.T @ wp, rtol=0, atol=1e-7 * np.abs(wp).max())
        assert_allclose(fd, rot.T @ (wd - np.cross(p, wp)), rtol=0, atol=1e-7 * np.abs(wd).max())
