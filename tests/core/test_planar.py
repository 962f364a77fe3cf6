"""The Sinatra–Angeles planar model: the corrected equations hold, the printed ones (errata) do not.

Each erratum of the paper is exercised twice: the derived form satisfies an identity that the
paper itself states (A u = 0, eq. 36; C = -u^T M u', eq. 39; a stationary mass centre, eq. 53),
and the printed form violates it.
"""

import numpy as np
import pytest
from numpy.testing import assert_allclose

from dualmech.core import planar as P
from tests.tolerances import BATCH_VS_SINGLE, FINITE_DIFFERENCE, PLANAR_IDENTITY


def _model(rng, offset=None, slider_com=None) -> P.PlanarSliderCrank:
    a1 = rng.uniform(0.1, 0.3)
    a2 = rng.uniform(3.0, 5.0) * a1
    return P.PlanarSliderCrank(
        crank_length=a1, rod_length=a2,
        offset=rng.uniform(-0.5, 0.5) * (a2 - a1) if offset is None else offset,
        masses=tuple(rng.uniform(0.5, 3.0, 3)), polar_inertias=tuple(rng.uniform(0.01, 0.2, 2)),
        crank_com=rng.normal(0, a1, 2), rod_com=rng.normal(0, a2 / 2, 2),
        slider_com=rng.normal(0, 0.05, 2) if slider_com is None else slider_com,
        gravity=rng.normal(0, 9.81, 2),
    )


def _psi(rng, n=40):
    return rng.uniform(-np.pi, 3 * np.pi, n)


def test_pose_closes_the_loop_on_the_branch():
    rng = np.random.default_rng(10)
    m = _model(rng)
    p = P.pose(m, _psi(rng))
    pin = p.r12 + p.r23
    assert_allclose(pin[:, 1], m.offset, rtol=0, atol=PLANAR_IDENTITY)
    assert_allclose(np.linalg.norm(p.r23, axis=1), m.rod_length, rtol=PLANAR_IDENTITY)
    assert np.all(p.r23[:, 0] > 0)
    assert_allclose(p.s, pin[:, 0], rtol=PLANAR_IDENTITY)


def test_influence_coefficients_are_derivatives():
    rng = np.random.default_rng(11)
    m = _model(rng)
    psi, h = _psi(rng), 1e-6
    k = P.influence(P.pose(m, psi))
    plus, minus = P.pose(m, psi + h), P.pose(m, psi - h)
    kp, km = P.influence(plus), P.influence(minus)
    scale = max(np.abs(k.r_s).max(), 1.0)
    assert_allclose(k.r_theta, (plus.theta - minus.theta) / (2 * h), rtol=0, atol=FINITE_DIFFERENCE)
    assert_allclose(k.r_s, (plus.s - minus.s) / (2 * h), rtol=0, atol=FINITE_DIFFERENCE * scale)
    assert_allclose(k.r_theta_prime, (kp.r_theta - km.r_theta) / (2 * h), rtol=0, atol=FINITE_DIFFERENCE)
    assert_allclose(k.r_s_prime, (kp.r_s - km.r_s) / (2 * h), rtol=0, atol=FINITE_DIFFERENCE * scale)


def test_twist_shaping_vector_spans_the_null_space_of_A():
    """Eq. (36), A u = 0 -- with the corrected u; the printed rod block (r23, eq. 35) violates it."""
    rng = np.random.default_rng(12)
    m = _model(rng)
    psi = _psi(rng)
    a = P.constraint_matrix(m, psi)
    u = P.twist_shaping_vector(m, psi)
    assert_allclose(np.einsum("nij,nj->ni", a, u), 0.0, rtol=0, atol=PLANAR_IDENTITY)
    p, k = P.pose(m, psi), P.influence(P.pose(m, psi))
    printed = u.copy()
    printed[:, 4:6] = np.stack([-(p.r12 + k.r_theta[:, None] * p.r23)[:, 1],
                                (p.r12 + k.r_theta[:, None] * p.r23)[:, 0]], 1)  # -(r12 + r_th r23)^T E
    assert np.abs(np.einsum("nij,nj->ni", a, printed)).max() > 1e-2 * m.crank_length
    assert np.linalg.matrix_rank(a[0]) == 8


def test_generalized_inertia_eq40_is_u_M_u():
    rng = np.random.default_rng(13)
    m = _model(rng)
    psi = _psi(rng)
    u = P.twist_shaping_vector(m, psi)
    assert_allclose(
        P.generalized_inertia(m, psi), np.einsum("ni,ij,nj->n", u, P.inertia_dyad(m), u), rtol=PLANAR_IDENTITY
    )


def test_coriolis_eq41_corrected_is_minus_u_M_udot_and_the_printed_one_is_not():
    rng = np.random.default_rng(14)
    m = _model(rng)
    psi, psidot = _psi(rng), 3.7
    u, du = P.twist_shaping_vector(m, psi), P.twist_shaping_derivative(m, psi)
    expect = -np.einsum("ni,ij,nj->n", u, P.inertia_dyad(m), du) * psidot  # eq. (39): C psidot = -u^T M udot
    got = P.coriolis(m, psi, psidot)
    scale = np.abs(expect).max()
    assert_allclose(got, expect, rtol=0, atol=PLANAR_IDENTITY * scale)
    h = 1e-6
    fd = (P.generalized_inertia(m, psi + h) - P.generalized_inertia(m, psi - h)) / (2 * h)
    assert_allclose(P.generalized_inertia_derivative(m, psi), fd, rtol=0, atol=FINITE_DIFFERENCE * scale)
    # the printed eq. (41): (E r12 + r_th r2)^T r2 in the first rod term
    p, k = P.pose(m, psi), P.influence(P.pose(m, psi))
    _, m2, m3 = m.masses
    e_r12 = np.stack([-p.r12[:, 1], p.r12[:, 0]], 1)
    e_r2 = np.stack([-p.r2[:, 1], p.r2[:, 0]], 1)
    printed = -psidot * (k.r_theta * k.r_theta_prime * m.polar_inertias[1]
                         + m2 * (k.r_theta_prime * np.sum((e_r12 + k.r_theta[:, None] * p.r2) * p.r2, 1)
                                 + k.r_theta * (k.r_theta - 1) * np.sum(p.r12 * e_r2, 1))
                         + m3 * k.r_s * k.r_s_prime)
    assert np.abs(printed - expect).max() > 1e-3 * scale


def test_du_is_the_derivative_of_u():
    rng = np.random.default_rng(15)
    m = _model(rng)
    psi, h = _psi(rng), 1e-6
    fd = (P.twist_shaping_vector(m, psi + h) - P.twist_shaping_vector(m, psi - h)) / (2 * h)
    du = P.twist_shaping_derivative(m, psi)
    assert_allclose(du, fd, rtol=0, atol=FINITE_DIFFERENCE * np.abs(du).max())


def test_gravity_torque_is_minus_the_potential_gradient():
    rng = np.random.default_rng(16)
    m = _model(rng)
    psi, h = _psi(rng), 1e-6
    masses = np.array(m.masses)

    def potential(x):
        p = P.pose(m, x)
        com = np.stack([p.r1, p.r12 + p.r2, p.r12 + p.r23 + p.r3])
        return -np.einsum("b,bni,i->n", masses, com, m.gravity)

    fd = -(potential(psi + h) - potential(psi - h)) / (2 * h)
    got = P.gravity_torque(m, psi)
    assert_allclose(got, fd, rtol=0, atol=FINITE_DIFFERENCE * np.abs(got).max())


def test_generalized_force_parts():
    rng = np.random.default_rng(17)
    m = _model(rng)
    psi = _psi(rng, 5)
    k = P.influence(P.pose(m, psi))
    tau = P.generalized_force(
        m, psi, 2.0, drive_torque=5.0, crank_damping=0.3, slider_damping=0.7, slider_force=-4.0
    )
    expect = 5.0 + P.gravity_torque(m, psi) - (0.3 + 0.7 * k.r_s**2) * 2.0 - 4.0 * k.r_s
    assert_allclose(tau, expect, rtol=PLANAR_IDENTITY)
    acc = P.acceleration(m, psi, 2.0, tau)
    assert_allclose(
        P.generalized_inertia(m, psi) * acc, P.coriolis(m, psi, 2.0) * 2.0 + tau, rtol=PLANAR_IDENTITY
    )


def test_balancing_point_derived_not_printed():
    """xi1 = -(1+mu2)/mu1, xi2 = -1/mu2 make the mass centre stationary; eq. (75)'s xi2 = +1/mu2 does not."""
    rng = np.random.default_rng(18)
    m = _model(rng, slider_com=np.zeros(2))
    m1, m2, m3 = m.masses
    mu1, mu2 = m1 / m3, m2 / m3
    psi = np.linspace(0, 2 * np.pi, 73)

    def with_xi2(xi2):
        return P.PlanarSliderCrank(m.crank_length, m.rod_length, m.offset, m.masses, m.polar_inertias,
                                   crank_com=[-(1 + mu2) / mu1 * m.crank_length, 0.0],
                                   rod_com=[xi2 * m.rod_length, 0.0])

    c = P.mass_centre(with_xi2(-1 / mu2), psi)
    assert_allclose(c, np.broadcast_to(c[0], c.shape), rtol=0, atol=PLANAR_IDENTITY * m.rod_length)
    printed = P.mass_centre(with_xi2(+1 / mu2), psi)
    assert np.ptp(printed, axis=0).max() > 1e-2 * m.crank_length


def test_batched_equals_one_position_at_a_time():
    rng = np.random.default_rng(19)
    m = _model(rng)
    psi = _psi(rng, 6)
    batch = P.coriolis(m, psi, 1.3)
    single = [P.coriolis(m, psi[i:i + 1], 1.3)[0] for i in range(6)]
    assert_allclose(batch, single, rtol=BATCH_VS_SINGLE)


def test_bad_input_is_refused():
    rng = np.random.default_rng(20)
    with pytest.raises(ValueError, match="crank_length"):
        P.PlanarSliderCrank(0.0, 1.0, 0.0, (1, 1, 1), (0, 0), [0, 0], [0, 0])
    with pytest.raises(ValueError, match="masses"):
        P.PlanarSliderCrank(1.0, 3.0, 0.0, (1, -1, 1), (0, 0), [0, 0], [0, 0])
    far = _model(rng, offset=10.0)
    with pytest.raises(ValueError, match="cannot reach"):
        P.pose(far, np.array([0.0, 1.0]))
