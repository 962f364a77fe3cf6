"""Test oracles for the Pinocchio judge: random cases, closed-form motion, Newton–Euler residuals.

Nothing here calls Pinocchio or the in-house solver.  The motion is the tests' closed
form (``tests/oracles.py``: sphere–line intersection on the branch ``(P3 - P2)·k4 < 0``,
rates from the differentiated loop equation ``|P3 - P2|^2 = a2^2``).

Body motions follow the conventions' body frames; the rod has zero spin, so
``omega_rod = u × u_dot`` and ``omega_dot_rod = u × u_ddot``.
"""

from __future__ import annotations

import numpy as np

from dualmech.core.motion import CrankState
from dualmech.core.table import FORCE_COLUMNS, MOMENT_COLUMNS, ResultTable
from dualmech.models.case import Case, case_from_dict
from tests.oracles import slider_motion


def physical_inertia(rng: np.random.Generator) -> list[list[float]]:
    """A valid central inertia (principal moments from second moments >= 0) with random axes, 3x3."""
    a, b, c = rng.uniform(0.1, 2.0, size=3)
    axes, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return (axes @ np.diag([b + c, a + c, a + b]) @ axes.T).tolist()


def random_case(rng: np.random.Generator, mode: str, gravity: bool = True, step: float = 10.0,
                reach: float = 1.3) -> Case:
    """A seeded random generalized slider crank with explicit, non-trivial mass properties.

    ``reach`` > 1 makes the rod longer than the farthest the slider line can be
    from the crank pin, so the mechanism assembles at every angle; well below 1
    (say 0.7) most cases have arcs without assembly.
    """
    a1 = rng.uniform(3.0, 15.0)
    a4 = rng.uniform(-30.0, 30.0)
    s1 = rng.uniform(-10.0, 10.0)
    amp = float(rng.choice([0.0, rng.uniform(0.0, 3.0)]))
    twist = float(rng.choice([rng.uniform(10.0, 170.0), rng.uniform(190.0, 350.0)]))
    a2 = reach * (a1 + abs(a4) + abs(s1) + amp) + (rng.uniform(0.0, 20.0) if reach > 1.0 else 0.0)
    transverse = rng.uniform(0.5, 5.0)
    axial = rng.uniform(0.01, 0.9) * 2.0 * transverse
    data = {
        "name": "random-pinocchio",
        "geometry": {"crank_length": a1, "rod_length": a2, "slider_offset": a4, "slider_twist_deg": twist,
                     "crank_axial_shift": s1},
        "motion": {"crank_rpm": rng.uniform(-200.0, 200.0), "crank_accel": rng.uniform(-50.0, 50.0),
                   "axial_amplitude": amp, "axial_cycles": float(rng.integers(0, 4)),
                   "angles_deg": {"start": float(rng.uniform(0.0, 10.0)), "stop": 370.0, "step": step}},
        "bodies": {
            "crank": {"mass": rng.uniform(0.5, 5.0), "com": rng.normal(size=3).tolist(),
                      "inertia": physical_inertia(rng)},
            "rod": {"mass": rng.uniform(0.5, 5.0), "com": [rng.uniform(0.0, a2), 0.0, 0.0],
                    "inertia": [axial, transverse, transverse]},
            "slider": {"mass": rng.uniform(0.5, 5.0), "com": rng.normal(size=3).tolist(),
                       "inertia": physical_inertia(rng)},
        },
        "loads": {"gravity": (10.0 * rng.normal(size=3)).tolist() if gravity else [0.0, 0.0, 0.0]},
    }
    data["loads"]["drive_torque" if mode == "torque" else "slider_force"] = rng.uniform(-500.0, 500.0)
    return case_from_dict(data)


def oracle_motion(case: Case) -> dict[str, np.ndarray]:
    """Closed-form positions, velocities and accelerations of P2 and P3 and S4's rates, each (n, 3) or (n,)
    (:func:`tests.oracles.slider_motion`), with the crank state they follow.

    NaN where the rod cannot reach the slider line.
    """
    mo = slider_motion(case)
    n, m = mo["theta"].shape[0], case.motion
    mo["state"] = CrankState(mo["theta"], mo["S1"], np.full(n, m.speed), mo["S1_dot"], np.full(n, m.accel),
                             mo["S1_ddot"])
    return mo


def body_motion(case: Case, mo: dict) -> dict[str, tuple]:
    """Per body: (mass, com, com velocity, com acceleration, world inertia (n,3,3), omega, omega_dot)."""
    st, a2 = mo["state"], case.geometry.rod_length
    n = st.theta.shape[0]
    zeros = np.zeros((n, 3))
    c, s = np.cos(st.theta), np.sin(st.theta)
    rz = np.zeros((n, 3, 3))
    rz[:, 0, 0], rz[:, 0, 1], rz[:, 1, 0], rz[:, 1, 1], rz[:, 2, 2] = c, -s, s, c, 1.0
    axial = lambda x: np.stack([np.zeros(n), np.zeros(n), x], -1)  # noqa: E731
    b = case.bodies.crank
    arm = rz @ b.com
    om = axial(st.theta_dot)
    omd = axial(st.theta_ddot)
    crank = (b.mass, axial(st.s) + arm, axial(st.s_dot) + np.cross(om, arm),
             axial(st.s_ddot) + np.cross(omd, arm) + np.cross(om, np.cross(om, arm)),
             rz @ b.inertia @ np.swapaxes(rz, 1, 2), om, omd)
    b = case.bodies.rod
    u = (mo["p3"] - mo["p2"]) / a2
    ud = (mo["v3"] - mo["v2"]) / a2
    udd = (mo["a3"] - mo["a2"]) / a2
    uu = u[:, :, None] * u[:, None, :]
    rod = (b.mass, mo["p2"] + b.com[0] * u, mo["v2"] + b.com[0] * ud, mo["a2"] + b.com[0] * udd,
           b.inertia[0, 0] * uu + b.inertia[1, 1] * (np.eye(3) - uu), np.cross(u, ud), np.cross(u, udd))
    b = case.bodies.slider
    slider = (
        b.mass,
        mo["p3"] + b.com,
        mo["v3"],
        mo["a3"],
        np.broadcast_to(b.inertia, (n, 3, 3)),
        zeros,
        zeros,
    )
    return {"crank": crank, "rod": rod, "slider": slider}


def _vec(table: ResultTable, prefix: str) -> np.ndarray:
    return np.stack([table[f"{prefix}{x}"] for x in "xyz"], -1)


def newton_euler_residuals(case: Case, table: ResultTable) -> np.ndarray:
    """Residuals of each body's force balance and moment balance about its centre of mass.

    Returns shape (n, 3, 6): bodies crank, rod, slider; (force residual, moment residual), world axes.
    The table's reactions are applied as the conventions define them: j1 force at O plus
    moment about O on the crank, j2 force at P2 on the rod (its opposite on the crank),
    j3 force at P3 on the slider (its opposite on the rod), j4 force at P3 plus moment about P3
    on the slider.
    """
    mo = oracle_motion(case)
    bodies = body_motion(case, mo)
    gravity = case.loads.gravity
    j1f, j1m, j2f = _vec(table, "j1_f"), _vec(table, "j1_m"), _vec(table, "j2_f")
    j3f, j4f, j4m = _vec(table, "j3_f"), _vec(table, "j4_f"), _vec(table, "j4_m")
    origin = np.zeros_like(mo["p2"])
    actions = {
        "crank": [(j1f, origin, j1m), (-j2f, mo["p2"], 0.0)],
        "rod": [(j2f, mo["p2"], 0.0), (-j3f, mo["p3"], 0.0)],
        "slider": [(j3f, mo["p3"], 0.0), (j4f, mo["p3"], j4m)],
    }
    out = []
    for name in ("crank", "rod", "slider"):
        m, com, _, acc, inertia, om, omd = bodies[name]
        force = m * gravity - m * acc
        moment = -(np.einsum("nij,nj->ni", inertia, omd) + np.cross(om, np.einsum("nij,nj->ni", inertia, om)))
        for f, point, pure in actions[name]:
            force = force + f
            moment = moment + np.cross(point - com, f) + pure
        out.append(np.concatenate([force, moment], -1))
    return np.stack(out, 1)


def power_terms(case: Case, table: ResultTable) -> tuple[np.ndarray, np.ndarray]:
    """Power of every external action, (n, 6), and the rate of kinetic energy dK/dt, (n,).

    Columns: ground on crank ``j1_fz S1_dot`` and ``j1_mz theta1_dot`` (the crank point at O
    moves along z; the moment is about O), ground on slider ``j4_f · P3_dot`` (it does not
    rotate), gravity on crank, rod, slider.  ``dK/dt = sum m v_c·a_c + omega·(I omega_dot)``.
    The joint-2 and joint-3 forces are internal and do no net work.
    """
    mo = oracle_motion(case)
    st = mo["state"]
    terms = [
        table["j1_fz"] * st.s_dot,
        table["j1_mz"] * st.theta_dot,
        (_vec(table, "j4_f") * mo["v3"]).sum(-1),
    ]
    kinetic_rate = np.zeros(len(table))
    for m, _, vel, acc, inertia, om, omd in body_motion(case, mo).values():
        terms.append(m * (vel @ case.loads.gravity))
        kinetic_rate = (
            kinetic_rate + m * (vel * acc).sum(-1) + (om * np.einsum("nij,nj->ni", inertia, omd)).sum(-1)
        )
    return np.stack(terms, -1), kinetic_rate


def condition(case: Case, table: ResultTable) -> np.ndarray:
    """Condition factor per row: ``1/|transmission|`` in drive-torque mode, else 1 (conventions "Dead
    centres")."""
    if case.loads.mode == "torque":
        return 1.0 / np.abs(table["transmission"])
    return np.ones(len(table))


def group_scales(table: ResultTable, rows: np.ndarray, cond: np.ndarray) -> tuple[float, float]:
    """Largest ``|force| / c`` and ``|moment| / c`` over ``rows`` (the case's force and moment scales)."""
    force = max(np.abs(table[c][rows] / cond[rows]).max() for c in FORCE_COLUMNS)
    moment = max(np.abs(table[c][rows] / cond[rows]).max() for c in MOMENT_COLUMNS)
    return force, moment
