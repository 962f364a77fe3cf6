"""Inverse dynamics of the generalized slider crank: the reaction wrench at every joint.

Thesis section 2.8 in world coordinates.  Each body's dual momentum about the
world origin (the inertia binor applied to the body's dual velocity, eq. 49-53)
is :math:`\\hat H = m v_G + \\varepsilon (I_G\\omega + G\\times m v_G)`; its rate
(dual Euler equation, eq. 59-61) is

.. math:: \\dot{\\hat H} = m a_G
          + \\varepsilon\\,(I_G\\dot\\omega + \\omega\\times I_G\\omega + G\\times m a_G)

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

from dualmech.core.dual import Dual, norm, scalar_type
from dualmech.core.inertia import BodyInertia, MassArrays

Body = BodyInertia | MassArrays


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


def _mass(body: Body) -> np.ndarray:
    """Mass broadcastable against ``(n, 3)`` arrays."""
    return np.asarray(body.mass, dtype=scalar_type(body.mass))[..., None]


def _world_inertia(body: Body, rotation: np.ndarray) -> np.ndarray:
    return rotation @ body.inertia @ np.swapaxes(rotation, -1, -2)


def body_motion(body: Body, rotation: np.ndarray, origin: np.ndarray, twist: Dual, accel: Dual) -> BodyMotion:
    """Centre-of-mass motion from a body's twist :math:`\\omega + \\varepsilon v_O` and its rate.

    .. math:: v_G = v_O + \\omega\\times G, \\qquad
              a_G = \\dot v_O + \\dot\\omega\\times G + \\omega\\times v_G
    """
    com = origin + (rotation @ np.asarray(body.com)[..., None])[..., 0]
    omega, omega_dot = twist.re, accel.re
    vel = twist.du + np.cross(omega, com)
    acc = accel.du + np.cross(omega_dot, com) + np.cross(omega, vel)
    return BodyMotion(rotation, origin, com, vel, acc, omega, omega_dot)


def momentum(body: Body, motion: BodyMotion) -> Dual:
    """Dual momentum about the world origin, :math:`m v_G + \\varepsilon(I_G\\omega + G\\times m v_G)`,
    ``(n, 3)``."""
    i_world = _world_inertia(body, motion.rotation)
    lin = _mass(body) * motion.com_vel
    return Dual(lin, np.einsum("nij,nj->ni", i_world, motion.omega) + np.cross(motion.com, lin))


def momentum_rate(body: Body, motion: BodyMotion) -> Dual:
    """Rate of the dual momentum about the (fixed) world origin, ``(n, 3)`` (dual Euler equation)."""
    i_world = _world_inertia(body, motion.rotation)
    lin = _mass(body) * motion.com_acc
    spin = np.einsum("nij,nj->ni", i_world, motion.omega)
    ang = np.einsum("nij,nj->ni", i_world, motion.omega_dot) + np.cross(motion.omega, spin)
    return Dual(lin, ang + np.cross(motion.com, lin))


def force_at(point: np.ndarray, force: np.ndarray) -> Dual:
    """Dual force :math:`f + \\varepsilon P\\times f` of a force through ``point``."""
    return Dual(force, np.cross(point, force))


def kinetic_energy(body: Body, motion: BodyMotion) -> np.ndarray:
    """:math:`\\tfrac12 m v_G^2 + \\tfrac12 \\omega\\cdot I_G\\omega`, shape ``(n,)``."""
    rot = np.einsum("ni,nij,nj->n", motion.omega, _world_inertia(body, motion.rotation), motion.omega)
    return 0.5 * _mass(body)[..., 0] * np.einsum("ni,ni->n", motion.com_vel, motion.com_vel) + 0.5 * rot


@dataclass(frozen=True)
class Reactions:
    """Joint reactions at ``n`` positions, world axes (``docs/conventions.md``).

    ``j1_force``, ``j1_moment`` (about O): ground on crank; ``j2``: crank on rod at P2;
    ``j3``: rod on slider at P3, ``j3_moment`` its moment (a universal joint's; zero for a ball);
    ``j4_force``, ``j4_moment`` (about P3): ground on slider; ``slider_load`` and ``drive_torque``
    ``(n,)``; ``residual`` ``(n,)`` the largest violation of the 18 Newton-Euler equations, forces
    over the force scale and moments over the moment scale of the position.
    """

    j1_force: np.ndarray
    j1_moment: np.ndarray
    j2: np.ndarray
    j3: np.ndarray
    j3_moment: np.ndarray
    j4_force: np.ndarray
    j4_moment: np.ndarray
    slider_load: np.ndarray
    drive_torque: np.ndarray
    residual: np.ndarray

    def columns(self) -> dict[str, np.ndarray]:
        """The reaction columns of a result table (``docs/conventions.md``), each ``(n,)``, in the order
        of :data:`~dualmech.core.table.REACTION_COLUMNS`: ``j1_fx`` ... ``j3_mz`` ... ``j4_mz``,
        ``slider_load``, ``drive_torque``."""
        cols = {}
        for name, arr in (("j1_f", self.j1_force), ("j1_m", self.j1_moment), ("j2_f", self.j2),
                          ("j3_f", self.j3), ("j3_m", self.j3_moment), ("j4_f", self.j4_force),
                          ("j4_m", self.j4_moment)):
            for k, axis in enumerate("xyz"):
                cols[f"{name}{axis}"] = arr[:, k]
        return {**cols, "slider_load": self.slider_load, "drive_torque": self.drive_torque}


def solve_reactions(bodies: tuple[Body, Body, Body], motions: tuple[BodyMotion, BodyMotion, BodyMotion],
                    p2: np.ndarray, p3: np.ndarray, k4: np.ndarray, gravity: np.ndarray,
                    drive_torque: np.ndarray, slider_load: np.ndarray,
                    moment_axis: np.ndarray | None = None) -> Reactions:
    """Solve the 17 unknown reaction components for crank, rod and slider (18 with a universal joint).

    Parameters
    ----------
    bodies, motions : (crank, rod, slider)
    p2, p3 : ``(n, 3)`` crank pin and slider pin
    k4 : ``(3,)`` or ``(n, 3)`` slider direction
    gravity : ``(3,)`` or ``(n, 3)`` gravitational acceleration
    drive_torque, slider_load : float or ``(n,)``
        At each position exactly one is finite (given); the other is NaN and solved.
    moment_axis : ``(n, 3)``, optional
        A universal joint 3's moment axis ``n`` (:func:`dualmech.core.universal.joint_axes`; zero rows and
        ``None``: ball joints); :math:`\\mu n`, the 18th unknown: :math:`\\mu = -u\\cdot K_2/(n\\cdot u)`.

    Notes
    -----
    At a dead centre in torque mode the division by :math:`z\\cdot(P_2\\times u)`
    gives ``inf``/``nan``; callers flag those positions.
    """
    n = p2.shape[0]
    torque = np.broadcast_to(np.asarray(drive_torque, dtype=scalar_type(drive_torque)), (n,))
    load = np.broadcast_to(np.asarray(slider_load, dtype=scalar_type(slider_load)), (n,))
    torque_mode = np.isfinite(torque)
    if np.any(torque_mode == np.isfinite(load)):
        raise ValueError("solve_reactions: at every position give exactly one of drive_torque / slider_load")
    k4 = np.broadcast_to(k4, p2.shape)
    weights = [force_at(m.com, _mass(b) * np.broadcast_to(gravity, m.com.shape))
               for b, m in zip(bodies, motions)]
    # D'Alembert: what the joints must supply to each body, f + eps m_O
    need = [momentum_rate(b, m) - w for b, m, w in zip(bodies, motions, weights)]
    d = p3 - p2
    a2 = norm(d, axis=1, keepdims=True)
    u = d / a2
    # rod moments about P2: -(P3 - P2) x j3 = K2, hence the part of j3 across the rod
    k2 = need[1].du - np.cross(p2, need[1].re)
    j3_moment = _universal_moment(k2, u, moment_axis)
    k2 = k2 + j3_moment
    j3_perp = np.cross(u, k2) / a2
    # the axial rod force lambda, from the given load
    j2_perp = need[1].re + j3_perp
    tau0 = need[0].du[:, 2] + np.cross(p2, j2_perp)[:, 2]
    lever = np.cross(p2, u)[:, 2]
    s0 = np.einsum("ni,ni->n", need[2].re - j3_perp, k4)
    lam = np.where(torque_mode, (torque - tau0) / lever, (s0 - load) / np.einsum("ni,ni->n", u, k4))
    j3 = j3_perp + lam[:, None] * u
    j2 = need[1].re + j3
    j1_force = need[0].re + j2
    j1_moment = need[0].du + np.cross(p2, j2)
    j4_force = need[2].re - j3
    j4_moment_o = need[2].du - np.cross(p3, j3) - j3_moment
    j4_moment = j4_moment_o - np.cross(p3, j4_force)
    residual = _newton_euler_residual(need, p2, p3, j1_force, j1_moment, j2, (j3, j3_moment), j4_force,
                                      j4_moment_o)
    return Reactions(j1_force, j1_moment, j2, j3, j3_moment, j4_force, j4_moment,
                     np.einsum("ni,ni->n", j4_force, k4), j1_moment[:, 2], residual)


def _universal_moment(k2: np.ndarray, u: np.ndarray, axis: np.ndarray | None) -> np.ndarray:
    """The universal joint's moment on the slider, :math:`\\mu n` with :math:`\\mu = -u\\cdot K_2/(n\\cdot u)`
    ``(n, 3)``; zero where ``axis`` is zero (a ball joint)."""
    if axis is None:
        return np.zeros_like(k2)
    n_u = np.einsum("ni,ni->n", axis, u)
    mu = np.divide(-np.einsum("ni,ni->n", u, k2), n_u, out=np.zeros_like(n_u), where=n_u != 0.0)
    return mu[:, None] * axis


def _newton_euler_residual(need, p2, p3, f1, m1, j2, j3, f4, m4_o) -> np.ndarray:
    """Largest violation of the 18 equations of all three bodies, relative to the force / moment scale;
    ``j3`` is joint 3's force and moment."""
    j3, j3_moment = j3
    crank = Dual(f1, m1) - force_at(p2, j2) - need[0]
    rod = force_at(p2, j2) - force_at(p3, j3) - Dual(np.zeros_like(j3), j3_moment) - need[1]
    slider = force_at(p3, j3) + Dual(f4, m4_o + j3_moment) - need[2]
    forces = np.stack([f1, j2, j3, f4], axis=1)
    f_scale = np.maximum(np.abs(forces).max(axis=(1, 2)), 1e-300)
    lengths = np.maximum(np.linalg.norm(p2, axis=1), np.linalg.norm(p3, axis=1))
    m_scale = np.maximum(np.abs(np.stack([m1, m4_o], 1)).max(axis=(1, 2)), f_scale * lengths)
    f_err = np.abs(np.stack([crank.re, rod.re, slider.re], 1)).max(axis=(1, 2)) / f_scale
    m_err = np.abs(np.stack([crank.du, rod.du, slider.du], 1)).max(axis=(1, 2)) / m_scale
    return np.maximum(f_err, m_err)
