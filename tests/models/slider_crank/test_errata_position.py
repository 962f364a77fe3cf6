"""Errata E1-E3 of docs/errata.md, the position analysis (thesis section 2): the printed matrices (1)-(4)
and their derivatives, the five Z-Y unknowns of (5), (23)-(26), and the diagonal device of (22), each
evaluated against an independent computation.  A test fails if our claim about the printed text were
wrong (the printed form would then pass where we say it fails, or the correction would fail where we
say it holds).

Transcriptions of the printed equations and the independent oracles are in
``tests/models/slider_crank/thesis_oracles.py``; the rates are in ``test_errata_rates.py``, the dynamics in
``test_errata_dynamics.py``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.optimize import least_squares as scipy_least_squares

from dualmech.core.dual import Dual, rot_x, rot_y, rot_z
from tests.models.slider_crank import thesis_oracles as th
from tests.models.slider_crank.errata_example import PLANAR, SPATIAL_S1, SPATIAL_TWIST
from tests.tolerances import COMPLEX_STEP, ERRATA_ROUND_OFF

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
