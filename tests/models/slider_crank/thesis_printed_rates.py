"""The thesis's velocity and acceleration formulas as printed (Rahman 1991, sections 2.7-2.8).

The rates (39)-(43), the accelerations (38a)-(42a) one function per printed equation, the velocity
equations (37a)-(37f) as residuals and the 6x5 system (38).  Where the transcribed text shows a single
dot on a term that differentiation makes a second derivative (S1 in (38a)-(42a)), ``s1dd`` is used; the
thesis example has S1 constant, so those terms vanish anyway.  ``docs/errata.md`` (E4, E5, E14) says
where they are wrong.  Nothing here imports the in-house solver.

Angles ``q`` are ``(n, 5)``: (theta2, eta2, theta3, eta3, S4); rates ``qd`` the same order.
"""

from __future__ import annotations

import numpy as np

c, s = np.cos, np.sin

# ================================================================= printed velocity and acceleration formulas


def printed_rates(q, w1, s1d, a1, a2) -> np.ndarray:
    """Eqs. (39)-(43): (theta2_dot, eta2_dot, theta3_dot, eta3_dot, S4_dot), ``(n, 5)``."""
    th2, et2, th3, et3, _ = q.T
    th2d = (s1d * c(th3) * s(et2) * c(et2) - a1 * (w1 * s(th2) * c(th3) + w1 * c(th2) * s(th3) * c(et2))
            - a2 * w1 * s(th3)) / (a2 * s(th3))
    th3d = (a1 * (w1 * c(th2) * s(th3) + w1 * s(th2) * c(th3) * c(et2)) - s1d * c(th3) * s(et2)) / (
        a2 * s(th3)
    )
    et2d = -s(et2) * (a1 * (w1 * c(th2) * s(th3) + w1 * s(th2) * c(th3) * c(et2)) - s1d * s(et2) * c(th3)) / (
        a2 * s(th2) * s(th3))
    et3d = (
        c(th2)
        * s(et2)
        * (w1 * a1 * (s(th2) * c(th3) * c(et2) + c(th2) * s(th3)) - s1d * s(et2) * c(th3))
        / (a2 * s(th2) * s(th3))
    )
    s4d = (s1d * s(et2) - w1 * a1 * s(th2) * c(et2)) / s(th3)
    return np.stack([th2d, et2d, th3d, et3d, s4d], -1)

def _sines_and_rates(q, qd):
    """sin/cos of theta2, theta3, eta2 and the rates theta2_dot, eta2_dot, theta3_dot of ``q``, ``qd``."""
    th2, et2, th3, _, _ = q.T
    th2d, et2d, th3d, _, _ = qd.T
    return s(th2), c(th2), s(th3), c(th3), s(et2), c(et2), th2d, et2d, th3d


def theta2_ddot_38a(q, qd, w1, w1d, s1d, s1dd, a1, a2) -> np.ndarray:
    """Eq. (38a), printed for theta2_ddot: the quotient-rule derivative of (39), ``(n,)``."""
    s2, c2, s3, c3, se, ce, th2d, et2d, th3d = _sines_and_rates(q, qd)
    t1, t1d = w1, w1d
    return (
        a2
        * s3
        * (
            s1dd * c3 * se * ce
            - s1d * th3d * s3 * se * ce
            + s1d * et2d * c3 * ce**2
            - s1d * et2d * c3 * se**2
            - a1
            * (
                t1d * s2 * c3
                + t1 * th2d * c2 * c3
                - t1 * th3d * s2 * s3
                + t1d * c2 * s3 * ce
                - t1 * th2d * s2 * s3 * ce
                + t1 * th3d * c2 * c3 * ce
                - t1 * et2d * c2 * s3 * se
            )
            - a2 * t1d * s3
            - a2 * t1 * th3d * c3
        )
        - a2 * th3d * c3 * (s1d * c3 * se * ce - a1 * (t1 * s2 * c3 + t1 * c2 * s3 * ce) - a2 * t1 * s3)
    ) / (a2 * s3) ** 2


def theta3_ddot_39a(q, qd, w1, w1d, s1d, s1dd, a1, a2) -> np.ndarray:
    """Eq. (39a), printed for theta3_ddot: the quotient-rule derivative of (40), ``(n,)``."""
    s2, c2, s3, c3, se, ce, th2d, et2d, th3d = _sines_and_rates(q, qd)
    t1, t1d = w1, w1d
    return (
        a2
        * s3
        * (
            a1
            * (
                t1d * c2 * s3
                - t1 * th2d * s2 * s3
                + t1 * th3d * c2 * c3
                + t1d * s2 * c3 * ce
                + t1 * th2d * c2 * c3 * ce
                - t1 * th3d * s2 * s3 * ce
                - t1 * et2d * s2 * c3 * se
            )
            - s1dd * c3 * se
            + s1d * th3d * s3 * se
            - s1d * et2d * c3 * ce
        )
        - a2 * th3d * c3 * (a1 * (t1 * c2 * s3 + t1 * s2 * c3 * ce) - s1d * c3 * se)
    ) / (a2 * s3) ** 2


def eta2_ddot_40a(q, qd, w1, w1d, s1d, s1dd, a1, a2) -> np.ndarray:
    """Eq. (40a), printed for eta2_ddot: the quotient-rule derivative of (41) (divides by sin theta2),
    ``(n,)``."""
    s2, c2, s3, c3, se, ce, th2d, et2d, th3d = _sines_and_rates(q, qd)
    t1, t1d = w1, w1d
    x = a1 * (t1 * c2 * s3 + t1 * s2 * c3 * ce) - s1d * se * c3
    xd = (
        a1
        * (
            t1d * c2 * s3
            - t1 * th2d * s2 * s3
            + t1 * th3d * c2 * c3
            + t1d * s2 * c3 * ce
            + t1 * th2d * c2 * c3 * ce
            - t1 * th3d * s2 * s3 * ce
            - t1 * et2d * s2 * c3 * se
        )
        - s1dd * se * c3
        - s1d * et2d * ce * c3
        + s1d * th3d * se * s3
    )
    return (a2 * s2 * s3 * (-et2d * ce * x - se * xd) + a2 * se * x * (th2d * c2 * s3 + th3d * s2 * c3)) / (
        a2 * s2 * s3
    ) ** 2


def eta3_ddot_41a(q, qd, w1, w1d, s1d, s1dd, a1, a2) -> np.ndarray:
    """Eq. (41a), printed for eta3_ddot: the quotient-rule derivative of (42) (divides by sin theta2),
    ``(n,)``."""
    s2, c2, s3, c3, se, ce, th2d, et2d, th3d = _sines_and_rates(q, qd)
    t1, t1d = w1, w1d
    y = t1 * a1 * (s2 * c3 * ce + c2 * s3) - s1d * se * c3
    yd = (
        t1d * a1 * (s2 * c3 * ce + c2 * s3)
        + t1
        * a1
        * (th2d * c2 * c3 * ce - th3d * s2 * s3 * ce - et2d * s2 * c3 * se + th3d * c2 * c3 - th2d * s2 * s3)
        - s1dd * se * c3
        - s1d * et2d * ce * c3
        + s1d * th3d * se * s3
    )
    return (a2 * s2 * s3 * ((-th2d * s2 * se + et2d * c2 * ce) * y + c2 * se * yd)
            - a2 * c2 * se * y * (th2d * c2 * s3 + th3d * s2 * c3)) / (a2 * s2 * s3)**2


def s4_ddot_42a(q, qd, w1, w1d, s1d, s1dd, a1, a2) -> np.ndarray:
    """Eq. (42a), printed for S4_ddot: the quotient-rule derivative of (43), ``(n,)``."""
    s2, c2, s3, c3, se, ce, th2d, et2d, th3d = _sines_and_rates(q, qd)
    t1, t1d = w1, w1d
    return (
        s3 * (s1dd * se + s1d * et2d * ce - a1 * (t1d * s2 * ce + t1 * th2d * c2 * ce - t1 * et2d * s2 * se))
        - (s1d * se - t1 * a1 * s2 * ce) * th3d * c3
    ) / s3**2


def printed_accels(q, qd, w1, w1d, s1d, s1dd, a1, a2) -> np.ndarray:
    """Eqs. (38a)-(42a): (theta2_ddot, eta2_ddot, theta3_ddot, eta3_ddot, S4_ddot) from angles ``q`` and rates
    ``qd``, ``(n, 5)`` (the printed order is (38a) theta2, (39a) theta3, (40a) eta2, (41a) eta3, (42a) S4)."""
    args = (q, qd, w1, w1d, s1d, s1dd, a1, a2)
    return np.stack([theta2_ddot_38a(*args), eta2_ddot_40a(*args), theta3_ddot_39a(*args),
                     eta3_ddot_41a(*args), s4_ddot_42a(*args)], -1)


def eq37_residuals(q, qd, w1, s1d, a1, a2) -> np.ndarray:
    """Left minus right side of eqs. (37a)-(37f), ``(n, 6)``; qd in the order of :func:`printed_rates`."""
    th2, et2, th3, et3, _ = q.T
    th2d, et2d, th3d, et3d, s4d = qd.T
    return np.stack([
        -(w1 + th2d) * s(et2) + et2d * s(th2) * c(et2),
        w1 * a1 * s(th2) * c(et2) - s1d * s(et2) + s4d * s(th3),
        et2d * c(th2) + et3d,
        w1 * (a1 * c(th2) + a2 * c(et2)) + th2d * a2 * c(et2) + et2d * a2 * s(th2) * s(et2) - s4d * c(th3),
        (w1 + th2d) * c(et2) + et2d * s(th2) * s(et2) + th3d,
        w1 * a1 * s(th2) * s(et2) - et2d * a2 * c(th2) + s1d * c(et2)], -1)


def system38(q, w1, s1d, a1, a2):
    """Printed 6x5 matrix and right side of eq. (38); unknowns (theta2, theta3, eta2, eta3, S4) dots."""
    th2, et2, th3, _, _ = q.T
    z, o = np.zeros_like(th2), np.ones_like(th2)
    a = np.stack([
        np.stack([-s(et2), z, s(th2) * c(et2), z, z], -1),
        np.stack([z, z, z, z, s(th3)], -1),
        np.stack([z, z, c(th2), o, z], -1),
        np.stack([a2 * c(et2), z, a2 * s(th2) * s(et2), z, -c(th3)], -1),
        np.stack([c(et2), o, s(th2) * s(et2), z, z], -1),
        np.stack([z, z, -a2 * c(th2), z, z], -1)], -2)
    b = np.stack(
        [
            w1 * s(et2),
            -w1 * a1 * s(th2) * c(et2) + s1d * s(et2),
            z,
            -w1 * (a1 * c(th2) + a2 * c(et2)),
            -w1 * c(et2),
            -w1 * a1 * s(th2) - s1d * c(et2),
        ],
        -1,
    )
    return a, b
