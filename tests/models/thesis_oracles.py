"""Test oracles for the errata and findings tests: the thesis's printed equations, transcribed, and an
independent closed-form kinematics / Newton-Euler model.  Nothing here imports the in-house solver.

Transcriptions follow Rahman (1991) symbol by symbol (``docs/errata.md`` says where they are wrong):
matrices (1)-(4), the derivative operators (2a)-(4a) and (8)-(10), the Newton-Raphson system (24)-(25),
the velocity equations (37a)-(37f), (38), (39)-(43) and the accelerations (38a)-(42a).  Where the
transcribed text shows a single dot on a term that differentiation makes a second derivative (S1 in
(38a)-(42a)), ``s1dd`` is used; the thesis example has S1 constant, so those terms vanish anyway.

The independent model: S4 of the sphere-line intersection and its time derivatives in closed form,
the rod's zero-spin angular velocity ``u x u_dot``, and the 18 Newton-Euler equations of crank, rod and
slider in world axes (moments about O), assembled as a matrix and solved by least squares.
"""

from __future__ import annotations

import numpy as np

from tests import oracles

c, s = np.cos, np.sin

# ============================================================================ printed matrices (1)-(4)


def m1(th1: float, s1: float, a1: float) -> tuple[np.ndarray, np.ndarray]:
    """Eq. (1): primary and dual part of 1_2M."""
    p = np.array([[c(th1), -s(th1), 0], [s(th1), c(th1), 0], [0, 0, 1]])
    d = np.array(
        [[-s1 * s(th1), -s1 * c(th1), a1 * s(th1)], [s1 * c(th1), -s1 * s(th1), -a1 * c(th1)], [0, a1, 0]]
    )
    return p, d


def l2(th2: float, et2: float, a2: float) -> tuple[np.ndarray, np.ndarray]:
    """Eq. (2)."""
    p = np.array([[c(th2) * c(et2), -s(th2), c(th2) * s(et2)], [s(th2) * c(et2), c(th2), s(th2) * s(et2)],
                  [-s(et2), 0, c(et2)]])
    d = np.array(
        [[0, a2 * c(th2) * s(et2), a2 * s(th2)], [0, a2 * s(th2) * s(et2), -a2 * c(th2)], [0, a2 * c(et2), 0]]
    )
    return p, d


def l3(th3: float, et3: float) -> tuple[np.ndarray, np.ndarray]:
    """Eq. (3) (no dual part: a3 = 0)."""
    p = np.array([[c(th3) * c(et3), c(th3) * s(et3), s(th3)], [s(th3) * c(et3), s(th3) * s(et3), -c(th3)],
                  [-s(et3), c(et3), 0]])
    return p, np.zeros((3, 3))


def m4(s4: float, al4: float, a4: float) -> tuple[np.ndarray, np.ndarray]:
    """Eq. (4)."""
    p = np.array([[1, 0, 0], [0, c(al4), -s(al4)], [0, s(al4), c(al4)]])
    d = np.array(
        [[0, -s4 * c(al4), s4 * s(al4)], [s4, -a4 * s(al4), -a4 * c(al4)], [0, a4 * c(al4), -a4 * s(al4)]]
    )
    return p, d


def dl2_dth2(th2, et2, a2):
    """Printed derivative of (2) with respect to theta2 (section 2.5)."""
    p = np.array(
        [
            [-s(th2) * c(et2), -c(th2), -s(th2) * s(et2)],
            [c(th2) * c(et2), -s(th2), c(th2) * s(et2)],
            [0, 0, 0],
        ]
    )
    d = np.array([[0, -a2 * s(th2) * s(et2), a2 * c(th2)], [0, a2 * c(th2) * s(et2), a2 * s(th2)], [0, 0, 0]])
    return p, d


def dl2_det2(th2, et2, a2):
    p = np.array(
        [
            [-c(th2) * s(et2), 0, c(th2) * c(et2)],
            [-s(th2) * s(et2), 0, s(th2) * c(et2)],
            [-c(et2), 0, -s(et2)],
        ]
    )
    d = np.array([[0, a2 * c(th2) * c(et2), 0], [0, a2 * s(th2) * c(et2), 0], [0, -a2 * s(et2), 0]])
    return p, d


def dl3_dth3(th3, et3):
    return np.array([[-s(th3) * c(et3), -s(th3) * s(et3), c(th3)], [c(th3) * c(et3), c(th3) * s(et3), s(th3)],
                     [0, 0, 0]]), np.zeros((3, 3))


def dl3_det3(th3, et3):
    return np.array([[-c(th3) * s(et3), c(th3) * c(et3), 0], [-s(th3) * s(et3), s(th3) * c(et3), 0],
                     [-c(et3), -s(et3), 0]]), np.zeros((3, 3))


def dm4_ds4(al4):
    return np.zeros((3, 3)), np.array([[0, -c(al4), s(al4)], [1, 0, 0], [0, 0, 0]])


def q_theta():
    """Eqs. (2a), (3a), (8)."""
    return np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 0]]), np.zeros((3, 3))


def q_eta(th):
    """Eqs. (2b), (3b), (9)."""
    return np.array([[0, 0, c(th)], [0, 0, s(th)], [-c(th), -s(th), 0]]), np.zeros((3, 3))


def q_s():
    """Eqs. (4a), (10): epsilon times the Q_theta pattern."""
    return np.zeros((3, 3)), np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 0]])


def dmul(a, b):
    """Product of dual matrices given as (primary, dual)."""
    return a[0] @ b[0], a[0] @ b[1] + a[1] @ b[0]


def dtr(a):
    return a[0].T, a[1].T


def dvec(a, v):
    """Dual matrix times dual vector (primary, dual)."""
    return a[0] @ v[0], a[0] @ v[1] + a[1] @ v[0]


def frame_origin(a) -> np.ndarray:
    """Origin ``p`` of the later frame in the earlier one, from :math:`\\hat M = R + \\varepsilon[p]_\\times
    R`."""
    m = a[1] @ a[0].T
    return 0.5 * np.array([m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1]])


def loop_product(x, th1, s1, a1, a2, a4, al4):
    """B of eq. (18) for the thesis's unknowns x = (theta2, eta2, theta3, eta3, S4)."""
    th2, et2, th3, et3, s4 = x
    return dmul(dmul(dmul(m1(th1, s1, a1), l2(th2, et2, a2)), l3(th3, et3)), m4(s4, al4, a4))


def closure_residual(x, th1, s1, a1, a2, a4, al4) -> np.ndarray:
    """All 18 entries of :math:`\\hat B - \\hat I` (dual part over a2): eq. (5) as a residual vector."""
    b = loop_product(x, th1, s1, a1, a2, a4, al4)
    return np.concatenate([(b[0] - np.eye(3)).ravel(), b[1].ravel() / a2])


def newton_system(x, th1, s1, a1, a2, a4, al4, diagonal: bool = True):
    """A of eq. (24) and V of eq. (25) (``diagonal=False``: V of the unmodified eqs. (20)-(21))."""
    th2, et2, th3, et3, s4 = x
    p1 = m1(th1, s1, a1)
    p2 = dmul(p1, l2(th2, et2, a2))
    p3 = dmul(p2, l3(th3, et3))
    hs = [dmul(dmul(p1, q_theta()), dtr(p1)), dmul(dmul(p1, q_eta(th2)), dtr(p1)),
          dmul(dmul(p2, q_theta()), dtr(p2)), dmul(dmul(p2, q_eta(th3)), dtr(p2)),
          dmul(dmul(p3, q_s()), dtr(p3))]
    idx = [(0, 1), (0, 2), (1, 2)]
    a = np.array([[h[part][i, j] for h in hs] for part in (0, 1) for (i, j) in idx])
    bp, bd = dmul(p3, m4(s4, al4, a4))
    if diagonal:
        vp = [
            bp[1, 0] + bp[0, 0] + bp[1, 1] - 2,
            bp[2, 0] + bp[0, 0] + bp[2, 2] - 2,
            bp[2, 1] + bp[1, 1] + bp[2, 2] - 2,
        ]
    else:
        vp = [bp[1, 0], bp[2, 0], bp[2, 1]]
    return a, np.array(vp + [bd[1, 0], bd[2, 0], bd[2, 1]])


def thesis_newton(x, geom, iterations: int, diagonal: bool = True):
    """The printed iteration: Delta = (A^T A)^-1 A^T V (eq. 23a), x += Delta. Returns x and |B - I| per
    step."""
    history = []
    for _ in range(iterations):
        a, v = newton_system(x, *geom, diagonal=diagonal)
        x = x + np.linalg.solve(a.T @ a, a.T @ v)
        history.append(float(np.linalg.norm(closure_residual(x, *geom))))
    return x, np.array(history)


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


def printed_accels(q, qd, w1, w1d, s1d, s1dd, a1, a2) -> np.ndarray:
    """Eqs. (38a)-(42a): (theta2_ddot, eta2_ddot, theta3_ddot, eta3_ddot, S4_ddot) from angles ``q`` and rates
    ``qd``."""
    th2, et2, th3, et3, _ = q.T
    th2d, et2d, th3d, et3d, _ = qd.T
    t1, t1d = w1, w1d
    s2, c2, s3, c3, se, ce = s(th2), c(th2), s(th3), c(th3), s(et2), c(et2)
    th2dd = (
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
    th3dd = (
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
    et2dd = (a2 * s2 * s3 * (-et2d * ce * x - se * xd) + a2 * se * x * (th2d * c2 * s3 + th3d * s2 * c3)) / (
        a2 * s2 * s3
    ) ** 2
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
    et3dd = (a2 * s2 * s3 * ((-th2d * s2 * se + et2d * c2 * ce) * y + c2 * se * yd)
             - a2 * c2 * se * y * (th2d * c2 * s3 + th3d * s2 * c3)) / (a2 * s2 * s3)**2
    s4dd = (
        s3 * (s1dd * se + s1d * et2d * ce - a1 * (t1d * s2 * ce + t1 * th2d * c2 * ce - t1 * et2d * s2 * se))
        - (s1d * se - t1 * a1 * s2 * ce) * th3d * c3
    ) / s3**2
    return np.stack([th2dd, et2dd, th3dd, et3dd, s4dd], -1)


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


# ======================================================================== independent kinematics and dynamics


def kinematics(case, theta: np.ndarray) -> dict[str, np.ndarray]:
    """Closed-form positions, velocities, accelerations of P2, P3, u and S4 at crank angles ``theta``
    (rad)."""
    g, m = case.geometry, case.motion
    a1, a2, a4, al = g.crank_length, g.rod_length, g.slider_offset, g.slider_twist
    w, wd, amp, cyc = m.speed, m.accel, m.axial_amplitude, m.axial_cycles
    s1 = g.crank_axial_shift + amp * s(cyc * theta)
    s1d = amp * cyc * c(cyc * theta) * w
    s1dd = amp * cyc * (c(cyc * theta) * wd - cyc * s(cyc * theta) * w**2)
    p2 = np.stack([a1 * c(theta), a1 * s(theta), s1], 1)
    v2 = np.stack([-a1 * s(theta) * w, a1 * c(theta) * w, s1d], 1)
    acc2 = np.stack(
        [-a1 * c(theta) * w**2 - a1 * s(theta) * wd, -a1 * s(theta) * w**2 + a1 * c(theta) * wd, s1dd], 1
    )
    k = np.array([0.0, s(al), c(al)])
    d = p2 - np.array([-a4, 0.0, 0.0])
    kd, kv, ka = d @ k, v2 @ k, acc2 @ k
    q = kd**2 - (d * d).sum(1) + a2**2
    qd = 2 * kd * kv - 2 * (d * v2).sum(1)
    qdd = 2 * kv**2 + 2 * kd * ka - 2 * (v2 * v2).sum(1) - 2 * (d * acc2).sum(1)
    r = np.sqrt(q)
    s4, s4d, s4dd = -kd + r, -kv + qd / (2 * r), -ka + qdd / (2 * r) - qd**2 / (4 * r**3)
    p3 = np.array([-a4, 0.0, 0.0]) - s4[:, None] * k
    v3, acc3 = -s4d[:, None] * k, -s4dd[:, None] * k
    return dict(
        theta=theta,
        w=w,
        wd=wd,
        S1=s1,
        S1d=s1d,
        S1dd=s1dd,
        P2=p2,
        V2=v2,
        A2=acc2,
        P3=p3,
        V3=v3,
        A3=acc3,
        S4=s4,
        S4d=s4d,
        S4dd=s4dd,
        k4=k,
        u=(p3 - p2) / a2,
        ud=(v3 - v2) / a2,
        udd=(acc3 - acc2) / a2,
    )


def _skew(v):
    z = np.zeros(v.shape[:-1])
    return np.stack([np.stack([z, -v[..., 2], v[..., 1]], -1), np.stack([v[..., 2], z, -v[..., 0]], -1),
                     np.stack([-v[..., 1], v[..., 0], z], -1)], -2)


def momentum_rates(case, kin):
    """Per body (crank, rod, slider): (m a_G, dH_O/dt, G, m) in world axes, moments about O.

    Crank: frame Rz(theta1) at (0, 0, S1); rod: zero spin, omega = u x u_dot, inertia
    diag(Ia, It, It) about its axis; slider: translation only.
    """
    th, w, wd = kin["theta"], kin["w"], kin["wd"]
    n = th.shape[0]
    rz = np.zeros((n, 3, 3))
    rz[:, 0, 0], rz[:, 0, 1], rz[:, 1, 0], rz[:, 1, 1], rz[:, 2, 2] = c(th), -s(th), s(th), c(th), 1.0
    bodies = []
    b = case.bodies.crank
    r = rz @ b.com
    om = np.stack([0 * th, 0 * th, np.full(n, w)], 1)
    omd = np.stack([0 * th, 0 * th, np.full(n, wd)], 1)
    acc = np.stack([0 * th, 0 * th, kin["S1dd"]], 1) + np.cross(omd, r) + np.cross(om, np.cross(om, r))
    bodies.append((om, omd, np.stack([0 * th, 0 * th, kin["S1"]], 1) + r, acc,
                   rz @ b.inertia @ np.swapaxes(rz, 1, 2), b.mass))
    b, u = case.bodies.rod, kin["u"]
    inertia = b.inertia[1, 1] * np.eye(3) + (b.inertia[0, 0] - b.inertia[1, 1]) * np.einsum(
        "ni,nj->nij", u, u
    )
    bodies.append((np.cross(u, kin["ud"]), np.cross(u, kin["udd"]), kin["P2"] + b.com[0] * u,
                   kin["A2"] + b.com[0] * kin["udd"], inertia, b.mass))
    b = case.bodies.slider
    z = np.zeros((n, 3))
    bodies.append((z, z, kin["P3"] + b.com, kin["A3"], np.broadcast_to(b.inertia, (n, 3, 3)), b.mass))
    out = []
    for om, omd, g, acc, inertia, m in bodies:
        lin = m * acc
        ang = (np.einsum("nij,nj->ni", inertia, omd) + np.cross(om, np.einsum("nij,nj->ni", inertia, om))
               + np.cross(g, lin))
        out.append((lin, ang, g, m))
    return out


#: Column blocks of the unknowns x = [F1, M1_O, J2, J3, F4, M4_O] (3 each).
F1, M1, J2, J3, F4, M4 = range(6)


def newton_euler_system(case, kin, literal: bool = False):
    """The 18 Newton-Euler equations of crank, rod and slider as ``A x = b``, ``(n, 18, 18)`` and ``(n, 18)``.

    Physical (``literal=False``): ``J2`` is the force of the crank on the rod, ``J3`` of the rod on the
    slider: crank ``F1 - J2``, rod ``J2 - J3``, slider ``J3 + F4`` equal the momentum rates (minus gravity).
    ``literal=True``: the printed pattern of eqs. (62)-(64) with f the momentum rate of eqs. (59)-(61),
    :math:`F_1 + F_2 + f_1 = 0`, :math:`F_2 + F_3 + f_2 = 0`, :math:`F_3 + F_4 + f_3 = 0`, where each joint
    force enters both bodies it connects with the same sign.  Moment rows are divided by a2 (all rows in force
    units).
    """
    p2, p3 = kin["P2"], kin["P3"]
    n = p2.shape[0]
    a2 = case.geometry.rod_length
    grav = np.broadcast_to(case.loads.gravity, (n, 3))
    eye = np.broadcast_to(np.eye(3), (n, 3, 3))
    sk2, sk3 = _skew(p2), _skew(p3)
    sign = -1.0 if literal else 1.0
    force_terms = {0: [(F1, sign * eye), (J2, -eye)], 1: [(J2, sign * eye), (J3, -eye)],
                   2: [(J3, sign * eye), (F4, sign * eye)]}
    moment_terms = {0: [(M1, sign * eye), (J2, -sk2)], 1: [(J2, sign * sk2), (J3, -sk3)],
                    2: [(J3, sign * sk3), (M4, sign * eye)]}
    a = np.zeros((n, 18, 18))
    b = np.zeros((n, 18))
    for body, (lin, ang, g, m) in enumerate(momentum_rates(case, kin)):
        for col, blk in force_terms[body]:
            a[:, 6 * body:6 * body + 3, 3 * col:3 * col + 3] = blk
        for col, blk in moment_terms[body]:
            a[:, 6 * body + 3:6 * body + 6, 3 * col:3 * col + 3] = blk / a2
        b[:, 6 * body:6 * body + 3] = lin - m * grav
        b[:, 6 * body + 3:6 * body + 6] = (ang - np.cross(g, m * grav)) / a2
    return a, b


def least_squares(a, b, given: dict[int, np.ndarray]):
    """Solve ``a x = b`` in the least-squares sense with columns ``given`` fixed; returns ``x`` and ``a x -
    b``."""
    n, _, k = a.shape
    free = [j for j in range(k) if j not in given]
    rhs = b.copy()
    x = np.zeros((n, k))
    for j, v in given.items():
        rhs -= a[:, :, j] * v[:, None]
        x[:, j] = v
    x[:, free] = np.einsum("nkm,nm->nk", np.linalg.pinv(a[:, :, free], rcond=1e-12), rhs)
    return x, np.einsum("nmk,nk->nm", a, x) - b


#: Column of the drive torque (z moment of joint 1) and of the axial force at joint 1.
DRIVE_TORQUE_COLUMN = 3 * M1 + 2
AXIAL_FORCE_COLUMN = 3 * F1 + 2
