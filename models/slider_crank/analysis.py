"""The in-house engine: displacement, velocity, acceleration and inverse dynamics of a case.

:func:`analyze_many` runs the whole analysis for all positions of many cases at once (the
geometry is a per-position parameter of the loop, :class:`~dualmech.models.slider_crank.loop.Batch`,
so cases share one batch): the loop closure of :mod:`dualmech.models.slider_crank.closure`,
then screws for the rates, dual momentum and D'Alembert for the reactions, the edges of
assembly and the dead centres.  :func:`to_table` turns the result into the common
:class:`~dualmech.core.table.ResultTable`; :func:`solve_case` runs the compiled kernel, which
computes the same.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Iterator, Sequence

import numpy as np

from dualmech.core.assembly import closure_condition, edge_status, reach
from dualmech.core.dual import Dual, origin
from dualmech.core.inertia import MassArrays
from dualmech.core.loop import LoopState, evaluate
from dualmech.core.motion import CrankState
from dualmech.core.rates import Rates, solve_rates
from dualmech.core.reactions import BodyMotion, Reactions, body_motion, solve_reactions
from dualmech.core.status import Status, flag_joint_lock, is_status, joint_locked, settle
from dualmech.core.table import NUMERIC_COLUMNS, REACTION_COLUMNS, ResultTable
from dualmech.core.thresholds import ASSEMBLY_LIMIT_CONDITION, ASSEMBLY_REACH
from dualmech.core.universal import joint_axes, link_frame, universal_motion
from dualmech.models.angle_ranges import status_messages
from dualmech.models.case import Case
from dualmech.models.mechanism import crank_pin
from dualmech.models.slider_crank.closure import close_loop
from dualmech.models.slider_crank.loop import DEAD_CENTRE, LOOP, Batch
from dualmech.models.units import column_unit

#: Positions analysed together at most: bounds memory (about 9 kB of work arrays per position) and keeps
#: the work arrays near the CPU caches (10k: 67k positions/s, 50k: 62k, 2k: 59k on the CI machine).
CHUNK_POSITIONS = 10_000


@dataclass(frozen=True)
class Analysis:
    """Everything the in-house solver computes for one case (arrays over its ``n`` positions).

    ``status`` is an object array of status words (``docs/conventions.md``);
    ``iterations`` and ``closure_residual`` per position; ``closure_condition`` the
    ``|u·k4|`` of ``docs/conventions.md`` (geometric where the loop did not close); ``motions`` the crank,
    rod and slider :class:`BodyMotion`; ``rates`` the loop :class:`Rates`;
    ``reactions`` the :class:`Reactions` (not masked: see :func:`to_table`); ``moment_axis`` ``(n, 3)``
    the universal joint's moment axis ``n`` the reactions were solved with (zero rows: a ball joint, or a
    universal joint at its lock), for solving them again under other loads
    (:func:`dualmech.models.slider_crank.forward_dynamics.simulate`).
    """

    case: Case
    crank: CrankState
    s4: np.ndarray
    status: np.ndarray
    iterations: np.ndarray
    closure_residual: np.ndarray
    p2: np.ndarray
    p3: np.ndarray
    transmission: np.ndarray
    closure_condition: np.ndarray
    rates: Rates
    motions: tuple[BodyMotion, BodyMotion, BodyMotion]
    reactions: Reactions
    moment_axis: np.ndarray


def _take(obj, index: slice):
    """Slice every array field of a dataclass (recursively through lists and tuples) along axis 0."""
    if isinstance(obj, np.ndarray):
        return obj[index]
    if isinstance(obj, (list, tuple)):
        return type(obj)(_take(o, index) for o in obj)
    if hasattr(obj, "__dataclass_fields__"):
        return type(obj)(**{f.name: _take(getattr(obj, f.name), index) for f in fields(obj)})
    return obj


def _rod_motion(rotation: np.ndarray, twist: Dual, accel: Dual, p2: np.ndarray, u: np.ndarray,
                k4: np.ndarray, universal: np.ndarray) -> tuple[np.ndarray, Dual, Dual]:
    """The rod's axes, twist and its rate: the table's zero-spin gauge, or where ``universal`` the spin
    the universal joint at ``P3`` determines (:mod:`dualmech.core.universal`)."""
    if not universal.any():
        return rotation, twist, accel
    at = np.flatnonzero(universal)
    spun = universal_motion(_take(twist, at), _take(accel, at), p2[at], u[at], k4[at])
    rotation, twist, accel = rotation.copy(), Dual(twist.re.copy(), twist.du.copy()), \
        Dual(accel.re.copy(), accel.du.copy())
    rotation[at] = link_frame(u[at], k4[at])
    for whole, part in ((twist, spun[0]), (accel, spun[1])):
        whole.re[at], whole.du[at] = part.re, part.du
    return rotation, twist, accel


def _analyze_batch(cases: Sequence[Case], cranks: Sequence[CrankState]) -> list[Analysis]:
    batch = Batch.of(cases, cranks)
    return analyze_closed(cases, cranks, batch, close_loop(batch))


def analyze_closed(cases: Sequence[Case], cranks: Sequence[CrankState], batch: Batch,
                   closed: tuple[LoopState, np.ndarray, np.ndarray, np.ndarray]) -> list[Analysis]:
    """Everything after the loop closure, for the positions of ``batch`` (``Batch.of(cases, cranks)``).

    ``closed`` is ``(state, status, iterations, residual)`` as
    :func:`~dualmech.models.slider_crank.closure.close_loop` returns them.  Every step is numpy over
    the positions, generic in the scalar type (:func:`dualmech.core.dual.scalar_type`): the tolerance
    study passes complex cases and a state polished in complex arithmetic
    (:func:`dualmech.core.closure.polish`) to take derivatives through this code.
    """
    counts = [len(c) for c in cranks]
    state, status, iters, residual = closed
    chain = evaluate(LOOP, batch.inputs(), state)
    c = batch.crank
    rates = solve_rates(chain, LOOP, {"theta1": c.theta_dot, "S1": c.s_dot},
                        {"theta1": c.theta_ddot, "S1": c.s_ddot})
    p2, p3 = origin(chain.frames[0]), origin(chain.frames[1])
    u = (p3 - p2) / batch.a2[:, None]
    hub = np.stack([np.zeros_like(c.s), np.zeros_like(c.s), c.s], 1)
    transmission = np.cross(p2 - hub, u)[:, 2] / batch.a1
    _, k4 = batch.slider_line()
    condition_closed = closure_condition(p2, p3, k4)
    universal_joint = np.repeat([k.joints.universal for k in cases], counts)
    # where the joint locks its spin is not determined: the gauge's instead (joint_lock gives the pose only)
    universal = universal_joint & ~joint_locked(condition_closed, universal_joint)
    rod = _rod_motion(chain.frames[1].re, rates.link_twist[1], rates.link_accel[1], p2, u, k4, universal)
    frames = ((chain.frames[0].re, hub, rates.link_twist[0], rates.link_accel[0]), (*rod[:1], p2, *rod[1:]),
              (np.broadcast_to(np.eye(3), chain.frames[0].re.shape), p3, rates.link_twist[2],
               rates.link_accel[2]))
    bodies = tuple(MassArrays.repeat([getattr(k.bodies, name) for k in cases], counts)
                   for name in ("crank", "rod", "slider"))
    motions = tuple(body_motion(b, *f) for b, f in zip(bodies, frames))
    closed = is_status(status, Status.OK)
    status, condition = edge_status(status, closed, batch.reach(), condition_closed,
                                    ASSEMBLY_REACH.value, ASSEMBLY_LIMIT_CONDITION.value)
    s4 = np.where(is_status(status, Status.ASSEMBLY_LIMIT) & ~closed, batch.foot_s4(), state.scalars[:, 0])
    given = np.array([[np.nan if k.loads.drive_torque is None else k.loads.drive_torque,
                       np.nan if k.loads.slider_force is None else k.loads.slider_force] for k in cases])
    gravity = np.repeat([k.loads.gravity for k in cases], counts, axis=0)
    moment_axis = np.where(universal[:, None], joint_axes(u, k4)[1], 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        reactions = solve_reactions(bodies, motions, p2, p3, k4, gravity,
                                    np.repeat(given[:, 0], counts), np.repeat(given[:, 1], counts),
                                    moment_axis)
    torque_mode = np.repeat(np.isfinite(given[:, 0]), counts)
    dead = is_status(status, Status.OK) & torque_mode & (np.abs(transmission) < DEAD_CENTRE)
    status[dead] = Status.DEAD_CENTRE.value
    status = flag_joint_lock(status, condition, universal_joint)
    out, start = [], 0
    for case, crank, n in zip(cases, cranks, counts):
        sl = slice(start, start + n)
        start += n
        out.append(Analysis(case, crank, s4[sl], status[sl], iters[sl], residual[sl], p2[sl], p3[sl],
                            transmission[sl], condition[sl], _take(rates, sl), _take(motions, sl),
                            _take(reactions, sl), moment_axis[sl]))
    return out


def iter_analyses(cases: Sequence[Case], cranks: Sequence[CrankState] | None = None,
                  chunk_positions: int = CHUNK_POSITIONS) -> Iterator[Analysis]:
    """Analyse many cases, batching up to ``chunk_positions`` positions at a time; yields one per case.

    Crank states are built chunk by chunk, so memory stays bounded by the chunk
    size (plus the case list) however many positions there are in all.
    """
    def crank(i: int) -> CrankState:
        return cases[i].own_crank_states() if cranks is None else cranks[i]

    group: list[int] = []
    size = 0
    for i, case in enumerate(cases):
        n = len(case.motion.angles_deg) if cranks is None else len(cranks[i])
        if group and size + n > chunk_positions:
            yield from _analyze_batch([cases[j] for j in group], [crank(j) for j in group])
            group, size = [], 0
        group.append(i)
        size += n
    if group:
        yield from _analyze_batch([cases[j] for j in group], [crank(j) for j in group])


def analyze_many(cases: Sequence[Case], cranks: Sequence[CrankState] | None = None) -> list[Analysis]:
    """Displacement, velocity, acceleration and inverse dynamics of every case, batched together."""
    return list(iter_analyses(cases, cranks))


def analyze(case: Case, crank: CrankState | None = None) -> Analysis:
    """:func:`analyze_many` for one case (optionally at given crank states)."""
    return analyze_many([case], None if crank is None else [crank])[0]


def to_table(an: Analysis) -> ResultTable:
    """The common result table of an :class:`Analysis`, settled by :func:`~dualmech.core.status.settle`.

    Every column a row's status word does not give is NaN; a row claiming a
    non-finite value becomes ``not_finite`` (e.g. ``crank_rpm = 1e308``).
    """
    r = an.reactions
    cols = {
        "theta1_deg": np.degrees(an.crank.theta), "S1": an.crank.s, "S4": an.s4,
        "S4_dot": an.rates.q_dot[:, 0], "S4_ddot": an.rates.q_ddot[:, 0],
        "transmission": an.transmission, "residual": an.closure_residual,
        "closure_condition": an.closure_condition, **r.columns(),
    }
    cols = {c: np.array(cols[c], dtype=float) for c in NUMERIC_COLUMNS}
    status = settle(cols, an.status, REACTION_COLUMNS)
    meta = {"iterations": an.iterations, "dynamics_residual": r.residual,
            "messages": status_messages(cols["theta1_deg"], status == Status.NO_ASSEMBLY)}
    return ResultTable("dualmech", an.case.name, cols, status, meta)


def solve_case(case: Case) -> ResultTable:
    """In-house engine: every position of ``case`` by the compiled kernel, as the common result table.

    :func:`~dualmech.models.slider_crank.kernel.solve_case` runs the same algorithm as
    :func:`analyze` (which stays: it returns the body motions and rates that forward dynamics,
    balancing and the findings use, and it is the kernel's test oracle).
    """
    from dualmech.models.slider_crank.kernel import solve_case as solve_compiled  # numba loads on first use

    return solve_compiled(case)


def assembly_failure(case: Case) -> str | None:
    """Why ``case`` assembles at none of its crank angles, in one line with the reach's numbers, or ``None``
    where it assembles at one at least.

    The reach test of every engine (:func:`dualmech.core.assembly.reach`, ``docs/conventions.md``, "Edges of
    assembly"): the loop closes where the crank pin ``P2`` is within ``a2 (1 + ASSEMBLY_REACH)`` of the slider
    line.  The line names the crank pin's least distance from the line and where, and, when that is the
    reason, that the offset alone puts the line out of reach (``|a4| - a1 > a2``: the distance is at least
    ``|a4| - a1`` at every crank angle).
    """
    g, crank = case.geometry, case.own_crank_states()
    rho = reach(crank_pin(g.crank_length, crank.theta, crank.s), g.foot, g.k4, g.rod_length)
    if (rho <= 1.0 + ASSEMBLY_REACH.value).any():
        return None
    i = int(np.argmin(rho))
    unit = column_unit("S4", case.units)
    at = f" {unit}" if unit else ""
    line = (f"{case.name}: the design assembles at no crank angle: the crank pin comes no nearer the slider "
            f"line than {rho[i] * g.rod_length:.6g}{at} (theta1 = {np.degrees(crank.theta[i]):g} deg), "
            f"beyond the rod's reach a2 = {g.rod_length:g}{at}")
    a1, a4 = g.crank_length, abs(g.slider_offset)
    if a4 - a1 > g.rod_length:
        line += (f" (the offset |a4| = {a4:g}{at} exceeds the rod plus crank reach "
                 f"a1 + a2 = {a1 + g.rod_length:g}{at})")
    return line
