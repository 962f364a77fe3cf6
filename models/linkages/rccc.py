"""The RCCC linkage (Yang 1971) by the dual-number method: one input revolute, three cylindrical joints.

::

    row  joint              theta      S      eta  alpha        a
    1    revolute (1)       theta1*    s1     0    alpha12      a12
    2    cylindrical (2)    theta2?    s2?    0    alpha23      a23
    3    cylindrical (3)    theta3?    s3?    0    alpha34      a34
    4    cylindrical (4)    theta4?    s4?    0    alpha41      a41

    * prescribed input   ? unknown

The primary (real) part of the loop equation is the spherical four-bar of the four axes, the
dual part is then linear in the slides: the start estimate solves the spherical part in closed
form (the axis ``z3`` on the two cones about ``z2`` and ``z4``, :func:`spherical_estimate`) with
the slides at 0, and the generic dual-number Newton (:func:`~dualmech.core.closure.solve_closure`)
finds the slides and polishes the angles.  Rates by the generic screw sums, reactions by the
generic Newton-Euler least squares with each cylinder's zero axial force and moment as rows.

The in-house engine is the loop engine on the RCCC's preset table (:mod:`dualmech.models.loop.preset_engine`),
started from :func:`spherical_estimate` and :func:`estimate`; the pipeline here (:func:`analyze_rccc`) is
the forward dynamics' analysis (:mod:`dualmech.models.linkages.forward_dynamics`) and the tests' oracle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from dualmech.core.closure import ClosureStatus
from dualmech.core.dual import origin
from dualmech.core.loop import Chain, Loop, LoopState, Row, evaluate, inp, par, unk
from dualmech.core.motion import CrankState
from dualmech.core.rates import solve_rates
from dualmech.core.reactions import BodyMotion, body_motion
from dualmech.core.status import Status, settle
from dualmech.models.linkages.dynamics import GivenLoad, Joint, JointReactions, solve_joint_reactions
from dualmech.models.linkages.rccc_case import RcccCase, RcccGeometry
from dualmech.models.linkages.rssr import assembles, close, no_assembly_messages, status_words
from dualmech.models.tables import LinkageTable, TableSpec

LOOP = Loop(
    rows=(
        Row("joint1", theta=inp("theta1"), s=par("s1"), alpha=par("alpha1"), a=par("a1")),
        Row("joint2", theta=unk("theta2"), s=unk("s2"), alpha=par("alpha2"), a=par("a2")),
        Row("joint3", theta=unk("theta3"), s=unk("s3"), alpha=par("alpha3"), a=par("a3")),
        Row("joint4", theta=unk("theta4"), s=unk("s4"), alpha=par("alpha4"), a=par("a4")),
    ),
    length_scale="size",
)
JOINTS = ("j1", "j2", "j3", "j4")
#: Output columns of an RCCC result table, in order (``docs/conventions.md``, "RCCC").
COLUMNS: tuple[str, ...] = (
    "theta1_deg", "theta4_deg", "s4", "theta4_dot", "s4_dot", "theta4_ddot", "s4_ddot",
    *(f"{j}_{k}{axis}" for j in JOINTS for k in "fm" for axis in "xyz"),
    "drive_torque", "output_torque", "transmission_out", "residual", "dynamics_residual",
)
REACTIONS: tuple[str, ...] = COLUMNS[7:33] + ("dynamics_residual",)
POSE: tuple[str, ...] = ("theta4_deg", "s4", "transmission_out")
RATES: tuple[str, ...] = ("theta4_dot", "s4_dot", "theta4_ddot", "s4_ddot")
SPEC = TableSpec(COLUMNS, POSE, RATES, REACTIONS)


def loop_values(geom: RcccGeometry, theta1: np.ndarray) -> dict[str, np.ndarray]:
    """Inputs and parameters of :data:`LOOP` (and its length scale ``size``) at ``theta1`` ``(n,)``."""
    full = np.ones_like(theta1)
    values = {"theta1": theta1, "s1": geom.s1 * full, "size": geom.size * full}
    for i in range(4):
        values[f"a{i + 1}"], values[f"alpha{i + 1}"] = geom.a[i] * full, geom.alpha[i] * full
    return values


def _rot(axis: int, angle: np.ndarray) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    out = np.zeros(angle.shape + (3, 3))
    out[..., axis, axis] = 1.0
    out[..., i, i], out[..., j, j], out[..., i, j], out[..., j, i] = c, c, -s, s
    return out


def axes(geom: RcccGeometry, theta1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``z2`` ``(n, 3)`` (turning with the input) and ``z4`` ``(3,)`` (fixed), world axes."""
    z2 = (_rot(2, theta1) @ _rot(0, np.full_like(theta1, geom.alpha[0])))[:, :, 2]
    z4 = _rot(0, np.array(-geom.alpha[3]))[:, 2]
    return z2, z4


def spherical_estimate(geom: RcccGeometry, theta1: np.ndarray, branch: int
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Axis ``z3`` ``(n, 3)`` with ``z2·z3 = cos alpha23``, ``z3·z4 = cos alpha34`` and
    ``sign(det[z2, z3, z4]) = branch``, and the reach ``rho = |a z2 + b z4|^2`` (> 1: no assembly).

    ``z3 = a z2 + b z4 + c z2 x z4`` with ``a + b g = cos alpha23``, ``a g + b = cos alpha34``
    (``g = z2·z4``) and ``c^2 |z2 x z4|^2 = 1 - rho``; ``det[z2, z3, z4] = -c |z2 x z4|^2``.
    """
    z2, z4 = axes(geom, theta1)
    g = z2 @ z4
    c23, c34 = math.cos(geom.alpha[1]), math.cos(geom.alpha[2])
    with np.errstate(divide="ignore", invalid="ignore"):
        det = 1.0 - g**2
        a, b = (c23 - g * c34) / det, (c34 - g * c23) / det
        rho = a**2 + b**2 + 2 * a * b * g
        c = -branch * np.sqrt(np.maximum(1.0 - rho, 0.0) / det)
    return a[:, None] * z2 + b[:, None] * z4 + c[:, None] * np.cross(z2, z4), rho


def _angle(x_from: np.ndarray, x_to: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Angle about ``z`` from ``x_from`` to ``x_to`` (all ``(n, 3)``, the x's normal to ``z``)."""
    return np.arctan2(np.einsum("ni,ni->n", np.cross(x_from, x_to), z), np.einsum("ni,ni->n", x_from, x_to))


def estimate(geom: RcccGeometry, theta1: np.ndarray, z3: np.ndarray) -> LoopState:
    """Loop unknowns from the axis ``z3``: the joint angles of the spherical part, the slides 0."""
    z2, z4 = axes(geom, theta1)
    z4 = np.broadcast_to(z4, z2.shape)
    x2 = _rot(2, theta1)[:, :, 0]
    x3, x4 = (np.cross(za, zb) / np.sin(alpha) for za, zb, alpha in ((z2, z3, geom.alpha[1]),
                                                                      (z3, z4, geom.alpha[2])))
    x1 = np.broadcast_to([1.0, 0.0, 0.0], z2.shape)
    zero = np.zeros_like(theta1)
    scalars = np.stack([_angle(x2, x3, z2), zero, _angle(x3, x4, z3), zero, _angle(x4, x1, z4), zero], 1)
    return LoopState(scalars, np.zeros((theta1.shape[0], 0, 3, 3)))


def transmission(chain: Chain, geom: RcccGeometry) -> np.ndarray:
    """``t = det[z2, z3, z4] / |sin alpha23 sin alpha34|`` in [-1, 1]: 0 at the assembly limit, its sign
    the branch, ``(n,)``."""
    z2, z3, z4 = (chain.frames[i].re[:, :, 2] for i in range(3))
    norm = abs(math.sin(geom.alpha[1]) * math.sin(geom.alpha[2]))
    return np.einsum("ni,ni->n", z2, np.cross(z3, z4)) / norm


def body_frames(chain: Chain, geom: RcccGeometry) -> list[tuple[np.ndarray, np.ndarray]]:
    """Rotation ``(n, 3, 3)`` and origin ``(n, 3)`` of each moving link's body frame: on its first axis
    ``z_k``, x along the common normal toward ``z_(k+1)`` (the table's frame before ``X(alpha + eps a)``)."""
    out = []
    for k in range(3):
        end = chain.frames[k]
        rot = end.re @ _rot(0, np.array(-geom.alpha[k]))
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


def analyze_rccc(case: RcccCase, guess: LoopState | None = None) -> RcccAnalysis:
    """Displacement, velocity, acceleration and inverse dynamics at every position of ``case``
    (``guess`` replaces the spherical start estimate: tests use it)."""
    geom = case.geometry
    crank = case.motion.state(geom.s1)
    z3, rho = spherical_estimate(geom, crank.theta, case.branch)
    values = loop_values(geom, crank.theta)
    start = estimate(geom, crank.theta, z3) if guess is None else guess
    state, codes, residual, iterations = close(LOOP, values, start, assembles(rho))
    chain = evaluate(LOOP, values, state)
    with np.errstate(all="ignore"):
        rates = solve_rates(chain, LOOP, {"theta1": crank.theta_dot}, {"theta1": crank.theta_ddot})
        frames = body_frames(chain, geom)
        motions = tuple(body_motion(b, r, o, rates.link_twist[i], rates.link_accel[i])
                        for i, (b, (r, o)) in enumerate(zip(case.bodies, frames)))
        reactions = rccc_reactions(case, chain, motions, frames)
    t = transmission(chain, geom)
    status = status_words(codes == ClosureStatus.OK, np.ones_like(t), t, case.branch, False, residual)
    status[~assembles(rho)] = Status.NO_ASSEMBLY.value
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


def to_table(an: RcccAnalysis) -> LinkageTable:
    """The result table of ``an`` (:data:`COLUMNS`), settled by the status words."""
    r = an.reactions
    cols = {"theta1_deg": np.degrees(an.crank.theta),
            "theta4_deg": np.degrees(np.mod(an.q[:, 4] + math.pi, 2 * math.pi) - math.pi), "s4": an.q[:, 5],
            "theta4_dot": an.q_dot[:, 4], "s4_dot": an.q_dot[:, 5], "theta4_ddot": an.q_ddot[:, 4],
            "s4_ddot": an.q_ddot[:, 5]}
    for j in JOINTS:
        for k, axis in enumerate("xyz"):
            cols[f"{j}_f{axis}"], cols[f"{j}_m{axis}"] = r.force[j][:, k], r.moment[j][:, k]
    z4 = _rot(0, np.array(-an.case.geometry.alpha[3]))[:, 2]
    cols.update({"drive_torque": r.moment["j1"][:, 2], "output_torque": r.moment["j4"] @ z4,
                 "transmission_out": an.t, "residual": an.residual, "dynamics_residual": r.residual})
    cols = {c: np.array(cols[c], dtype=float) for c in COLUMNS}
    status = settle(cols, an.status, REACTIONS, pose=POSE, rates=RATES)
    messages = no_assembly_messages(cols["theta1_deg"], status, "the axes' cones about z2 and z4 do not meet")
    return LinkageTable("dualmech", an.case.name, cols, status,
                        {"iterations": an.iterations, "messages": messages, "branch": an.case.branch})

