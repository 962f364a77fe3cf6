"""Generalized inertia and generalized forces of a one-degree-of-freedom mechanism.

The natural orthogonal complement (Sinatra–Angeles eq. 34–39, after Angeles and
Lee) in space: every body's twist is linear in the single rate
:math:`\\dot\\theta`,

.. math:: \\omega_b = w_b(\\theta)\\,\\dot\\theta, \\qquad \\dot c_b = v_b(\\theta)\\,\\dot\\theta,

with the *influence coefficients* :math:`w_b, v_b` (angular velocity and
centre-of-mass velocity per unit :math:`\\dot\\theta`).  The kinetic energy is
:math:`T = \\tfrac12 I(\\theta)\\dot\\theta^2` with the generalized inertia

.. math:: I(\\theta) = \\sum_b m_b\\, v_b\\cdot v_b + w_b\\cdot J_b(\\theta)\\, w_b
   \\qquad (\\text{Sinatra–Angeles eq. 40 in space})

(:math:`J_b` the central inertia in world axes), and Lagrange's equation of the
scleronomic system is

.. math:: I\\ddot\\theta + \\tfrac12 I'(\\theta)\\dot\\theta^2 = \\tau,
   \\quad\\text{i.e.}\\quad I\\ddot\\theta = C\\dot\\theta + \\tau,\\;
   C = -\\tfrac12 I'(\\theta)\\dot\\theta \\qquad (\\text{eq. 39, 41}).

Because :math:`dJ_b/d\\theta = [W_b, J_b]` (:math:`W_b` the cross-product matrix
of :math:`w_b`) and :math:`w_b^T[W_b, J_b]w_b = 0`,

.. math:: I'(\\theta) = 2\\sum_b m_b\\, v_b\\cdot v_b' + w_b\\cdot J_b\\, w_b'

where :math:`v_b' = dv_b/d\\theta`, :math:`w_b' = dw_b/d\\theta` are the
centre-of-mass acceleration and angular acceleration of a motion with
:math:`\\dot\\theta = 1, \\ddot\\theta = 0`.  The generalized force is the
power of the applied loads per unit :math:`\\dot\\theta` (eq. 43,
:math:`\\tau = \\tau^A + \\tau^G + \\tau^D`).

Everything here is numpy on arrays (no mechanism model): the influence
coefficients come from any velocity analysis (``models/slider_crank/forward_dynamics.py``
takes them from the in-house solver).  Shapes: ``b`` bodies, ``n`` positions.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class InfluenceCoefficients:
    """Body rates per unit :math:`\\dot\\theta`, and their :math:`\\theta`-derivatives, world axes.

    Attributes
    ----------
    com_rate : numpy.ndarray, shape (b, n, 3)
        :math:`v_b = \\partial \\dot c_b/\\partial\\dot\\theta` (length/rad).
    omega_rate : numpy.ndarray, shape (b, n, 3)
        :math:`w_b = \\partial\\omega_b/\\partial\\dot\\theta` (rad/rad).
    com_rate_prime, omega_rate_prime : numpy.ndarray, shape (b, n, 3)
        :math:`dv_b/d\\theta` and :math:`dw_b/d\\theta` (the accelerations at
        :math:`\\dot\\theta = 1, \\ddot\\theta = 0`).
    """

    com_rate: np.ndarray
    omega_rate: np.ndarray
    com_rate_prime: np.ndarray
    omega_rate_prime: np.ndarray


def generalized_inertia(masses: np.ndarray, inertia_world: np.ndarray,
                        coeffs: InfluenceCoefficients) -> np.ndarray:
    """:math:`I(\\theta) = \\sum_b m_b |v_b|^2 + w_b\\cdot J_b w_b`, shape ``(n,)`` (mass·length²).

    Parameters
    ----------
    masses : array, shape (b,)
    inertia_world : array, shape (b, n, 3, 3)
        Central inertia of each body in world axes at each position.
    coeffs : InfluenceCoefficients
    """
    m = np.asarray(masses, dtype=float)
    trans = np.einsum("b,bni,bni->n", m, coeffs.com_rate, coeffs.com_rate)
    rot = np.einsum("bni,bnij,bnj->n", coeffs.omega_rate, inertia_world, coeffs.omega_rate)
    return trans + rot


def generalized_inertia_derivative(masses: np.ndarray, inertia_world: np.ndarray,
                                   coeffs: InfluenceCoefficients) -> np.ndarray:
    """:math:`dI/d\\theta = 2\\sum_b m_b v_b\\cdot v_b' + w_b\\cdot J_b w_b'`, shape ``(n,)``.

    The term :math:`w_b^T (dJ_b/d\\theta) w_b = w_b^T[W_b, J_b]w_b` vanishes
    identically (module docstring).
    """
    m = np.asarray(masses, dtype=float)
    trans = np.einsum("b,bni,bni->n", m, coeffs.com_rate, coeffs.com_rate_prime)
    rot = np.einsum("bni,bnij,bnj->n", coeffs.omega_rate, inertia_world, coeffs.omega_rate_prime)
    return 2.0 * (trans + rot)


def coriolis_coefficient(inertia_derivative: np.ndarray, theta_dot: np.ndarray | float) -> np.ndarray:
    """:math:`C = -\\tfrac12 I'(\\theta)\\dot\\theta`, so that :math:`I\\ddot\\theta = C\\dot\\theta + \\tau`.

    Sinatra–Angeles eq. (39), (41): :math:`C\\dot\\psi = -u^T M \\dot u\\,\\dot\\psi`
    and, with a constant planar inertia dyad, :math:`u^T M u' = \\tfrac12 I'`.
    """
    return -0.5 * np.asarray(inertia_derivative) * theta_dot


def gravity_force(masses: np.ndarray, gravity: np.ndarray, coeffs: InfluenceCoefficients) -> np.ndarray:
    """:math:`\\tau^G = \\sum_b m_b\\, g\\cdot v_b`, shape ``(n,)`` (force·length/rad).

    ``gravity`` ``(3,)`` is the gravitational acceleration in world axes.
    """
    m = np.asarray(masses, dtype=float)
    return np.einsum("b,bni,i->n", m, coeffs.com_rate, np.asarray(gravity, dtype=float))


def potential_energy(masses: np.ndarray, gravity: np.ndarray, com: np.ndarray) -> np.ndarray:
    """:math:`V = -\\sum_b m_b\\, g\\cdot c_b`, shape ``(n,)``, from ``com`` ``(b, n, 3)``.

    So :math:`\\tau^G = -dV/d\\theta`.
    """
    m = np.asarray(masses, dtype=float)
    return -np.einsum("b,bni,i->n", m, com, np.asarray(gravity, dtype=float))


def slider_force(slider_rate: np.ndarray, slider_load: np.ndarray | float) -> np.ndarray:
    """Generalized force of a load along the slider line, :math:`-F\\,S_4'(\\theta)`.

    ``slider_load`` :math:`F = k_4\\cdot f` is the component along :math:`k_4` of the
    force applied to the slider (``docs/conventions.md``); the slider pin moves
    by :math:`dP_3 = -k_4\\, dS_4`, so the load's power per unit
    :math:`\\dot\\theta` is :math:`-F S_4'`.  ``slider_rate`` is :math:`S_4'` ``(n,)``.
    """
    return -np.asarray(slider_load) * np.asarray(slider_rate)


def damping_force(theta_dot: np.ndarray | float, slider_rate: np.ndarray,
                  crank_damping: float = 0.0, slider_damping: float = 0.0) -> np.ndarray:
    """Viscous generalized force :math:`\\tau^D = -(c_1 + c_4 S_4'^2)\\dot\\theta` (eq. 43).

    ``crank_damping`` :math:`c_1` (torque per rad/s) acts between ground and
    crank about the crank axis; ``slider_damping`` :math:`c_4` (force per
    length/s) between ground and slider along the slider line.  The source
    names viscous effects without a formula; this is the Rayleigh function
    :math:`\\tfrac12(c_1\\dot\\theta^2 + c_4\\dot S_4^2)`.
    """
    rate = np.asarray(slider_rate, dtype=float)
    return -(crank_damping + slider_damping * rate**2) * theta_dot


def acceleration(inertia: np.ndarray, inertia_derivative: np.ndarray, theta_dot: np.ndarray | float,
                 generalized_force_value: np.ndarray | float) -> np.ndarray:
    """Forward dynamics :math:`\\ddot\\theta = (\\tau - \\tfrac12 I'\\dot\\theta^2)/I` (eq. 39)."""
    coriolis = coriolis_coefficient(inertia_derivative, theta_dot) * theta_dot
    return (generalized_force_value + coriolis) / inertia


def project_mass_matrix(mass_matrix: np.ndarray, basis: np.ndarray) -> np.ndarray:
    """:math:`n^T M n` of a mass matrix on a null-space vector of the constraints.

    For a model with ``k`` coordinates, ``mass_matrix`` ``(n, k, k)`` and the
    constraint null-space vector ``basis`` ``(n, k)`` scaled so that its
    :math:`\\dot\\theta` component is 1 (the twist-shaping vector ``u`` of
    Sinatra–Angeles eq. 34) give the generalized inertia ``(n,)``.
    """
    return np.einsum("ni,nij,nj->n", basis, mass_matrix, basis)
