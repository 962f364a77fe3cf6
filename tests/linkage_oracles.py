"""The RSSR's and RCCC's closed-form pipelines: the tests' oracles of the loop engine on their preset tables.

Each mechanism's own link-joint table (``docs/conventions.md``, "RSSR", "RCCC"; the RSSR's coupler and
output crank as two rows of ball joints, the RCCC's as revolute and three cylindrical rows), closed
position by position from the mechanism's own start estimate (the RSSR's closed-form output angle
:func:`~dualmech.models.linkages.rssr.closed_form_phi`, the RCCC's spherical estimate
:func:`~dualmech.models.linkages.rccc.spherical_estimate`) by the generic dual-number Newton
(:func:`~dualmech.core.closure.solve_closure`), rates by the generic screw sums
(:func:`~dualmech.core.rates.solve_rates`), reactions by the Newton-Euler least squares of
:mod:`tests.linkage_reactions` in the mechanism's own body frames and reference points, and the result
tables by the mechanism's status rules (:func:`~dualmech.models.linkages.rssr.status_words`).  These were
the product's pipelines before the RSSR and RCCC were solved and simulated by the loop engine on their
preset tables (:mod:`dualmech.models.loop.preset_engine`, :mod:`dualmech.models.loop.preset_dynamics`);
they share with it the start estimates, the status rules and ``core``'s closure and rates, not the joint
table, the continuation, the compiled kernel, the readback or the reactions.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from dualmech.core.closure import ClosureStatus, solve_closure
from dualmech.core.dual import origin
from dualmech.core.loop import Chain, Loop, LoopState, Row, evaluate, inp, par, unk
from dualmech.core.motion import CrankState
from dualmech.core.rates import solve_rates
from dualmech.core.reactions import BodyMotion, body_motion
from dualmech.core.status import Status, settle
from dualmech.models.linkages import rccc, rssr
from dualmech.models.linkages.rccc_case import RcccCase, RcccGeometry
from dualmech.models.linkages.rssr_case import RssrCase, RssrGeometry
from dualmech.models.tables import LinkageTable, TableSpec
from tests.linkage_reactions import GivenLoad, Joint, JointReactions, solve_joint_reactions

#: Joint names of the reaction columns, in loop order (``j1`` ... ``j4``).
JOINTS = ("j1", "j2", "j3", "j4")


def _rx(angle: float) -> np.ndarray:
    """The rotation ``(3, 3)`` by ``angle`` (rad) about x."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


RSSR_LOOP = Loop(
    rows=(
        Row("joint1", theta=inp("theta1"), s=par("s1"), a=par("a1")),
        Row("joint2", spherical=True, a=par("a2")),
        Row("joint3", spherical=True, a=par("a3")),
        Row("joint4", theta=unk("theta4"), s=par("s4"), alpha=par("alpha4"), a=par("a4")),
    ),
    spin_gauges=(1,),
    length_scale="a2",
)


def rssr_loop_values(geom: RssrGeometry, theta1: np.ndarray) -> dict[str, np.ndarray]:
    """Inputs and parameters of :data:`RSSR_LOOP` at the crank angles ``theta1`` ``(n,)`` (rad)."""
    full = np.ones_like(theta1)
    return {"theta1": theta1, "s1": geom.s1 * full, "a1": geom.a1 * full, "a2": geom.a2 * full,
            "a3": geom.a3 * full, "s4": -geom.h * full, "alpha4": geom.alpha4 * full, "a4": geom.a4 * full}


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
    phi0, rho = rssr.closed_form_phi(geom, theta1, case.branch)
    guess = rssr.estimate(geom, theta1, phi0 if phi_guess is None else phi_guess)
    values = rssr_loop_values(geom, theta1)
    state, codes, residual, iterations = close(RSSR_LOOP, values, guess, rssr.assembles(rho))
    chain = evaluate(RSSR_LOOP, values, state)
    rates = solve_rates(chain, RSSR_LOOP, {"theta1": crank.theta_dot}, {"theta1": crank.theta_ddot})
    p2, p3, _, t1, t4 = _transmissions(geom, chain, geom.s1)
    n = theta1.shape[0]
    hub = np.tile([0.0, 0.0, geom.s1], (n, 1))
    flip = np.diag([-1.0, -1.0, 1.0])  # output frame: x toward P3, the table's frame {4} has x toward Q4
    frames = ((chain.frames[0].re, hub), (chain.frames[1].re, p2), (chain.frames[2].re @ flip, origin(
        chain.frames[2])))
    motions = tuple(body_motion(b, r, o, rates.link_twist[i], rates.link_accel[i])
                    for i, (b, (r, o)) in enumerate(zip(case.bodies, frames)))
    reactions = rssr_reactions(case, motions, p2, p3, n)
    torque_mode = case.mode == "torque"
    status = rssr.status_words(codes == ClosureStatus.OK, t1, t4, case.branch, torque_mode, residual)
    status[~rssr.assembles(rho)] = Status.NO_ASSEMBLY.value
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


def rssr_to_table(an: RssrAnalysis) -> LinkageTable:
    """The result table of ``an`` (:data:`~dualmech.models.linkages.rssr.COLUMNS`), settled: columns a row's
    status does not give are NaN."""
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
    return _settled(an, cols, rssr.SPEC, "the coupler cannot reach the output crank")


RCCC_LOOP = Loop(
    rows=(
        Row("joint1", theta=inp("theta1"), s=par("s1"), alpha=par("alpha1"), a=par("a1")),
        Row("joint2", theta=unk("theta2"), s=unk("s2"), alpha=par("alpha2"), a=par("a2")),
        Row("joint3", theta=unk("theta3"), s=unk("s3"), alpha=par("alpha3"), a=par("a3")),
        Row("joint4", theta=unk("theta4"), s=unk("s4"), alpha=par("alpha4"), a=par("a4")),
    ),
    length_scale="size",
)


def rccc_loop_values(geom: RcccGeometry, theta1: np.ndarray) -> dict[str, np.ndarray]:
    """Inputs and parameters of :data:`RCCC_LOOP` (and its length scale ``size``) at ``theta1`` ``(n,)``."""
    full = np.ones_like(theta1)
    values = {"theta1": theta1, "s1": geom.s1 * full, "size": geom.size * full}
    for i in range(4):
        values[f"a{i + 1}"], values[f"alpha{i + 1}"] = geom.a[i] * full, geom.alpha[i] * full
    return values


def rccc_transmission(chain: Chain, geom: RcccGeometry) -> np.ndarray:
    """``t = det[z2, z3, z4] / |sin alpha23 sin alpha34|`` in [-1, 1]: 0 at the assembly limit, its sign
    the branch, ``(n,)``."""
    z2, z3, z4 = (chain.frames[i].re[:, :, 2] for i in range(3))
    norm = abs(math.sin(geom.alpha[1]) * math.sin(geom.alpha[2]))
    return np.einsum("ni,ni->n", z2, np.cross(z3, z4)) / norm


def rccc_body_frames(chain: Chain, geom: RcccGeometry) -> list[tuple[np.ndarray, np.ndarray]]:
    """Rotation ``(n, 3, 3)`` and origin ``(n, 3)`` of each moving link's body frame: on its first axis
    ``z_k``, x along the common normal toward ``z_(k+1)`` (the table's frame before ``X(alpha + eps a)``)."""
    out = []
    for k in range(3):
        end = chain.frames[k]
        rot = end.re @ _rx(-geom.alpha[k])
        out.append((rot, origin(end) - geom.a[k] * end.re[:, :, 0]))
    return out


@dataclass(frozen=True)
class RcccAnalysis:
    """The in-house answer at the ``n`` crank positions of an RCCC case (``q``, ``q_dot``, ``q_ddot``
    ``(n, 6)``: theta2, s2, theta3, s3, theta4, s4 and their rates)."""

    case: RcccCase
    crank: CrankState
    q: np.ndarray
    q_dot: np.ndarray
    q_ddot: np.ndarray
    t: np.ndarray
    status: np.ndarray
    residual: np.ndarray
    iterations: np.ndarray
    reactions: JointReactions
    motions: tuple[BodyMotion, BodyMotion, BodyMotion]
    frames: list[tuple[np.ndarray, np.ndarray]]


def analyze_rccc(case: RcccCase, guess: LoopState | None = None, crank: CrankState | None = None
                 ) -> RcccAnalysis:
    """Displacement, velocity, acceleration and inverse dynamics at every position of ``case``
    (``guess`` replaces the spherical start estimate: tests use it; ``crank`` the case's crank states, as
    :func:`analyze_rssr`'s)."""
    geom = case.geometry
    crank = case.motion.state(geom.s1) if crank is None else crank
    z3, rho = rccc.spherical_estimate(geom, crank.theta, case.branch)
    values = rccc_loop_values(geom, crank.theta)
    start = rccc.estimate(geom, crank.theta, z3) if guess is None else guess
    state, codes, residual, iterations = close(RCCC_LOOP, values, start, rssr.assembles(rho))
    chain = evaluate(RCCC_LOOP, values, state)
    with np.errstate(all="ignore"):
        rates = solve_rates(chain, RCCC_LOOP, {"theta1": crank.theta_dot}, {"theta1": crank.theta_ddot})
        frames = rccc_body_frames(chain, geom)
        motions = tuple(body_motion(b, r, o, rates.link_twist[i], rates.link_accel[i])
                        for i, (b, (r, o)) in enumerate(zip(case.bodies, frames)))
        reactions = rccc_reactions(case, chain, motions, frames)
    t = rccc_transmission(chain, geom)
    status = rssr.status_words(codes == ClosureStatus.OK, np.ones_like(t), t, case.branch, False, residual)
    status[~rssr.assembles(rho)] = Status.NO_ASSEMBLY.value
    return RcccAnalysis(case, crank, state.scalars, rates.q_dot, rates.q_ddot, t, status, residual,
                        iterations, reactions, motions, frames)


def rccc_reactions(case: RcccCase, chain: Chain, motions: tuple[BodyMotion, ...],
                   frames: list[tuple[np.ndarray, np.ndarray]]) -> JointReactions:
    """``j1`` ground on the input link (moment about O), ``j2`` / ``j3`` the previous link on links 2 / 3
    (moments about their body origins on ``z2`` / ``z3``), ``j4`` ground on the output link (moment about
    ``G = (-a41, 0, 0)`` on ``z4``); each cylinder transmits no force and no moment along its axis but the
    given ``output_torque`` about ``z4``."""
    geom = case.geometry
    n = chain.closure.re.shape[0]
    ground = np.tile([-geom.a[3], 0.0, 0.0], (n, 1))
    joints = (Joint("j1", 0, -1, np.zeros((n, 3)), True), Joint("j2", 1, 0, frames[1][1], True),
              Joint("j3", 2, 1, frames[2][1], True), Joint("j4", 2, -1, ground, True))
    given = []
    for j in (1, 2, 3):
        z = chain.frames[j - 1].re[:, :, 2]
        torque = case.output_torque if j == 3 else 0.0
        given += [GivenLoad(j, z, np.zeros(n), force=True), GivenLoad(j, z, np.full(n, torque))]
    return solve_joint_reactions(case.bodies, motions, joints, case.gravity, tuple(given),
                                 np.full(n, geom.size))


def rccc_to_table(an: RcccAnalysis) -> LinkageTable:
    """The result table of ``an`` (:data:`~dualmech.models.linkages.rccc.COLUMNS`), settled by the status
    words."""
    r = an.reactions
    cols = {"theta1_deg": np.degrees(an.crank.theta),
            "theta4_deg": np.degrees(np.mod(an.q[:, 4] + math.pi, 2 * math.pi) - math.pi), "s4": an.q[:, 5],
            "theta4_dot": an.q_dot[:, 4], "s4_dot": an.q_dot[:, 5], "theta4_ddot": an.q_ddot[:, 4],
            "s4_ddot": an.q_ddot[:, 5]}
    for j in JOINTS:
        for k, axis in enumerate("xyz"):
            cols[f"{j}_f{axis}"], cols[f"{j}_m{axis}"] = r.force[j][:, k], r.moment[j][:, k]
    z4 = _rx(-an.case.geometry.alpha[3])[:, 2]
    cols.update({"drive_torque": r.moment["j1"][:, 2], "output_torque": r.moment["j4"] @ z4,
                 "transmission_out": an.t, "residual": an.residual, "dynamics_residual": r.residual})
    return _settled(an, cols, rccc.SPEC, "the axes' cones about z2 and z4 do not meet")


def _settled(an: RssrAnalysis | RcccAnalysis, cols: dict[str, np.ndarray], spec: TableSpec,
             why: str) -> LinkageTable:
    """The result table of ``an``'s columns ``cols`` (in ``spec``'s order), settled by its status words:
    columns a row's status does not give are NaN; ``meta``: iterations, the ``no_assembly`` messages
    (``why`` the geometry does not reach), branch."""
    cols = {c: np.array(cols[c], dtype=float) for c in spec.columns}
    status = settle(cols, an.status, spec.reactions, pose=spec.pose, rates=spec.rates)
    messages = rssr.no_assembly_messages(cols["theta1_deg"], status, why)
    return LinkageTable("dualmech", an.case.name, cols, status,
                        {"iterations": an.iterations, "messages": messages, "branch": an.case.branch})
