"""Generalized inertia, its derivative and the generalized forces on a synthetic 1-dof system.

The system: a rigid body whose attitude is R(th) = Rz(th) Rx(phi(th)), phi = A sin(th), with its mass
centre at R(th) rho + h(th) z, h = B sin(2 th), plus a point mass moving along x by x(th).  Every
influence coefficient is known in closed form, so the functions can be checked against finite
differences of the energy and against Lagrange's equations (energy conservation).
"""

import numpy as np
from numpy.testing import assert_allclose
from scipy.integrate import solve_ivp

from dualmech.core import generalized_inertia as gi
from tests.tolerances import BATCH_VS_SINGLE, FINITE_DIFFERENCE

A, B = 0.4, 0.3
RHO = np.array([0.7, -0.2, 0.4])
J_BODY = np.array([[2.0, 0.1, -0.2], [0.1, 1.5, 0.05], [-0.2, 0.05, 0.9]])
MASSES = np.array([3.0, 1.7])
GRAVITY = np.array([0.5, -9.81, -2.0])


def _rz(t):
    c, s = np.cos(t), np.sin(t)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])


def _rx(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[1.0, 0, 0], [0, c, -s], [0, s, c]])


def _system(theta: np.ndarray):
    """Masses, world inertias (2, n, 3, 3), COM positions (2, n, 3) and influence coefficients."""
    n = theta.shape[0]
    rot = np.stack([_rz(t) @ _rx(A * np.sin(t)) for t in theta])
    x_axis = np.stack([_rz(t)[:, 0] for t in theta])
    y_axis = np.stack([_rz(t)[:, 1] for t in theta])
    phi_p, phi_pp = A * np.cos(theta), -A * np.sin(theta)
    z = np.array([0.0, 0.0, 1.0])
    w = z + phi_p[:, None] * x_axis
    wp = phi_pp[:, None] * x_axis + phi_p[:, None] * y_axis
    arm = rot @ RHO
    h, hp, hpp = B * np.sin(2 * theta), 2 * B * np.cos(2 * theta), -4 * B * np.sin(2 * theta)
    c_body = arm + h[:, None] * z
    v_body = np.cross(w, arm) + hp[:, None] * z
    a_body = np.cross(wp, arm) + np.cross(w, np.cross(w, arm)) + hpp[:, None] * z
    x, xp, xpp = np.cos(theta) + 0.2 * np.sin(2 * theta), -np.sin(theta) + 0.4 * np.cos(2 * theta), \
        -np.cos(theta) - 0.8 * np.sin(2 * theta)
    ex = np.array([1.0, 0.0, 0.0])
    inertia = np.stack([rot @ J_BODY @ np.swapaxes(rot, 1, 2), np.zeros((n, 3, 3))])
    com = np.stack([c_body, x[:, None] * ex])
    coeffs = gi.InfluenceCoefficients(
        com_rate=np.stack([v_body, xp[:, None] * ex]),
        omega_rate=np.stack([w, np.zeros((n, 3))]),
        com_rate_prime=np.stack([a_body, xpp[:, None] * ex]),
        omega_rate_prime=np.stack([wp, np.zeros((n, 3))]),
    )
    return inertia, com, coeffs


def _inertia(theta):
    inertia, _, coeffs = _system(theta)
    return gi.generalized_inertia(MASSES, inertia, coeffs)


def test_inertia_is_twice_the_kinetic_energy_at_unit_rate():
    rng = np.random.default_rng(1)
    theta = rng.uniform(-4, 4, 9)
    inertia, _, c = _system(theta)
    kinetic = 0.5 * sum(
        MASSES[b] * np.sum(c.com_rate[b] ** 2, axis=1)
        + np.einsum("ni,nij,nj->n", c.omega_rate[b], inertia[b], c.omega_rate[b]) for b in range(2))
    assert_allclose(gi.generalized_inertia(MASSES, inertia, c), 2 * kinetic, rtol=1e-14)


def test_inertia_derivative_matches_central_difference():
    rng = np.random.default_rng(2)
    theta = rng.uniform(-4, 4, 25)
    inertia, _, coeffs = _system(theta)
    step = 1e-6
    fd = (_inertia(theta + step) - _inertia(theta - step)) / (2 * step)
    got = gi.generalized_inertia_derivative(MASSES, inertia, coeffs)
    assert_allclose(got, fd, rtol=0, atol=FINITE_DIFFERENCE * np.abs(_inertia(theta)).max())


def test_gravity_force_is_minus_the_potential_gradient():
    rng = np.random.default_rng(3)
    theta = rng.uniform(-4, 4, 25)
    step = 1e-6
    _, com_p, _ = _system(theta + step)
    _, com_m, _ = _system(theta - step)
    _, _, coeffs = _system(theta)
    dv = (gi.potential_energy(MASSES, GRAVITY, com_p) - gi.potential_energy(MASSES, GRAVITY, com_m)) / (
        2 * step
    )
    got = gi.gravity_force(MASSES, GRAVITY, coeffs)
    assert_allclose(got, -dv, rtol=0, atol=FINITE_DIFFERENCE * np.abs(got).max())


def test_batched_equals_one_position_at_a_time():
    rng = np.random.default_rng(4)
    theta = rng.uniform(-4, 4, 7)
    inertia, _, coeffs = _system(theta)
    batch = gi.generalized_inertia_derivative(MASSES, inertia, coeffs)
    single = [gi.generalized_inertia_derivative(MASSES, *_system(theta[i:i + 1])[::2])[0] for i in range(7)]
    assert_allclose(batch, single, rtol=BATCH_VS_SINGLE)


def test_equation_of_motion_conserves_energy():
    """Lagrange: I th'' + I'/2 th'^2 = tau^G conserves T + V (checks the sign and factor of C)."""

    def rhs(t, y):
        inertia, _, coeffs = _system(np.array([y[0]]))
        i = gi.generalized_inertia(MASSES, inertia, coeffs)
        di = gi.generalized_inertia_derivative(MASSES, inertia, coeffs)
        return [y[1], gi.acceleration(i, di, y[1], gi.gravity_force(MASSES, GRAVITY, coeffs))[0]]

    def energy(y):
        inertia, com, coeffs = _system(np.array([y[0]]))
        return (0.5 * gi.generalized_inertia(MASSES, inertia, coeffs) * y[1] ** 2
                + gi.potential_energy(MASSES, GRAVITY, com))[0]

    sol = solve_ivp(rhs, (0.0, 3.0), [0.3, 6.0], method="DOP853", rtol=1e-11, atol=1e-11)
    e = np.array([energy(y) for y in sol.y.T])
    # 1e-8: DOP853 at 1e-11 accumulates ~1e-10 of the energy over a few hundred steps
    assert_allclose(e, e[0], rtol=1e-8)
    # the same equation with the Coriolis sign flipped does not conserve it
    def rhs_flipped(t, y):
        inertia, _, coeffs = _system(np.array([y[0]]))
        i = gi.generalized_inertia(MASSES, inertia, coeffs)
        di = gi.generalized_inertia_derivative(MASSES, inertia, coeffs)
        return [y[1], gi.acceleration(i, -di, y[1], gi.gravity_force(MASSES, GRAVITY, coeffs))[0]]

    bad = solve_ivp(rhs_flipped, (0.0, 3.0), [0.3, 6.0], method="DOP853", rtol=1e-11, atol=1e-11)
    e_bad = np.array([energy(y) for y in bad.y.T])
    assert np.abs(e_bad - e_bad[0]).max() > 1e-3 * abs(e[0])


def test_damping_and_slider_forces_dissipate_and_do_work():
    rate = np.array([0.5, -2.0, 0.0])
    assert_allclose(gi.damping_force(3.0, rate, crank_damping=0.2, slider_damping=0.1),
                    -(0.2 + 0.1 * rate**2) * 3.0, rtol=1e-15)
    assert_allclose(gi.slider_force(rate, 10.0), -10.0 * rate, rtol=1e-15)


def test_projected_mass_matrix():
    rng = np.random.default_rng(5)
    a = rng.normal(size=(4, 5, 5))
    mass = a @ np.swapaxes(a, 1, 2)
    basis = rng.normal(size=(4, 5))
    expect = [basis[i] @ mass[i] @ basis[i] for i in range(4)]
    assert_allclose(gi.project_mass_matrix(mass, basis), expect, rtol=1e-13)
