"""What the linkages' judges share: start estimates, the per-position driver, the table, the comparison.

A judge (``pinocchio_rssr``, ``mujoco_rssr``, ``pinocchio_rccc``, ``mujoco_rccc``) builds its own
model from the case and answers one position at a time with its own Newton, rates and inverse
dynamics (:class:`JudgeAnswer`).  Only the start estimate comes from the in-house closed form,
moved by :data:`START_OFFSET` so that the judge's Newton, not the estimate, decides the pose.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.spatial.transform import Rotation

from dualmech.core.motion import CrankState
from dualmech.core.status import Status, settle
from dualmech.models.linkages.rccc import SPEC as RCCC_SPEC
from dualmech.models.linkages.rccc import estimate, spherical_estimate
from dualmech.models.linkages.rccc_case import RcccCase
from dualmech.models.linkages.rssr import (
    SPEC,
    assembles,
    closed_form_phi,
    crank_pin,
    output_pin,
    status_words,
)
from dualmech.models.linkages.rssr_case import RssrCase
from dualmech.models.linkages.table import LinkageTable, TableSpec

#: The judges start Newton this far (rad) from the closed-form output angle: far enough that the
#: answer is the judge's own (Newton takes 4-6 iterations), near enough to stay on the case's branch.
START_OFFSET = 0.1
#: A judge's closure is converged when the gap between the two ball centres is below this times a2.
JUDGE_CLOSURE_TOL = 1e-14
#: Newton iterations a judge may take per position.
JUDGE_MAX_ITER = 50


@dataclass(frozen=True)
class JudgeAnswer:
    """One position: ``converged`` closure, the output angle ``phi`` (rad), the transmissions
    ``t1``, ``t4``, and ``values``: every column of :data:`~dualmech.models.linkages.rssr.COLUMNS`
    but ``theta1_deg``, ``transmission_*``, ``residual``."""

    converged: bool
    phi: float
    t1: float
    t4: float
    gap: float
    values: dict[str, float]


def judge_positions(name: str, engine: str, crank: CrankState, starts: np.ndarray, reach: np.ndarray,
                    branch: int, torque_mode: bool, spec: TableSpec, length: float,
                    position: Callable[[float, float, float, np.ndarray], JudgeAnswer]) -> LinkageTable:
    """Run ``position(theta1, theta1_dot, theta1_ddot, starts[k])`` at every position ``k`` that
    ``reach`` says assembles, and collect the common table: the same columns, status words
    (:func:`~dualmech.models.linkages.rssr.status_words`) and settling as the in-house engine;
    ``residual`` is the judge's closure gap over ``length``."""
    n = crank.theta.shape[0]
    cols = {c: np.full(n, np.nan) for c in spec.columns}
    converged, t1, t4 = np.zeros(n, dtype=bool), np.full(n, np.nan), np.full(n, np.nan)
    for k in np.flatnonzero(reach):
        state = (float(crank.theta[k]), float(crank.theta_dot[k]), float(crank.theta_ddot[k]))
        ans = position(*state, starts[k])
        converged[k], t1[k], t4[k] = ans.converged, ans.t1, ans.t4
        cols["residual"][k] = ans.gap / length
        for column, value in ans.values.items():
            cols[column][k] = value
    cols["theta1_deg"] = np.degrees(crank.theta)
    cols["transmission_out"] = t4
    if "transmission_in" in cols:
        cols["transmission_in"] = t1
    status = status_words(converged, t1, t4, branch, torque_mode, cols["residual"])
    status[~reach] = Status.NO_ASSEMBLY.value
    status = settle(cols, status, spec.reactions, pose=spec.pose, rates=spec.rates)
    return LinkageTable(engine, name, cols, status)


def judge_table(case: RssrCase, engine: str,
                position: Callable[[float, float, float, float], JudgeAnswer]) -> LinkageTable:
    """:func:`judge_positions` for an RSSR case, each position started :data:`START_OFFSET` from the
    closed-form output angle."""
    crank = case.motion.state(case.geometry.s1)
    phi0, rho = closed_form_phi(case.geometry, crank.theta, case.branch)
    return judge_positions(case.name, engine, crank, phi0 + START_OFFSET, assembles(rho), case.branch,
                           case.mode == "torque", SPEC, case.geometry.a2,
                           lambda th, w, wd, start: position(th, w, wd, float(start)))


def wrench_columns(f1: np.ndarray, m1_o: np.ndarray, f2: np.ndarray, f3: np.ndarray, f4: np.ndarray,
                   m4_q: np.ndarray, k4: np.ndarray) -> dict[str, float]:
    """The reaction columns from the four joints' world vectors (``j1`` moment about O, ``j4`` about Q4)."""
    out: dict[str, float] = {}
    for name, vec in (("j1_f", f1), ("j1_m", m1_o), ("j2_f", f2), ("j3_f", f3), ("j4_f", f4), ("j4_m", m4_q)):
        for axis, value in zip("xyz", vec):
            out[name + axis] = float(value)
    out["drive_torque"] = float(m1_o[2])
    out["output_torque"] = float(k4 @ m4_q)
    return out


def transmissions(p2: np.ndarray, p3: np.ndarray, case: RssrCase) -> tuple[float, float]:
    """``t1``, ``t4`` of a judge's own pose (``docs/conventions.md``, "RSSR")."""
    g = case.geometry
    u = (p3 - p2) / np.linalg.norm(p3 - p2)
    t1 = float(np.cross(p2 - np.array([0.0, 0.0, g.s1]), u)[2] / g.a1)
    t4 = float(np.cross(p3 - g.foot, u) @ g.k4 / g.a3)
    return t1, t4


def loop_efforts(case: RssrCase, bias: np.ndarray, jac: np.ndarray) -> tuple[np.ndarray, float]:
    """The loop force and the fit of ``bias = S^T tau + J_c^T lambda`` (``bias`` ``(5,)`` = ``M a + c``).

    ``v = (theta1, 3 coupler rotations, phi4)``: the coupler's ball carries no effort, the given load is
    known, the other revolute's effort and ``lambda`` (3, the force ``J_c`` maps) are solved by least
    squares (5 equations, 4 unknowns; every row is a moment).  Returns ``lambda`` and the relative
    residual ``|lhs x - rhs| / |rhs|``.
    """
    given, solved = (0, 4) if case.mode == "torque" else (4, 0)
    rhs = bias.copy()
    rhs[given] -= case.drive_torque if case.mode == "torque" else case.output_torque
    lhs = np.column_stack([np.eye(bias.shape[0])[:, solved], jac.T])
    x = np.linalg.lstsq(lhs, rhs, rcond=None)[0]
    return x[1:], float(np.linalg.norm(lhs @ x - rhs) / max(np.linalg.norm(rhs), np.finfo(float).tiny))


def motion_values(phi: float, phi_dot: float, phi_ddot: float, fit: float) -> dict[str, float]:
    """The output-angle columns (``phi4_deg`` in [-180, 180)) and ``dynamics_residual`` of a judge."""
    return {"phi4_deg": float(np.degrees(np.mod(phi + np.pi, 2 * np.pi) - np.pi)), "phi4_dot": float(phi_dot),
            "phi4_ddot": float(phi_ddot), "dynamics_residual": fit}


def coupler_start(case: RssrCase, theta1: float, phi: float) -> np.ndarray:
    """The coupler's rotation relative to the input crank ``(3, 3)`` that points its x axis from ``P2`` at
    the output pin of angle ``phi`` (a judge's start; the spin about that axis is arbitrary)."""
    g = case.geometry
    p2 = crank_pin(g, np.array([theta1]))[0]
    u = output_pin(g, np.array([phi]))[0] - p2
    u /= np.linalg.norm(u)
    v = np.cross([0.0, 0.0, 1.0] if abs(u[2]) < 0.9 else [1.0, 0.0, 0.0], u)
    v /= np.linalg.norm(v)
    c, s = np.cos(theta1), np.sin(theta1)
    return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]]) @ np.column_stack([u, v, np.cross(u, v)])


def min_norm_step(jac: np.ndarray, gap: np.ndarray) -> np.ndarray:
    """``-J^T (J J^T)^{-1} gap``: the smallest step that closes a linearised gap (3 rows, any columns)."""
    return -jac.T @ np.linalg.solve(jac @ jac.T, gap)


def rccc_judge_table(case: RcccCase, engine: str,
                     position: Callable[[float, float, float, np.ndarray], JudgeAnswer]) -> LinkageTable:
    """:func:`judge_positions` for an RCCC case, each position started from the spherical estimate's
    joint angles moved by :data:`START_OFFSET` (``start`` = theta2, s2, theta3, s3, theta4, s4)."""
    crank = case.motion.state(case.geometry.s1)
    z3, rho = spherical_estimate(case.geometry, crank.theta, case.branch)
    starts = estimate(case.geometry, crank.theta, z3).scalars + START_OFFSET * np.array([1, 0, 1, 0, 1, 0])
    return judge_positions(case.name, engine, crank, starts, assembles(rho), case.branch, False, RCCC_SPEC,
                           case.geometry.size, position)


def rotation_log(rot: np.ndarray) -> np.ndarray:
    """Rotation vector ``(3,)`` of a rotation matrix ``(3, 3)`` (the axis times the angle)."""
    return Rotation.from_matrix(rot).as_rotvec()


def pose_error(rot: np.ndarray, point: np.ndarray, theta1: float, s1: float) -> np.ndarray:
    """World error ``(6,)``: translation to the input link's target origin ``(0, 0, s1)``, then the rotation
    vector from the current axes ``rot`` to the target ``Rz(theta1)`` (a judge's cut at joint 1)."""
    c, s = np.cos(theta1), np.sin(theta1)
    target = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return np.concatenate([np.array([0.0, 0.0, s1]) - point, rotation_log(target @ rot.T)])


def rccc_values(q: np.ndarray, v: np.ndarray, a: np.ndarray, fit: float, wrenches: dict[str, np.ndarray],
                z4: np.ndarray) -> dict[str, float]:
    """The RCCC columns of a judge whose first joint is the cylinder ``z4`` with coordinates
    ``(-theta4, -s4)`` (``q``, ``v``, ``a`` its coordinates, rates, accelerations); ``wrenches``: force and
    moment (world) per ``j1_f`` ... ``j4_m`` (``docs/conventions.md``, "RCCC")."""
    out = {"theta4_deg": float(np.degrees(np.mod(-q[0] + np.pi, 2 * np.pi) - np.pi)), "s4": -float(q[1]),
           "theta4_dot": -float(v[0]), "s4_dot": -float(v[1]), "theta4_ddot": -float(a[0]),
           "s4_ddot": -float(a[1]), "dynamics_residual": fit}
    for name, vec in wrenches.items():
        for axis, value in zip("xyz", vec):
            out[name + axis] = float(value)
    out["drive_torque"] = out["j1_mz"]
    out["output_torque"] = float(z4 @ wrenches["j4_m"])
    return out


def rccc_transmission(z2: np.ndarray, z3: np.ndarray, z4: np.ndarray, case: RcccCase) -> float:
    """``det[z2, z3, z4] / |sin alpha23 sin alpha34|`` of a judge's own axes."""
    g = case.geometry
    return float(z2 @ np.cross(z3, z4) / abs(np.sin(g.alpha[1]) * np.sin(g.alpha[2])))


def cut_efforts(case: RcccCase, bias: np.ndarray, jac: np.ndarray) -> tuple[np.ndarray, float]:
    """The ground's wrench on the input link at the cut, ``(6,)`` (force, moment about its origin on
    ``z1``; world), from ``bias = M a + c = S^T tau + J^T w`` with ``tau`` 0 but the given output torque on
    the first coordinate (the angle about ``z4``); ``jac`` ``(6, 6)`` the input link frame's world Jacobian
    (linear rows first).  Returns ``w`` and the relative residual."""
    rhs = bias.copy()
    rhs[0] -= case.output_torque
    w = np.linalg.solve(jac.T, rhs)
    return w, float(np.linalg.norm(jac.T @ w - rhs) / max(np.linalg.norm(rhs), np.finfo(float).tiny))


def cfrc_about(data, body: int, root_com: np.ndarray, point: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """MuJoCo's ``cfrc_int`` of ``body`` (the wrench of its parent on it; moment about its tree's centre
    of mass ``root_com``) as force and moment about ``point``, world axes."""
    torque, force = data.cfrc_int[body, :3], data.cfrc_int[body, 3:]
    return force.copy(), torque + np.cross(root_com - point, force)
