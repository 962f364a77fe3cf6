"""A universal joint between a spinning link and a translating one: the spin it determines.

A link whose ends sit in two ball joints (the slider crank's rod) is free to spin
about the line through them, with unit vector :math:`u`; the loop's table fixes that
gauge with zero spin (``docs/conventions.md``, "Rod spin").  When the second joint is a
universal joint instead, whose axis on the translating side is a fixed direction
:math:`k` and whose axis on the link's side is normal to the link,

.. math:: a = \\frac{u\\times k}{|u\\times k|}, \\qquad n = a\\times k,

the joint's cross keeps :math:`a\\perp k`: the link may not turn about :math:`n`, the
normal of both joint axes.  Its angular velocity is the gauge's :math:`\\omega_g` plus a
spin :math:`s` about :math:`u` that satisfies :math:`n\\cdot\\omega = 0`, and its angular
acceleration satisfies the derivative of that condition:

.. math:: s = -\\frac{n\\cdot\\omega_g}{n\\cdot u}, \\qquad
          \\dot s = -\\frac{\\dot n\\cdot\\omega + n\\cdot\\dot\\omega_g + s\\, n\\cdot\\dot u}{n\\cdot u},
          \\qquad \\dot n = (\\omega\\times a)\\times k, \\quad \\dot u = \\omega_g\\times u.

(:math:`n\\cdot u = -|u\\times k|` vanishes only with the link along :math:`k`, where the joint
locks.)  The spin is a rotation about the link's line :math:`\\hat L = u + \\varepsilon\\,P\\times u`
(:math:`P` a point of the line), so the twist gains :math:`s\\hat L` and its rate
:math:`\\dot s\\hat L + s\\dot{\\hat L}` with :math:`\\dot{\\hat L} = \\dot u + \\varepsilon(v_P\\times u
+ P\\times\\dot u)`.  The points of the loop do not depend on the spin, so the closure and
the rates of the table stand; only the link's own motion, and the joint's constraint
moment along :math:`n` (:func:`dualmech.core.reactions.solve_reactions`), change.  The same
condition as two revolute rows of the table (``docs/conventions.md``, "Joints") gives the
same motion: checked against finite differences of the link's frame
:math:`(u, a, u\\times a)` in ``tests/core/test_universal.py``.
"""

from __future__ import annotations

import numpy as np

from dualmech.core.dual import Dual, norm


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("ni,ni->n", a, b)[:, None]


def joint_axes(u: np.ndarray, k: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The link-side axis ``a = (u x k)/|u x k|`` and the moment axis ``n = a x k``, ``(n, 3)`` each.

    ``u`` ``(n, 3)`` the link's unit vector, ``k`` ``(n, 3)`` the fixed unit axis.
    """
    a = np.cross(u, k)
    with np.errstate(invalid="ignore", divide="ignore"):  # at the lock (u ∥ k) a is NaN: a joint_lock row
        a /= norm(a, axis=1, keepdims=True)
    return a, np.cross(a, k)


def link_frame(u: np.ndarray, k: np.ndarray) -> np.ndarray:
    """The link's axes ``(u, a, u x a)`` as the columns of ``(n, 3, 3)`` rotation matrices."""
    a, _ = joint_axes(u, k)
    return np.stack([u, a, np.cross(u, a)], axis=2)


def universal_motion(twist: Dual, accel: Dual, point: np.ndarray, u: np.ndarray,
                     k: np.ndarray) -> tuple[Dual, Dual]:
    """The link's twist and its rate with the spin the universal joint determines.

    Parameters
    ----------
    twist, accel : Dual ``(n, 3)``
        The link's zero-spin twist :math:`\\omega_g + \\varepsilon v_O` and its time derivative
        (world axes, about the world origin).
    point : ``(n, 3)``
        A point of the link's line (the ball centre ``P2``).
    u, k : ``(n, 3)``
        The link's unit vector and the fixed axis of the joint's other side (``k4``).
    """
    a, n = joint_axes(u, k)
    omega_g, alpha_g = twist.re, accel.re
    v_point = twist.du + np.cross(omega_g, point)
    n_u = _dot(n, u)
    spin = -_dot(n, omega_g) / n_u
    omega = omega_g + spin * u
    u_dot = np.cross(omega_g, u)
    n_dot = np.cross(np.cross(omega, a), k)
    spin_dot = -(_dot(n_dot, omega) + _dot(n, alpha_g) + spin * _dot(n, u_dot)) / n_u
    line = Dual(u, np.cross(point, u))
    line_dot = Dual(u_dot, np.cross(v_point, u) + np.cross(point, u_dot))
    return twist + line * spin, accel + line * spin_dot + line_dot * spin
