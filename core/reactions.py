"""Inverse dynamics of the generalized slider crank: the reaction wrench at every joint.

Thesis section 2.8 in world coordinates.  Each body's dual momentum about the
world origin (the inertia binor applied to the body's dual velocity, eq. 49-53)
is :math:`\\hat H = m v_G + \\varepsilon (I_G\\omega + G\\times m v_G)`; its rate
(dual Euler equation, eq. 59-61) is

.. math:: \\dot{\\hat H} = m a_G + \\varepsilon\\,(I_G\\dot\\omega + \\omega\\times I_G\\omega + G\\times m a_G)

and D'Alembert's principle (eq. 62-64) reads, for every body,
:math:`\\sum \\hat F_{applied} - \\dot{\\hat H} = 0`, a dual force being
:math:`f + \\varepsilon\\, m_O` (moment about the world origin).  A force ``f``
through point ``P`` is :math:`f + \\varepsilon P\\times f`.

Unknowns (``docs/conventions.md``): ground→crank wrench (6), crank→rod force
``j2`` (3), rod→slider force ``j3`` (3), ground→slider wrench (6), less the one
given load: 17 unknowns, 18 equations, one of them (the rod's spin) ``0 = 0``.
They are eliminated in closed form, batched over positions:

* rod, moments about :math:`P_2`: :math:`-a_2 u\\times j_3 = K_2`, so
  :math:`j_3 = \\lambda u + (u\\times K_2)/a_2`, with the axial rod force
  :math:`\\lambda` still free (:math:`u\\cdot K_2 = 0` is the spin equation);
* rod forces give ``j2``, slider forces and moments about :math:`P_3` give the
  joint-4 wrench, crank forces and moments about O the joint-1 wrench;
* the given load fixes :math:`\\lambda`: drive torque
  :math:`\\tau = \\tau_0 + \\lambda\\, z\\cdot(P_2\\times u)` (singular at dead
  centres, :math:`z\\cdot(P_2\\times u) = a_1 t = 0`), or slider load
  :math:`s = s_0 - \\lambda\\, k_4\\cdot u` (singular only at the edge of assembly).

This replaces the printed elimination (69a)-(69q) (errata E9-E12).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dualmech.core.dual import Dual
from dualmech.core.inertia import BodyInertia


@dataclass(frozen=True)
class BodyMotion:
    """Motion of one body at ``n`` positions; all arrays in world axes.

    ``rotation`` ``(n, 3, 3)`` body axes in world; ``origin`` ``(n, 3)`` body-frame
    origin; ``com``, ``com_vel``, ``com_acc`` ``(n, 3)`` centre of mass and its
    velocity and acceleration; ``omega``, ``omega_dot`` ``(n, 3)``.
    """

    rotation: np.ndarray
    origin: np.ndarray
    com: np.ndarray
    com_vel: np.ndarray
    com_acc: np.ndarray
    omega: np.ndarray
    omega_dot: np.ndarray


def body_motion(body: BodyInertia, rotation: np.ndarray, origin: np.ndarray, twist: Dual, accel: Dual) -> BodyMotion:
    """Centre-of-mass motion from a body's twist :math:`\\omega + \\varepsilon v_O` and its rate.

    .. math:: v_G = v_O + \\omega\\times G, \\qquad a_G = \\dot v_O + \\dot\\omega\\times G + \\omega\\times v_G
    """
    com = origin + np.einsum("nij,j->ni", rotation, body.com)
    omega, omega_dot = twist.re, accel.re
    vel = twist.du + np.cross(omega, com)
    acc = accel.du + np.cross(omega_dot, com) + np.cross(omega, vel)
    return BodyMotion(rotation, origin, com, vel, acc, omega, omega_dot)


def momentum(body: BodyInertia, motion: BodyMotion) -> Dual:
    """Dual momentum about the world origin, :math:`m v_G + \\varepsilon(I_G\\omega + G\\times m v_G)`, ``(n, 3)``."""
    i_world = motion.rotation @ body.inertia @ np.swapaxes(motion.rotation, 1, 2)
    lin = body.mass * motion.com_vel
    return Dual(lin, np.einsum("nij,nj->ni", i_world, motion.omega) + np.cross(motion.com, lin))


def momentum_rate(body: BodyInertia, motion: BodyMotion) -> Dual:
    """Rate of the dual momentum about the (fixed) world origin, ``(n, 3)`` (dual Euler equation)."""
    i_world = motion.rotation @ body.inertia @ np.swapaxes(motion.rotation, 1, 2)
    lin = body.mass * motion.com_acc
    spin = np.einsum("nij,nj->ni", i_world, motion.omega)
    ang = np.einsum("nij,nj->ni", i_world, motion.omega_dot) + np.cross(motion.omega, spin)
    return Dual(lin, ang + np.cross(motion.com, lin))


def force_at(point: np.ndarray, force: np.ndarray) -> Dual:
    """Dual force :math:`f + \\varepsilon P\\times f` of a force through ``point``."""
    return Dual(force, np.cross(point, force))


def kinetic_energy(body: BodyInertia, motion: BodyMotion) -> np.ndarray:
    """:math:`\\tfrac12 m v_G^2 + \\tfrac12 \\omega\\cdot I_G\\omega`, shape ``(n,)``."""
    i_world = motion.rotation @ body.inertia @ np.swapaxes(motion.rotation, 1, 2)
    rot = np.einsum("ni,nij,nj->n", motion.omega, i_world, motion.omega)
    return 0.5 * body.mass * np.einsum("ni,ni->n", motion.com_vel, motion.com_vel) + 0.5 * rot


@dataclass(frozen=True)
class Reactions:
    """Joint reactions at ``n`` positions, world axes (``docs/conventions.md``).

    ``j1_force``, ``j1_moment`` (about O): ground on crank; ``j2``: crank on rod at P2;
    ``j3``: rod on slider at P3; ``j4_force``, ``j4_moment`` (about P3): ground on
    slider; ``slider_load`` and ``drive_torque`` ``(n,)``; ``residual`` ``(n,)`` the
    largest violation of the 18 Newton-Euler equations, forces over the force
    scale and moments over the moment scale of the position.
    """

    j1_force: np.ndarray
    j1_moment: np.ndarray
    j2: np.ndarray
    j3: np.ndarray
    j4_force: np.ndarray
    j4_moment: np.ndarray
    slider_load: np.ndarray
    drive_torque: np.ndarray
    residual: np.ndarray


def solve_reactions(bodies: tuple[BodyInertia, BodyInertia, BodyInertia],
                    motions: tuple[BodyMotion, BodyMotion, BodyMotion],
                    p2: np.ndarray, p3: np.ndarray, k4: np.ndarray, gravity: np.ndarray,
                    drive_torque: float | None = None, slider_load: float | None = None) -> Reactions:
    """Solve the 17 unknown reaction components for crank, rod and slider.

    Parameters
    ----------
    bodies, motions : (crank, rod, slider)
    p2, p3 : ``(n, 3)`` crank pin and slider pin
    k4 : ``(3,)`` slider direction
    gravity : ``(3,)`` gravitational acceleration
    drive_torque, slider_load : float
        Exactly one is given; the other is solved.

    Notes
    -----
    At a dead centre in torque mode the division by :math:`z\\cdot(P_2\\times u)`
    gives ``inf``/``nan``; callers flag those positions.
    """
    if (drive_torque is None) == (slider_load is None):
        raise ValueError("solve_reactions: give exactly one of drive_torque / slider_load")
    crank, rod, slider = bodies
    rates = [momentum_rate(b, m) for b, m in zip(bodies, motions)]
    weights = [force_at(m.com, b.mass * np.broadcast_to(gravity, m.com.shape)) for b, m in zip(bodies, motions)]
    # D'Alembert: what the joints must supply to each body, f + eps m_O
    need = [r - w for r, w in zip(rates, weights)]
    d = p3 - p2
    a2 = np.linalg.norm(d, axis=1, keepdims=True)
    u = d / a2
    # rod moments about P2: P2-terms cancel in -(P3 - P2) x j3 = K2
    k2 = need[1].du - np.cross(p2, need[1].re)
    j3_perp = np.cross(u, k2) / a2
    # the axial rod force lambda, from the given load
    j2_perp = need[1].re + j3_perp
    tau0 = need[0].du[:, 2] + np.cross(p2, j2_perp)[:, 2]
    lever = np.cross(p2, u)[:, 2]
    s0 = need[2].re @ k4 - j3_perp @ k4
    if drive_torque is not None:
        lam = (drive_torque - tau0) / lever
    else:
        lam = (s0 - slider_load) / (u @ k4)
    j3 = j3_perp + lam[:, None] * u
    j2 = need[1].re + j3
    j1_force = need[0].re + j2
    j1_moment = need[0].du + np.cross(p2, j2)
    j4_force = need[2].re - j3
    j4_moment_o = need[2].du - np.cross(p3, j3)
    j4_moment = j4_moment_o - np.cross(p3, j4_force)
    residual = _newton_euler_residual(need, p2, p3, j1_force, j1_moment, j2, j3, j4_force, j4_moment_o)
    return Reactions(j1_force, j1_moment, j2, j3, j4_force, j4_moment, j4_force @ k4, j1_moment[:, 2], residual)


def _newton_euler_residual(need, p2, p3, f1, m1, j2, j3, f4, m4_o) -> np.ndarray:
    """Largest violation of the 18 equations of all three bodies, relative to the force / moment scale."""
    crank = Dual(f1, m1) - force_at(p2, j2) - need[0]
    rod = force_at(p2, j2) - force_at(p3, j3) - need[1]
    slider = force_at(p3, j3) + Dual(f4, m4_o) - need[2]
    forces = np.stack([f1, j2, j3, f4], axis=1)
    f_scale = np.maximum(np.abs(forces).max(axis=(1, 2)), 1e-300)
    lengths = np.maximum(np.linalg.norm(p2, axis=1), np.linalg.norm(p3, axis=1))
    m_scale = np.maximum(np.abs(np.stack([m1, m4_o], 1)).max(axis=(1, 2)), f_scale * lengths)
    f_err = np.abs(np.stack([crank.re, rod.re, slider.re], 1)).max(axis=(1, 2)) / f_scale
    m_err = np.abs(np.stack([crank.du, rod.du, slider.du], 1)).max(axis=(1, 2)) / m_scale
    return np.maximum(f_err, m_err)
