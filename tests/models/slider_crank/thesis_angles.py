"""The thesis's Z-Y angles of an exact closed position, and their derivatives with respect to theta1.

S4 comes from the sphere-line intersection (:mod:`tests.oracles`), the angles (theta2, eta2, theta3,
eta3) are read off the rod direction; derivatives are 8th-order central differences.  Independent of
the in-house solver and of the printed equations (``tests/models/slider_crank/thesis_printed.py``).
"""

from __future__ import annotations

import numpy as np

from tests import oracles

c, s = np.cos, np.sin

# ========================================================================= thesis angles of a closed position


def exact_s4(th1, s1, a1, a2, a4, al4):
    """Sphere-line intersection on the branch (P3 - P2).k4 < 0 (:mod:`tests.oracles`); scalar or array th1."""
    th1 = np.asarray(th1, dtype=float)
    foot, k = oracles.slider_line(a4, al4)
    p2 = np.stack([a1 * c(th1), a1 * s(th1), np.full_like(th1, s1)], -1)
    s4 = oracles.sphere_line_s4(p2, foot, k, a2)
    return s4.reshape(th1.shape)


def thesis_angles(th1, s1, a1, a2, a4, al4) -> np.ndarray:
    """(theta2, eta2, theta3, eta3, S4) of the exact closed position, ``(n, 5)``.

    The Z-Y angles are read off the rod direction u: forward, u in frame {2} is
    (c th2 c et2, s th2 c et2, -s et2); backward, u in frame {4} is
    (c th3 c et3, c th3 s et3, s th3) (first row of eq. 3), with |eta| < 90 deg.
    In a spatial case the two pairs imply different rod frames (errata E2).
    """
    th1 = np.atleast_1d(np.asarray(th1, dtype=float))
    s4 = exact_s4(th1, s1, a1, a2, a4, al4)
    k = np.array([0.0, s(al4), c(al4)])
    p2 = np.stack([a1 * c(th1), a1 * s(th1), np.full_like(th1, s1)], -1)
    u = (np.array([-a4, 0.0, 0.0]) - s4[:, None] * k - p2) / a2
    ucx = c(th1) * u[:, 0] + s(th1) * u[:, 1]
    ucy = -s(th1) * u[:, 0] + c(th1) * u[:, 1]
    th2 = np.arctan2(ucy, ucx)
    et2 = -np.arcsin(u[:, 2])
    u4x, u4y, u4z = u[:, 0], c(al4) * u[:, 1] - s(al4) * u[:, 2], s(al4) * u[:, 1] + c(al4) * u[:, 2]
    et3 = np.arctan(u4y / u4x)
    th3 = np.arctan2(u4z, u4x / c(et3))
    return np.stack([th2, et2, th3, et3, s4], -1)


_W1 = np.array([1 / 280, -4 / 105, 1 / 5, -4 / 5, 0, 4 / 5, -1 / 5, 4 / 105, -1 / 280])
_W2 = np.array([-1 / 560, 8 / 315, -1 / 5, 8 / 5, -205 / 72, 8 / 5, -1 / 5, 8 / 315, -1 / 560])


def derivatives(f, x: np.ndarray, h: float = 2e-3, angles: slice = slice(0, 0)):
    """f, f', f'' by 8th-order central differences (error ~ h^8 f^(9) + eps f / h^2), vectorized over x.

    Columns ``angles`` of ``f``'s ``(n, k)`` output are unwrapped against the centre point first.
    """
    vals = np.stack([f(x + k * h) for k in range(-4, 5)])
    centre = vals[4]
    vals[..., angles] = centre[..., angles] + np.angle(np.exp(1j * (vals[..., angles] - centre[..., angles])))
    return centre, np.tensordot(_W1, vals, 1) / h, np.tensordot(_W2, vals, 1) / h**2


def angle_derivatives(geom, th1: np.ndarray):
    """Thesis angles ``(n, 5)`` and their first and second derivatives with respect to theta1."""
    return derivatives(lambda t: thesis_angles(t, *geom), th1, angles=slice(0, 4))
