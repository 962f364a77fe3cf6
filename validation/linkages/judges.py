"""The rigid MuJoCo answers that start the linkages' simulated judges: their starts, the per-position
driver, the table.

The ``pinocchio`` and ``mujoco`` engines of an RSSR or RCCC case are the generated judges of its joint
table (:mod:`dualmech.validation.judges.presets`); the simulations (``mujoco_rssr_sim``,
``mujoco_rccc_sim``) still start from the rigid MuJoCo model of their own MJCF (``mujoco_rssr``,
``mujoco_rccc``), which builds its model from the case and answers one position at a time with its own
Newton, rates and inverse dynamics (:class:`JudgeAnswer`).  It shares nothing with the in-house solver
but the case's description (geometry, bodies, loads, motion, the branch convention of ``docs/conventions.md``,
"RSSR" / "RCCC") and the status rules (:func:`~dualmech.models.linkages.rssr.assembles` on a reach
ratio, :func:`~dualmech.models.linkages.rssr.status_words`, ``settle``): no start, reach or pose of
the in-house solver enters it.

**Starts** (:func:`judge_positions`, as the slider crank's Pinocchio judge,
:func:`~dualmech.validation.pinocchio_closure.close_positions`): a position continues from the judge's
own closed pose at the previous position when that was accepted (converged and on the case's branch by
the judge's own transmission sign, or at the assembly limit); the first position, one after a failure or
a gap in assembly, and one the continuation did not close on the branch start crude: one angle scanned
over :data:`SCAN_POINTS` values of a mismatch the judge evaluates with its own model, started at a grid
point (never a root) next to the root whose slope has the branch's sign, on the far side from the other
root (:func:`scan_starts`); the next grid points are tried if the judge's Newton does not close on the
branch from it (:func:`judge_answer`).  RSSR: the output angle ``phi``, mismatch ``|P3(phi) - P2|^2 -
a2^2``, slope sign ``branch`` (its derivative is ``2 a2 a3 t4``), the coupler aimed from ``P2`` at
``P3(phi)`` (:func:`coupler_start`).  RCCC: the output cylinder's angle (about ``z4``), mismatch
``z3·z2* - z3·z2`` (``z2*`` the axis the prescribed input pose asks for: the cone condition), slope sign
``-branch`` (its derivative is ``-det[z2*, z3, z4]``), then the coupler's and the input link's angles
turned to ``z2*`` and to the input's ``x`` (:func:`turn_to`), slides 0.  **Reach** from the judge's own
placements: :func:`circle_reach` (RSSR), :func:`cone_reach` (RCCC).  The scan and its constants are the
generated judges' (:func:`~dualmech.validation.judges.presets.scan_starts`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Iterator

import numpy as np
from scipy.spatial.transform import Rotation

from dualmech.core.motion import CrankState
from dualmech.core.status import Status, settle
from dualmech.models.linkages.rccc import SPEC as RCCC_SPEC
from dualmech.models.linkages.rccc_case import RcccCase
from dualmech.models.linkages.rssr import assembles, status_words
from dualmech.models.linkages.rssr_case import RssrCase
from dualmech.models.linkages.table import LinkageTable, TableSpec
from dualmech.validation.judges.presets import MAX_CRUDE_STARTS, SCAN_POINTS, scan_starts

#: A judge's closure is converged when the gap between the two ball centres is below this times a2.
JUDGE_CLOSURE_TOL = 1e-14
#: Newton iterations a judge may take per position.
JUDGE_MAX_ITER = 50
#: The status words of an accepted answer: a start for the next position.
ACCEPTED = (Status.OK.value, Status.DEAD_CENTRE.value, Status.ASSEMBLY_LIMIT.value)


@dataclass(frozen=True)
class JudgeAnswer:
    """One position: ``converged`` closure, the output angle ``phi`` (rad), the transmissions
    ``t1``, ``t4``, the closure ``gap``, and ``values``: every column of the mechanism's table but
    ``theta1_deg``, ``transmission_*``, ``residual``; ``state`` the judge's closed pose as a start for
    the next position, ``iterations`` its Newton iterations."""

    converged: bool
    phi: float
    t1: float
    t4: float
    gap: float
    values: dict[str, float]
    state: Any = None
    iterations: int = 0


@dataclass(frozen=True)
class JudgeLoop:
    """A judge as :func:`judge_positions` drives it: ``reach(theta1)`` its reach ratio (``|rho| > 1``: no
    assembly), ``crude(theta1)`` its crude starts, best first, ``position(theta1, theta1_dot, theta1_ddot,
    start)`` its answer from a start (a crude one or a previous answer's ``state``)."""

    reach: Callable[[float], float]
    crude: Callable[[float], list]
    position: Callable[[float, float, float, Any], JudgeAnswer]


def scan_grid() -> np.ndarray:
    """The scanned angles of a crude start, ``(SCAN_POINTS,)`` rad, from 0 in equal steps."""
    return 2.0 * np.pi * np.arange(SCAN_POINTS) / SCAN_POINTS


def rank(answer: JudgeAnswer, branch: int, torque_mode: bool, length: float) -> int:
    """How good ``answer`` is by its own status word (:func:`~dualmech.models.linkages.rssr.status_words`):
    2 accepted (:data:`ACCEPTED`) on the branch (``sign(t4) = branch``), 1 accepted at the assembly limit
    with the other sign, 0 not accepted."""
    word = status_words(np.array([answer.converged]), np.array([answer.t1]), np.array([answer.t4]), branch,
                        torque_mode, np.array([answer.gap / length]))[0]
    if word not in ACCEPTED:
        return 0
    return 2 if np.sign(answer.t4) == branch else 1


def judge_answer(loop: JudgeLoop, state: tuple[float, float, float], previous: Any, branch: int,
                 torque_mode: bool, length: float) -> tuple[JudgeAnswer, bool, int]:
    """The answer at one position (``state`` = theta1, its rate and acceleration): from ``previous`` (the
    judge's closed pose at the previous position, or None), else or if that is not on the branch
    (:func:`rank` 2) from the crude starts in turn until one is; with none on it, the first of the best
    :func:`rank`.  Returns the answer, whether it came from a crude start, and the Newton iterations of
    every attempt."""
    iterations, best = 0, None

    def attempts() -> Iterator[tuple[bool, Any]]:
        if previous is not None:
            yield False, previous
        for start in loop.crude(state[0])[:MAX_CRUDE_STARTS]:
            yield True, start

    for crude, start in attempts():
        answer = loop.position(*state, start)
        iterations += answer.iterations
        score = rank(answer, branch, torque_mode, length)
        if best is None or score > best[0]:
            best = (score, answer, crude)
        if score == 2:
            break
    return best[1], best[2], iterations


def judge_positions(name: str, engine: str, crank: CrankState, branch: int, torque_mode: bool,
                    spec: TableSpec, length: float, loop: JudgeLoop) -> LinkageTable:
    """Answer every position where the judge's reach assembles (:func:`judge_answer`, continuing from the
    previous accepted pose; a gap restarts crude), and collect the common table: the same columns,
    status words (:func:`~dualmech.models.linkages.rssr.status_words`) and settling as the in-house
    engine; ``residual`` is the judge's closure gap over ``length``; ``meta["iterations"]`` ``(n,)`` the
    Newton iterations and ``meta["crude"]`` ``(n,)`` whether the position started crude."""
    n = crank.theta.shape[0]
    cols = {c: np.full(n, np.nan) for c in spec.columns}
    converged, t1, t4 = np.zeros(n, dtype=bool), np.full(n, np.nan), np.full(n, np.nan)
    reach = assembles(np.array([loop.reach(float(th)) for th in crank.theta]))
    iterations, crude = np.zeros(n, dtype=int), np.zeros(n, dtype=bool)
    previous = None
    for k in range(n):
        if not reach[k]:
            previous = None
            continue
        state = (float(crank.theta[k]), float(crank.theta_dot[k]), float(crank.theta_ddot[k]))
        ans, crude[k], iterations[k] = judge_answer(loop, state, previous, branch, torque_mode, length)
        previous = ans.state if rank(ans, branch, torque_mode, length) else None
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
    return LinkageTable(engine, name, cols, status, {"iterations": iterations, "crude": crude})


Pins = Callable[[float, float], tuple[np.ndarray, np.ndarray]]


def circle_reach(pins: Pins, theta1: float, a2: float) -> float:
    """The RSSR's reach ratio at ``theta1`` from the judge's own ``pins(theta1, phi) -> (P2, P3)``.

    ``|P3(phi) - P2|^2 = K + A cos phi + B sin phi`` (the output pin's circle about ``Q4``), read at
    ``phi = 0, pi/2, pi, 3 pi/2``; ``rho = (a2^2 - K) / sqrt(A^2 + B^2)``: the coupler reaches the
    circle iff ``|rho| <= 1``.
    """
    p2 = pins(theta1, 0.0)[0]
    f = np.array([np.sum((pins(theta1, phi)[1] - p2) ** 2) for phi in 0.5 * np.pi * np.arange(4)])
    return float((a2**2 - f.mean()) / np.hypot(0.5 * (f[0] - f[2]), 0.5 * (f[1] - f[3])))


def rssr_loop(case: RssrCase, pins: Pins, position: Callable[[float, float, float, float], JudgeAnswer]
              ) -> JudgeLoop:
    """An RSSR judge with ``pins(theta1, phi) -> (P2, P3)`` (its own model at the input angle ``theta1`` and
    the output angle ``phi``) and ``position(theta1, theta1_dot, theta1_ddot, phi)`` (its answer from the
    output angle ``phi``, the coupler aimed at the output pin): the crude starts scan
    ``|P3(phi) - P2|^2 - a2^2`` (module docstring), the reach is :func:`circle_reach`."""
    a2, grid = case.geometry.a2, scan_grid()

    def crude(theta1: float) -> list[float]:
        p2 = pins(theta1, 0.0)[0]
        span = np.array([np.sum((pins(theta1, phi)[1] - p2) ** 2) for phi in grid])
        return scan_starts(span - a2**2, case.branch)

    return JudgeLoop(lambda theta1: circle_reach(pins, theta1, a2), crude, position)


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


def coupler_start(theta1: float, p2: np.ndarray, p3: np.ndarray) -> np.ndarray:
    """The coupler's rotation relative to the input crank ``(3, 3)`` that points its x axis from ``p2`` at
    ``p3`` (world points of the judge's own model; a start: the spin about that axis is arbitrary)."""
    u = (p3 - p2) / np.linalg.norm(p3 - p2)
    v = np.cross([0.0, 0.0, 1.0] if abs(u[2]) < 0.9 else [1.0, 0.0, 0.0], u)
    v /= np.linalg.norm(v)
    c, s = np.cos(theta1), np.sin(theta1)
    return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]]) @ np.column_stack([u, v, np.cross(u, v)])


def min_norm_step(jac: np.ndarray, gap: np.ndarray) -> np.ndarray:
    """``-J^T (J J^T)^{-1} gap``: the smallest step that closes a linearised gap (3 rows, any columns)."""
    return -jac.T @ np.linalg.solve(jac @ jac.T, gap)


Axes = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]


def turn_to(axis: np.ndarray, current: np.ndarray, target: np.ndarray) -> float:
    """The angle (rad) about the unit ``axis`` that turns ``current`` nearest to ``target`` (their parts
    normal to ``axis`` aligned); all ``(3,)``."""
    normal = float(current @ target - (axis @ current) * (axis @ target))
    return float(np.arctan2(axis @ np.cross(current, target), normal))


def cone_reach(z2: np.ndarray, z3: np.ndarray, z4: np.ndarray, wanted: np.ndarray) -> float:
    """The RCCC's reach: ``rho = |a w + b z4|^2`` with ``w`` = the axis ``wanted`` of the input cylinder, the
    part of ``z3`` in the plane of ``w`` and ``z4`` that the cones ``z3·w = z3·z2``, ``z3·z4`` ask for (the
    cosines read off the judge's own axes ``z2, z3, z4`` at any pose); ``rho > 1``: the cones miss."""
    c23, c34, g = float(z3 @ z2), float(z3 @ z4), float(wanted @ z4)
    return (c23**2 + c34**2 - 2.0 * g * c23 * c34) / (1.0 - g**2)


def rccc_judge_table(case: RcccCase, engine: str, axes: Axes, wanted: Callable[[float], np.ndarray],
                     position: Callable[[float, float, float, np.ndarray], JudgeAnswer]) -> LinkageTable:
    """:func:`judge_positions` for an RCCC case judged with ``axes(q) -> (z2, z3, z4, x1)`` (the world axes
    of the cylinders and the input link's x axis of the judge's own model at its coordinates ``q`` =
    ``(-theta4, -s4, -theta3, -s3, -theta2, -s2)``), ``wanted(theta1) -> z2`` (the input cylinder's axis
    that the prescribed input pose asks of it) and ``position(theta1, theta1_dot, theta1_ddot, q)`` (its
    answer from ``q``): the crude starts scan ``q[0]`` (module docstring)."""
    grid, zero = scan_grid(), np.zeros(6)

    def reach(theta1: float) -> float:
        return cone_reach(*axes(zero)[:3], wanted(theta1))

    def crude(theta1: float) -> list[np.ndarray]:
        z2w, x1w = wanted(theta1), np.array([np.cos(theta1), np.sin(theta1), 0.0])
        turned = (axes(np.r_[angle, zero[1:]]) for angle in grid)
        mismatch = np.array([float(z3 @ (z2w - z2)) for z2, z3, _, _ in turned])
        starts = []
        for angle in scan_starts(mismatch, -case.branch):
            q = np.r_[angle, zero[1:]]
            z2, z3, _, _ = axes(q)
            q[2] = turn_to(z3, z2, z2w)
            z2, _, _, x1 = axes(q)
            q[4] = turn_to(z2, x1, x1w)
            starts.append(q)
        return starts

    crank = case.motion.state(case.geometry.s1)
    loop = JudgeLoop(reach, crude, position)
    return judge_positions(case.name, engine, crank, case.branch, False, RCCC_SPEC, case.geometry.size, loop)


def cut_tolerance(size: float, q: np.ndarray) -> float:
    """The largest cut gap (length) an RCCC judge's closure accepts at its coordinates ``q`` (slides at
    ``q[1::2]``): :data:`JUDGE_CLOSURE_TOL` times ``size`` plus the slides' lengths, since a point placed at
    slide ``s`` is computed to ~eps ``|s|`` (near the assembly limit the slides grow as ``1/t``: measured
    gaps stalled at 1e-14 m with slides of 41 m in a linkage of size 0.45 m)."""
    return JUDGE_CLOSURE_TOL * (size + float(np.abs(q[1::2]).sum()))


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
