"""The independent dynamics model of the errata and findings tests (no in-house solver, no printed text).

S4 of the sphere-line intersection and its time derivatives in closed form, the rod's zero-spin angular
velocity ``u x u_dot``, and the 18 Newton-Euler equations of crank, rod and slider in world axes (moments
about O), assembled as a matrix and solved by least squares.
"""

from __future__ import annotations

import numpy as np

c, s = np.cos, np.sin

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
    with np.errstate(invalid="ignore"):
        r = np.sqrt(q)  # NaN where the rod cannot reach the slider line (q < 0): no assembly
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


def table_violation(case, table) -> np.ndarray:
    """The largest violation of the 18 Newton-Euler equations by a result table's own reaction columns
    (``(n,)``, NaN where a row gives no reactions), over the table's largest joint force at that row.

    The equations are :func:`newton_euler_system`'s (closed-form kinematics and momentum rates, the rod's
    zero spin: ball joints at the rod's ends only); the unknowns are read from the columns, the slider's
    ground moment turned from about ``P3`` to about O.
    """
    theta = np.radians(table["theta1_deg"])
    kin = kinematics(case, theta)
    a, b = newton_euler_system(case, kin)
    f1, m1, j2, j3, f4, m4 = (np.stack([table[f"{j}{axis}"] for axis in "xyz"], 1)
                              for j in ("j1_f", "j1_m", "j2_f", "j3_f", "j4_f", "j4_m"))
    x = np.concatenate([f1, m1, j2, j3, f4, m4 + np.cross(kin["P3"], f4)], 1)
    err = np.abs(np.einsum("nmk,nk->nm", a, x) - b).max(1)
    return err / np.abs(np.concatenate([f1, j2, j3, f4], 1)).max(1)
