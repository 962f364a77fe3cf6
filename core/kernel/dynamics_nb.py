"""Dual momentum and D'Alembert for one rigid body at one position, compiled (thesis section 2.8).

The per-position form of :func:`dualmech.core.reactions.body_motion` and
:func:`~dualmech.core.reactions.momentum_rate`: from a body's twist
:math:`\\omega + \\varepsilon v_O` and its rate, what the joints must supply to it,

.. math:: \\hat N = \\dot{\\hat H} - \\hat W = m a_G - m g
          + \\varepsilon\\,(I_G\\dot\\omega + \\omega\\times I_G\\omega
          + G\\times m (a_G - g))

(dual Euler equation, eq. 59-61, less the weight as a dual force through ``G``),
a dual force :math:`f + \\varepsilon m_O` about the world origin.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from dualmech.core.kernel.dual_nb import INLINE, JIT, cross, matvec


@njit(**INLINE)
def required_wrench(
    mass: float,
    com_body: np.ndarray,
    inertia: np.ndarray,
    rotation: np.ndarray,
    origin: np.ndarray,
    twist: np.ndarray,
    accel: np.ndarray,
    gravity: np.ndarray,
    scratch: np.ndarray,
    out: np.ndarray,
) -> None:
    """``out`` ``(2, 3)``: :math:`\\hat N` of the module docstring, world axes, moments about O.

    ``com_body`` ``(3,)`` and ``inertia`` ``(3, 3)`` in body axes (about the centre of
    mass); ``rotation`` ``(3, 3)`` body axes in world; ``origin`` ``(3,)``; ``twist``,
    ``accel`` ``(2, 3)``; ``scratch`` ``(8, 3)``.
    """
    com, vel, acc, tmp, spin, ang, lin, i_w = (
        scratch[0],
        scratch[1],
        scratch[2],
        scratch[3],
        scratch[4],
        scratch[5],
        scratch[6],
        scratch[7],
    )
    omega, omega_dot = twist[0], accel[0]
    matvec(rotation, com_body, com)
    for i in range(3):
        com[i] += origin[i]
    cross(omega, com, tmp)
    for i in range(3):
        vel[i] = twist[1, i] + tmp[i]
    cross(omega_dot, com, acc)
    cross(omega, vel, tmp)
    for i in range(3):
        acc[i] += accel[1, i] + tmp[i]
    _world_inertia_times(rotation, inertia, omega, i_w, spin)  # spin = I_w omega
    _world_inertia_times(rotation, inertia, omega_dot, i_w, ang)
    cross(omega, spin, tmp)
    for i in range(3):
        ang[i] += tmp[i]
        lin[i] = mass * acc[i] - mass * gravity[i]
    cross(com, lin, tmp)
    for i in range(3):
        out[0, i] = lin[i]
        out[1, i] = ang[i] + tmp[i]


@njit(**JIT)
def _world_inertia_times(
    rotation: np.ndarray, inertia: np.ndarray, v: np.ndarray, tmp: np.ndarray, out: np.ndarray
) -> None:
    """``out = R I R^T v`` (``tmp`` ``(3,)`` scratch)."""
    for i in range(3):
        out[i] = rotation[0, i] * v[0] + rotation[1, i] * v[1] + rotation[2, i] * v[2]
    matvec(inertia, out, tmp)
    matvec(rotation, tmp, out)
