"""The RSSR spatial four-bar by the dual-number method: link-joint table, closure, rates, reactions.

::

    row  joint              theta      S     eta  alpha     a      (thesis Table 1 pattern)
    1    revolute (1)       theta1*    s1    0    0         a1
    2    ball (2)           -- free rotation --   0         a2
    3    ball (3)           -- free rotation --   0         a3
    4    revolute (4)       theta4?    -h    0    alpha4    a4

    * prescribed input   ? unknown (the output angle is phi4 = pi - theta4)

The loop is closed by the generic Newton with the screws of the table and its DFP fallback
(:func:`~dualmech.core.closure.solve_closure`), the rates by the generic screw sums
(:func:`~dualmech.core.rates.solve_rates`), the reactions by the generic Newton-Euler least
squares of :mod:`dualmech.models.linkages.dynamics`.  The coupler's spin is fixed by the
zero-spin gauge, as the slider crank's rod (``docs/conventions.md``, "RSSR").  The start
estimate of the output angle is the plane-free closed form ``A cos phi + B sin phi = C`` of
the output pin's circle meeting the sphere about ``P2`` (:func:`closed_form_phi`); it also
decides ``no_assembly`` (``|C| > sqrt(A^2 + B^2)``) and the branch.

The in-house engine is the loop engine on the RSSR's preset table (:mod:`dualmech.models.loop.preset_engine`),
started from :func:`closed_form_phi` and :func:`estimate` and read back by these columns and status rules
(:func:`status_words`); the pipeline here (:func:`analyze_rssr`) is the forward dynamics' analysis
(:mod:`dualmech.models.linkages.forward_dynamics`) and the tests' oracle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from dualmech.core.closure import ClosureStatus, solve_closure
from dualmech.core.dual import origin
from dualmech.core.loop import Loop, LoopState, Row, evaluate, inp, par, unk
from dualmech.core.motion import CrankState
from dualmech.core.rates import solve_rates
from dualmech.core.reactions import BodyMotion, body_motion
from dualmech.core.status import Status, is_status, settle
from dualmech.core.thresholds import (
    ASSEMBLY_LIMIT_CONDITION,
    ASSEMBLY_REACH,
    DEAD_CENTRE_TRANSMISSION,
    Tolerance,
)
from dualmech.models.angle_ranges import format_angle_ranges, no_assembly_ranges
from dualmech.models.linkages.dynamics import GivenLoad, Joint, JointReactions, solve_joint_reactions
from dualmech.models.linkages.rssr_case import RssrCase, RssrGeometry
from dualmech.models.tables import LinkageTable, TableSpec

LOOP = Loop(
    rows=(
        Row("joint1", theta=inp("theta1"), s=par("s1"), a=par("a1")),
        Row("joint2", spherical=True, a=par("a2")),
        Row("joint3", spherical=True, a=par("a3")),
        Row("joint4", theta=unk("theta4"), s=par("s4"), alpha=par("alpha4"), a=par("a4")),
    ),
    spin_gauges=(1,),
    length_scale="a2",
)

#: Closure residual accepted at the assembly limit (``|t4|`` in the band): there the loop's Jacobian is
#: singular, and a closure error of ~eps/|t| is the rounding of the pose, not a failure.
LIMIT_CLOSURE = Tolerance(
    1e-9, "the RCCC's slides close to ~1e-16/|t|: measured 2.7e-11 at |t| = 4e-6 (1e-9 deg from the edge), "
    "3.8e-12 at 4e-5; the pose there is given to that accuracy")
#: Joint names of the reaction columns, in loop order (``j1`` ... ``j4``).
JOINTS = ("j1", "j2", "j3", "j4")
#: Output columns of an RSSR result table, in order (``docs/conventions.md``, "RSSR").
COLUMNS: tuple[str, ...] = (
    "theta1_deg", "phi4_deg", "phi4_dot", "phi4_ddot",
    "j1_fx", "j1_fy", "j1_fz", "j1_mx", "j1_my", "j1_mz",
    "j2_fx", "j2_fy", "j2_fz", "j3_fx", "j3_fy", "j3_fz",
    "j4_fx", "j4_fy", "j4_fz", "j4_mx", "j4_my", "j4_mz",
    "drive_torque", "output_torque", "transmission_in", "transmission_out", "residual", "dynamics_residual",
)
REACTIONS: tuple[str, ...] = COLUMNS[4:24] + ("dynamics_residual",)
POSE: tuple[str, ...] = ("phi4_deg", "transmission_out")
RATES: tuple[str, ...] = ("phi4_dot", "phi4_ddot", "transmission_in")
SPEC = TableSpec(COLUMNS, POSE, RATES, REACTIONS)


def loop_values(geom: RssrGeometry, theta1: np.ndarray) -> dict[str, np.ndarray]:
    """Inputs and parameters of :data:`LOOP` at the crank angles ``theta1`` ``(n,)`` (rad)."""
    full = np.ones_like(theta1)
    return {"theta1": theta1, "s1": geom.s1 * full, "a1": geom.a1 * full, "a2": geom.a2 * full,
            "a3": geom.a3 * full, "s4": -geom.h * full, "alpha4": geom.alpha4 * full, "a4": geom.a4 * full}


def crank_pin(geom: RssrGeometry, theta1: np.ndarray) -> np.ndarray:
    """``P2 = (a1 cos theta1, a1 sin theta1, s1)``, ``(n, 3)``."""
    return np.stack([geom.a1 * np.cos(theta1), geom.a1 * np.sin(theta1), np.full_like(theta1, geom.s1)], 1)


def output_pin(geom: RssrGeometry, phi: np.ndarray) -> np.ndarray:
    """``P3 = Q4 + a3 G4 (cos phi, sin phi, 0)``, ``(n, 3)``."""
    local = np.stack([np.cos(phi), np.sin(phi), np.zeros_like(phi)], 1)
    return geom.foot + geom.a3 * local @ geom.ground_rotation().T


def closed_form_phi(geom: RssrGeometry, theta1: np.ndarray, branch: int) -> tuple[np.ndarray, np.ndarray]:
    """Output angle on ``branch`` and the reach ratio ``rho = C / sqrt(A^2 + B^2)`` (``|rho| > 1``: no
    assembly), each ``(n,)``.

    ``|P3(phi) - P2|^2 = a2^2`` reads ``A cos phi + B sin phi = C`` with ``D = Q4 - P2``,
    ``A = 2 a3 D·x4``, ``B = 2 a3 D·y4``, ``C = a2^2 - a3^2 - |D|^2`` (``x4, y4`` the first columns
    of ``G4``).  Its phi-derivative is ``2 a2 a3 t4``, so the root with ``sign(t4) = branch`` is
    ``phi = atan2(B, A) - branch * acos(rho)``.
    """
    d = geom.foot - crank_pin(geom, theta1)
    g4 = geom.ground_rotation()
    a, b = 2 * geom.a3 * d @ g4[:, 0], 2 * geom.a3 * d @ g4[:, 1]
    c = geom.a2**2 - geom.a3**2 - np.einsum("ni,ni->n", d, d)
    with np.errstate(divide="ignore", invalid="ignore"):
        rho = c / np.hypot(a, b)
    return np.arctan2(b, a) - branch * np.arccos(np.clip(rho, -1.0, 1.0)), rho


def frame_x(u: np.ndarray) -> np.ndarray:
    """A rotation ``(n, 3, 3)`` whose x axis is the unit vector ``u`` ``(n, 3)``: the coupler frame of
    :func:`estimate` (``docs/conventions.md``, "RSSR": y and z any completion; this one).  Its y is
    ``ref x u`` normalized, ``ref`` the world x where ``|u_z| > 0.9``, else the world z."""
    ref = np.where(np.abs(u[:, 2:3]) > 0.9, np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0]))
    v = np.cross(ref, u)
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    return np.stack([u, v, np.cross(u, v)], axis=2)


def _rz(angle: np.ndarray) -> np.ndarray:
    c, s, z, o = np.cos(angle), np.sin(angle), np.zeros_like(angle), np.ones_like(angle)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2)


def estimate(geom: RssrGeometry, theta1: np.ndarray, phi: np.ndarray) -> LoopState:
    """Loop unknowns that point the coupler from ``P2`` at the output pin of angle ``phi`` ``(n,)``.

    The rotations close exactly; the coupler length closes only if ``phi`` is a solution.
    """
    p2, p3 = crank_pin(geom, theta1), output_pin(geom, phi)
    coupler = frame_x((p3 - p2) / np.linalg.norm(p3 - p2, axis=1, keepdims=True))
    theta4 = math.pi - phi
    ball2 = np.swapaxes(_rz(theta1), 1, 2) @ coupler
    ball3 = np.swapaxes(coupler, 1, 2) @ geom.ground_rotation() @ _rz(-theta4)
    return LoopState(theta4[:, None].copy(), np.stack([ball2, ball3], axis=1))


@dataclass(frozen=True)
class RssrAnalysis:
    """The in-house answer at the ``n`` crank positions of a case.

    ``phi``, ``phi_dot``, ``phi_ddot`` the output angle (rad) and its rates; ``t1``, ``t4`` the
    input and output transmissions; ``status`` words; ``residual`` closure residual;
    ``iterations`` closure iterations; ``reactions`` per joint; ``motions`` of the three links.
    """

    case: RssrCase
    crank: CrankState
    phi: np.ndarray
    phi_dot: np.ndarray
    phi_ddot: np.ndarray
    t1: np.ndarray
    t4: np.ndarray
    status: np.ndarray
    residual: np.ndarray
    iterations: np.ndarray
    reactions: JointReactions
    motions: tuple[BodyMotion, BodyMotion, BodyMotion]


def close(loop: Loop, values: dict[str, np.ndarray], guess: LoopState, reach: np.ndarray
          ) -> tuple[LoopState, np.ndarray, np.ndarray, np.ndarray]:
    """Close ``loop`` from ``guess`` at the positions where ``reach`` ``(n,)`` says it assembles
    (:func:`~dualmech.core.closure.solve_closure`; the others keep ``guess``, ``not_converged`` codes, NaN
    residual: their status is ``no_assembly`` by geometry).  Returns state, closure status codes,
    residual, iterations."""
    n = reach.shape[0]
    codes = np.full(n, ClosureStatus.NOT_CONVERGED, dtype=np.int8)
    residual, iterations = np.full(n, np.nan), np.zeros(n, dtype=int)
    idx = np.flatnonzero(reach)
    if idx.size == 0:
        return guess, codes, residual, iterations
    res = solve_closure(loop, {k: v[idx] for k, v in values.items()}, guess.take(idx))
    codes[idx], residual[idx], iterations[idx] = res.status, res.residual, res.iterations
    return guess.put(idx, res.state), codes, residual, iterations


def _transmissions(geom: RssrGeometry, chain, s1: float) -> tuple[np.ndarray, ...]:
    """``P2``, ``P3``, ``u`` and the transmissions ``t1 = z·((P2 - (0,0,s1)) x u)/a1`` and
    ``t4 = k4·((P3 - Q4) x u)/a3``, ``(n, 3)`` / ``(n,)``."""
    p2, p3 = origin(chain.frames[0]), origin(chain.frames[1])
    u = (p3 - p2) / geom.a2
    t1 = np.cross(p2 - np.array([0.0, 0.0, s1]), u)[:, 2] / geom.a1
    t4 = np.cross(p3 - geom.foot, u) @ geom.k4 / geom.a3
    return p2, p3, u, t1, t4


def assembles(rho: np.ndarray) -> np.ndarray:
    """Whether the output pin's circle meets the coupler's sphere: ``|rho| <= 1`` (to rounding), ``(n,)``."""
    return np.abs(rho) <= 1.0 + ASSEMBLY_REACH.value


def status_words(converged: np.ndarray, t1: np.ndarray, t4: np.ndarray, branch: int,
                 torque_mode: bool, residual: np.ndarray) -> np.ndarray:
    """Status words of every engine, in precedence: not_converged, branch_jump (``sign(t4) != branch``),
    assembly_limit (``|t4|`` below the band: the closure is singular, rates unbounded; also where the
    closure stopped short of its tolerance but within :data:`LIMIT_CLOSURE`), dead_centre (drive torque
    given and ``|t1|`` below the band); ``(n,)`` object array (``residual`` the closure residual)."""
    status = np.full(t4.shape, Status.OK.value, dtype=object)
    limit = ASSEMBLY_LIMIT_CONDITION.value
    status[torque_mode & (np.abs(t1) < DEAD_CENTRE_TRANSMISSION.value)] = Status.DEAD_CENTRE.value
    at_limit = np.abs(t4) < limit
    status[at_limit] = Status.ASSEMBLY_LIMIT.value
    status[(np.sign(t4) != branch) & ~at_limit] = Status.BRANCH_JUMP.value
    status[~converged & ~(at_limit & (residual <= LIMIT_CLOSURE.value))] = Status.NOT_CONVERGED.value
    return status


def analyze_rssr(case: RssrCase, phi_guess: np.ndarray | None = None,
                 crank: CrankState | None = None) -> RssrAnalysis:
    """Displacement, velocity, acceleration and inverse dynamics at every position of ``case``.

    ``phi_guess`` ``(n,)`` replaces the closed-form start estimate of the output angle (tests
    use it to show that Newton, not the estimate, closes the loop); ``crank`` replaces the case's
    crank states (e.g. those of a simulation; ``s`` and its rates are not read).
    """
    geom = case.geometry
    crank = case.motion.state(geom.s1) if crank is None else crank
    theta1 = crank.theta
    phi0, rho = closed_form_phi(geom, theta1, case.branch)
    guess = estimate(geom, theta1, phi0 if phi_guess is None else phi_guess)
    state, codes, residual, iterations = close(LOOP, loop_values(geom, theta1), guess, assembles(rho))
    chain = evaluate(LOOP, loop_values(geom, theta1), state)
    rates = solve_rates(chain, LOOP, {"theta1": crank.theta_dot}, {"theta1": crank.theta_ddot})
    p2, p3, _, t1, t4 = _transmissions(geom, chain, geom.s1)
    n = theta1.shape[0]
    hub = np.tile([0.0, 0.0, geom.s1], (n, 1))
    flip = np.diag([-1.0, -1.0, 1.0])  # output frame: x toward P3, the table's frame {4} has x toward Q4
    frames = ((chain.frames[0].re, hub), (chain.frames[1].re, p2), (chain.frames[2].re @ flip, origin(
        chain.frames[2])))
    motions = tuple(body_motion(b, r, o, rates.link_twist[i], rates.link_accel[i])
                    for i, (b, (r, o)) in enumerate(zip(case.bodies, frames)))
    reactions = rssr_reactions(case, motions, p2, p3, n)
    status = status_words(codes == ClosureStatus.OK, t1, t4, case.branch, case.mode == "torque", residual)
    status[~assembles(rho)] = Status.NO_ASSEMBLY.value
    phi = np.mod(math.pi - state.scalars[:, 0] + math.pi, 2 * math.pi) - math.pi
    return RssrAnalysis(case, crank, phi, -rates.q_dot[:, 0], -rates.q_ddot[:, 0], t1, t4, status,
                        residual, iterations, reactions, motions)


def rssr_reactions(case: RssrCase, motions: tuple[BodyMotion, ...], p2: np.ndarray, p3: np.ndarray,
                   n: int) -> JointReactions:
    """The four joints' reactions (``docs/conventions.md``, "RSSR"): ``j1`` ground on the input crank
    at ``(0, 0, s1)``, ``j2`` input crank on coupler at ``P2``, ``j3`` coupler on output crank at
    ``P3``, ``j4`` ground on output crank at ``Q4``; the given load is ``j1``'s moment about z
    or ``j4``'s about ``k4``."""
    geom = case.geometry
    hub = np.tile([0.0, 0.0, geom.s1], (n, 1))
    foot = np.tile(geom.foot, (n, 1))
    joints = (Joint("j1", 0, -1, hub, True), Joint("j2", 1, 0, p2, False), Joint("j3", 2, 1, p3, False),
              Joint("j4", 2, -1, foot, True))
    if case.mode == "torque":
        given = GivenLoad(0, np.tile([0.0, 0.0, 1.0], (n, 1)), np.full(n, case.drive_torque))
    else:
        given = GivenLoad(3, np.tile(geom.k4, (n, 1)), np.full(n, case.output_torque))
    with np.errstate(divide="ignore", invalid="ignore"):
        return solve_joint_reactions(case.bodies, motions, joints, case.gravity, (given,),
                                     np.full(n, geom.a2))


def to_table(an: RssrAnalysis) -> LinkageTable:
    """The result table of ``an`` (:data:`COLUMNS`), settled: columns a row's status does not give are NaN."""
    r, geom = an.reactions, an.case.geometry
    cols = {"theta1_deg": np.degrees(an.crank.theta), "phi4_deg": np.degrees(an.phi),
            "phi4_dot": an.phi_dot, "phi4_ddot": an.phi_ddot}
    for j in JOINTS:
        for k, axis in enumerate("xyz"):
            cols[f"{j}_f{axis}"] = r.force[j][:, k]
        if j in ("j1", "j4"):
            for k, axis in enumerate("xyz"):
                cols[f"{j}_m{axis}"] = r.moment[j][:, k]
    # j1's moment is reported about O (as the slider crank's): move it from the hub (0, 0, s1)
    hub = np.array([0.0, 0.0, geom.s1])
    m1 = r.moment["j1"] + np.cross(hub, r.force["j1"])
    cols.update({"j1_mx": m1[:, 0], "j1_my": m1[:, 1], "j1_mz": m1[:, 2]})
    cols.update({"drive_torque": r.moment["j1"][:, 2], "output_torque": r.moment["j4"] @ geom.k4,
                 "transmission_in": an.t1, "transmission_out": an.t4, "residual": an.residual,
                 "dynamics_residual": r.residual})
    cols = {c: np.array(cols[c], dtype=float) for c in COLUMNS}
    status = settle(cols, an.status, REACTIONS, pose=POSE, rates=RATES)
    messages = no_assembly_messages(cols["theta1_deg"], status, "the coupler cannot reach the output crank")
    return LinkageTable("dualmech", an.case.name, cols, status,
                        {"iterations": an.iterations, "messages": messages, "branch": an.case.branch})


def no_assembly_messages(theta_deg: np.ndarray, status: np.ndarray, why: str) -> list[str]:
    """``["no_assembly: <why> at crank angles a..b, c..d deg"]`` for the ``no_assembly`` runs of ``status``
    ``(n,)`` (``theta_deg`` ``(n,)``), or ``[]``."""
    ranges = no_assembly_ranges(theta_deg, is_status(status, Status.NO_ASSEMBLY))
    return [f"no_assembly: {why} at crank angles {format_angle_ranges(ranges)} deg"] if ranges else []
