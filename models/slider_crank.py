"""The generalized slider crank as one instance of the link-joint table, and the in-house engine.

::

    row  joint              theta     S      eta   alpha    a      (thesis Table 1)
    1    cylindrical (1)    theta1*   S1*    0     0        a1
    2    ball (2)           -- free rotation --    0        a2
    3    ball (3)           -- free rotation --    pi/2     0
    4    prismatic (4)      0         S4?    0     alpha4   a4

    * prescribed input   ? unknown

The thesis gives the balls Z-Y angles (theta2, eta2, theta3, eta3); those
five unknowns cannot close a spatial loop (errata E2), so each ball here is a
free rotation and the rod's spin is fixed by the zero-spin gauge
(``docs/conventions.md``).

:func:`analyze_many` runs displacement, velocity, acceleration and inverse
dynamics for all positions of many cases at once (the geometry is a
per-position parameter of the loop, so cases share one batch);
:func:`solve_case` turns the result into the common
:class:`~dualmech.core.table.ResultTable`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Iterator, Sequence

import numpy as np

from dualmech.core.assembly import closure_condition, edge_status, foot_s4, reach
from dualmech.core.closure import ClosureStatus, solve_closure
from dualmech.core.dual import origin
from dualmech.core.inertia import MassArrays
from dualmech.core.loop import Loop, LoopState, Row, closure_residual, evaluate, inp, par, unk
from dualmech.core.motion import CrankState
from dualmech.core.rates import Rates, solve_rates
from dualmech.core.reactions import BodyMotion, Reactions, body_motion, solve_reactions
from dualmech.core.status import Status, is_status, settle
from dualmech.core.table import NUMERIC_COLUMNS, REACTION_COLUMNS, ResultTable
from dualmech.core.thresholds import ASSEMBLY_LIMIT_CONDITION, ASSEMBLY_REACH, DEAD_CENTRE_TRANSMISSION
from dualmech.models.case import Case

#: |transmission| below which the in-house engine flags a torque-mode position a dead centre (its numpy
#: path and the compiled kernel read this name; the number and its reason: core/thresholds.py).
DEAD_CENTRE = DEAD_CENTRE_TRANSMISSION.value
#: Geometry steps of the continuation fallback (from the planar mechanism to the case).
CONTINUATION_STEPS = 8
#: Positions analysed together at most: bounds memory (about 9 kB of work arrays per position) and keeps
#: the work arrays near the CPU caches (10k: 67k positions/s, 50k: 62k, 2k: 59k on the CI machine).
CHUNK_POSITIONS = 10_000

LOOP = Loop(
    rows=(
        Row("joint1", theta=inp("theta1"), s=inp("S1"), a=par("a1")),
        Row("joint2", spherical=True, a=par("a2")),
        Row("joint3", spherical=True, alpha=math.pi / 2),
        Row("joint4", s=unk("S4"), alpha=par("alpha4"), a=par("a4")),
    ),
    spin_gauges=(1,),
    length_scale="a2",
)


@dataclass(frozen=True)
class Batch:
    """Positions of one or more cases, concatenated: crank state and geometry per position (``(n,)``)."""

    crank: CrankState
    a1: np.ndarray
    a2: np.ndarray
    a4: np.ndarray
    alpha4: np.ndarray  # radians

    @staticmethod
    def of(cases: Sequence[Case], cranks: Sequence[CrankState]) -> "Batch":
        counts = [len(c) for c in cranks]
        crank = CrankState(*(np.concatenate([getattr(c, f.name) for c in cranks]) for f in fields(CrankState)))
        geo = [(c.geometry.crank_length, c.geometry.rod_length, c.geometry.slider_offset, c.geometry.slider_twist)
               for c in cases]
        return Batch(crank, *(np.repeat(col, counts) for col in zip(*geo)))

    def __len__(self) -> int:
        return len(self.crank)

    def take(self, index: np.ndarray) -> "Batch":
        return Batch(self.crank.take(index), self.a1[index], self.a2[index], self.a4[index], self.alpha4[index])

    def inputs(self) -> dict[str, np.ndarray]:
        """Inputs and parameters of :data:`LOOP`."""
        return {"theta1": self.crank.theta, "S1": self.crank.s, "a1": self.a1, "a2": self.a2,
                "a4": self.a4, "alpha4": self.alpha4}

    def slider_axis(self) -> tuple[np.ndarray, np.ndarray]:
        """``F`` and ``k4`` per position, ``(n, 3)`` each."""
        zero = np.zeros_like(self.a4)
        return (np.stack([-self.a4, zero, zero], 1),
                np.stack([zero, np.sin(self.alpha4), np.cos(self.alpha4)], 1))

    def crank_pin(self) -> np.ndarray:
        """``P2`` ``(n, 3)`` from the prescribed crank state."""
        th = self.crank.theta
        return np.stack([self.a1 * np.cos(th), self.a1 * np.sin(th), self.crank.s], 1)

    def foot_s4(self) -> np.ndarray:
        """``S4`` of the limit pose (:func:`~dualmech.core.assembly.foot_s4`), ``(n,)``."""
        return foot_s4(self.crank_pin(), *self.slider_axis())

    def reach(self) -> np.ndarray:
        """Distance from ``P2`` to the slider line over ``a2`` (:func:`~dualmech.core.assembly.reach`), ``(n,)``."""
        return reach(self.crank_pin(), *self.slider_axis(), self.a2)


def _rod_frame(u: np.ndarray) -> np.ndarray:
    """A rotation with x axis ``u`` ``(n, 3)``: y horizontal (``z x u``) unless ``u`` is vertical."""
    ref = np.where(np.abs(u[:, 2:3]) > 0.9, np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0]))
    v = np.cross(ref, u)
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    return np.stack([u, v, np.cross(u, v)], axis=2)


def _rot(axis: int, angle: np.ndarray) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    out = np.zeros(angle.shape + (3, 3))
    out[:, axis, axis] = 1.0
    out[:, i, i], out[:, j, j], out[:, i, j], out[:, j, i] = c, c, -s, s
    return out


def state_from_slider(batch: Batch, s4: np.ndarray) -> LoopState:
    """Loop unknowns that point the rod from the crank pin toward the slider at ``s4``.

    The rotation part of the loop closes exactly; the rod length generally does
    not (unless ``s4`` is the solution).  Used for initial estimates.
    """
    f, k4 = batch.slider_axis()
    p2 = batch.crank_pin()
    p3 = f - s4[:, None] * k4
    rz = _rot(2, batch.crank.theta)
    r_rod = _rod_frame((p3 - p2) / np.linalg.norm(p3 - p2, axis=1, keepdims=True))
    ball2 = np.swapaxes(rz, 1, 2) @ r_rod
    ball3 = np.swapaxes(r_rod, 1, 2) @ _rot(0, -batch.alpha4 - math.pi / 2)
    return LoopState(s4[:, None].copy(), np.stack([ball2, ball3], axis=1))


def planar_estimate(batch: Batch) -> np.ndarray:
    """Plane-geometry estimate of ``S4`` (thesis section 2.6.2, extended to every crank angle).

    The mechanism is treated as the planar offset slider crank (``S1 = 0``, twist
    270° or 90°, whichever is nearer); where even that cannot assemble the rod is
    laid at right angles to the slider line.
    """
    side = np.where(np.sin(batch.alpha4) < 0, 1.0, -1.0)
    th = batch.crank.theta
    reach = batch.a2**2 - (batch.a1 * np.cos(th) + batch.a4) ** 2
    return side * batch.a1 * np.sin(th) + np.sqrt(np.maximum(reach, 0.0))


def along_slider_estimate(batch: Batch) -> np.ndarray:
    """Branch-seeking estimate of ``S4``: the rod laid along the slider line, on the branch's side.

    The slider pin is put one rod length from the foot of the perpendicular from
    ``P2`` onto the slider line, toward ``-k4`` -- exact when ``P2`` lies on the line,
    and always on the assembly branch of the conventions.  The second estimate
    tried where the plane-geometry one fails or lands on the other branch.
    """
    f, k4 = batch.slider_axis()
    return batch.a2 - np.einsum("ni,ni->n", batch.crank_pin() - f, k4)


def on_branch(batch: Batch, s4: np.ndarray) -> np.ndarray:
    """``(P3 - P2)·k4 < 0``: the assembly branch of the conventions."""
    f, k4 = batch.slider_axis()
    return np.einsum("ni,ni->n", f - s4[:, None] * k4 - batch.crank_pin(), k4) < 0


def _blend(batch: Batch, lam: float) -> Batch:
    """Geometry ``lam`` of the way from the planar reference (S1 = 0, twist 270° or 90°) to ``batch``."""
    ref = np.where(np.sin(batch.alpha4) < 0, 1.5 * math.pi, 0.5 * math.pi)
    diff = (batch.alpha4 - ref + math.pi) % (2 * math.pi) - math.pi
    c = batch.crank
    crank = CrankState(c.theta, lam * c.s, c.theta_dot, c.s_dot, c.theta_ddot, c.s_ddot)
    return Batch(crank, batch.a1, batch.a2, batch.a4, ref + lam * diff)


def continuation(batch: Batch) -> tuple[LoopState, np.ndarray]:
    """Close the loop by continuation in the geometry, from the planar mechanism to ``batch``.

    Returns the state and whether each position stayed closed and on the branch
    at every step (a position that fails a step is not carried further).
    """
    start = _blend(batch, 0.0)
    state = state_from_slider(start, planar_estimate(start))
    ok = np.ones(len(batch), dtype=bool)
    for lam in np.linspace(0.0, 1.0, CONTINUATION_STEPS + 1):
        idx = np.flatnonzero(ok)
        if idx.size == 0:
            break
        b = _blend(batch.take(idx), float(lam))
        res = solve_closure(LOOP, b.inputs(), state.take(idx))
        ok[idx] = (res.status == ClosureStatus.OK) & on_branch(b, res.state.scalars[:, 0])
        state = state.put(idx, res.state)
    return state, ok


def close_loop(batch: Batch) -> tuple[LoopState, np.ndarray, np.ndarray, np.ndarray]:
    """Displacement analysis of every position: state, status words, iterations, residual.

    A position whose crank pin is farther from the slider line than ``a2 (1 +
    ASSEMBLY_REACH)`` is ``no_assembly`` (proven by geometry; its residual is that
    least gap over ``a2``, its state the rod laid toward the foot of the
    perpendicular); the others are closed by :func:`_close_reachable`.
    """
    rho = batch.reach()
    state = state_from_slider(batch, batch.foot_s4())
    status = np.full(len(batch), Status.NO_ASSEMBLY.value, dtype=object)
    iters = np.zeros(len(batch), dtype=int)
    residual = np.maximum(rho - 1.0, 0.0)
    idx = np.flatnonzero(rho <= 1.0 + ASSEMBLY_REACH.value)
    if idx.size:
        sub_state, status[idx], iters[idx], residual[idx] = _close_reachable(batch.take(idx))
        state = state.put(idx, sub_state)
    return state, status, iters, residual


def _close_reachable(batch: Batch) -> tuple[LoopState, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`close_loop` at positions within reach.

    Newton (with its DFP fallback) from the plane-geometry estimate; positions that
    did not converge or landed on the other branch are retried from
    :func:`along_slider_estimate`, then by :func:`continuation`.  Positions where DFP found a non-zero stationary
    closure error are ``no_assembly`` (the rod cannot reach the slider line).
    """
    res = solve_closure(LOOP, batch.inputs(), state_from_slider(batch, planar_estimate(batch)))
    state, iters, residual, codes = res.state, res.iterations.copy(), res.residual.copy(), res.status.copy()
    wrong = (codes == ClosureStatus.OK) & ~on_branch(batch, state.scalars[:, 0])
    retry = np.flatnonzero((codes == ClosureStatus.NOT_CONVERGED) | wrong)
    if retry.size:  # second estimate: the rod laid along the slider line
        sub_batch = batch.take(retry)
        again = solve_closure(LOOP, sub_batch.inputs(), state_from_slider(sub_batch, along_slider_estimate(sub_batch)))
        fixed = (again.status != ClosureStatus.NOT_CONVERGED) & ~(
            (again.status == ClosureStatus.OK) & ~on_branch(sub_batch, again.state.scalars[:, 0]))
        sel = np.flatnonzero(fixed)
        state = state.put(retry[sel], again.state.take(sel))
        codes[retry[sel]], residual[retry[sel]] = again.status[sel], again.residual[sel]
        iters[retry] += again.iterations
        wrong[retry[sel]] = False
    status = np.full(len(batch), Status.OK.value, dtype=object)
    status[codes == ClosureStatus.NO_ASSEMBLY] = Status.NO_ASSEMBLY.value
    retry = np.flatnonzero((codes == ClosureStatus.NOT_CONVERGED) | wrong)
    if retry.size:
        sub_batch = batch.take(retry)
        sub, sub_ok = continuation(sub_batch)
        fixed = np.flatnonzero(sub_ok)
        state = state.put(retry[fixed], sub.take(fixed))
        residual[retry] = closure_residual(evaluate(LOOP, sub_batch.inputs(), state.take(retry)), LOOP)
        failed = retry[~sub_ok]
        status[failed] = np.where(codes[failed] == ClosureStatus.OK, Status.BRANCH_JUMP.value,
                                  Status.NOT_CONVERGED.value)
    return state, status, iters, residual


@dataclass(frozen=True)
class Analysis:
    """Everything the in-house solver computes for one case (arrays over its ``n`` positions).

    ``status`` is an object array of status words (``docs/conventions.md``);
    ``iterations`` and ``closure_residual`` per position; ``closure_condition`` the
    ``|u·k4|`` of ``docs/conventions.md`` (geometric where the loop did not close); ``motions`` the crank,
    rod and slider :class:`BodyMotion`; ``rates`` the loop :class:`Rates`;
    ``reactions`` the :class:`Reactions` (not masked: see :func:`to_table`).
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


def _take(obj, index: slice):
    """Slice every array field of a dataclass (recursively through lists and tuples) along axis 0."""
    if isinstance(obj, np.ndarray):
        return obj[index]
    if isinstance(obj, (list, tuple)):
        return type(obj)(_take(o, index) for o in obj)
    if hasattr(obj, "__dataclass_fields__"):
        return type(obj)(**{f.name: _take(getattr(obj, f.name), index) for f in fields(obj)})
    return obj


def _analyze_batch(cases: Sequence[Case], cranks: Sequence[CrankState]) -> list[Analysis]:
    batch = Batch.of(cases, cranks)
    counts = [len(c) for c in cranks]
    state, status, iters, residual = close_loop(batch)
    chain = evaluate(LOOP, batch.inputs(), state)
    c = batch.crank
    rates = solve_rates(chain, LOOP, {"theta1": c.theta_dot, "S1": c.s_dot}, {"theta1": c.theta_ddot, "S1": c.s_ddot})
    p2, p3 = origin(chain.frames[0]), origin(chain.frames[1])
    u = (p3 - p2) / batch.a2[:, None]
    hub = np.stack([np.zeros_like(c.s), np.zeros_like(c.s), c.s], 1)
    transmission = np.cross(p2 - hub, u)[:, 2] / batch.a1
    frames = ((chain.frames[0].re, hub), (chain.frames[1].re, p2),
              (np.broadcast_to(np.eye(3), chain.frames[0].re.shape), p3))
    bodies = tuple(MassArrays.repeat([getattr(k.bodies, name) for k in cases], counts)
                   for name in ("crank", "rod", "slider"))
    motions = tuple(body_motion(b, r, o, rates.link_twist[i], rates.link_accel[i])
                    for i, (b, (r, o)) in enumerate(zip(bodies, frames)))
    _, k4 = batch.slider_axis()
    closed = is_status(status, Status.OK)
    status, condition = edge_status(status, closed, batch.reach(), closure_condition(p2, p3, k4),
                                    ASSEMBLY_REACH.value, ASSEMBLY_LIMIT_CONDITION.value)
    s4 = np.where(is_status(status, Status.ASSEMBLY_LIMIT) & ~closed, batch.foot_s4(), state.scalars[:, 0])
    given = np.array([[np.nan if k.loads.drive_torque is None else k.loads.drive_torque,
                       np.nan if k.loads.slider_force is None else k.loads.slider_force] for k in cases])
    gravity = np.repeat([k.loads.gravity for k in cases], counts, axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        reactions = solve_reactions(bodies, motions, p2, p3, k4, gravity,
                                    np.repeat(given[:, 0], counts), np.repeat(given[:, 1], counts))
    torque_mode = np.repeat(np.isfinite(given[:, 0]), counts)
    status[is_status(status, Status.OK) & torque_mode & (np.abs(transmission) < DEAD_CENTRE)] = Status.DEAD_CENTRE.value
    out, start = [], 0
    for case, crank, n in zip(cases, cranks, counts):
        sl = slice(start, start + n)
        start += n
        out.append(Analysis(case, crank, s4[sl], status[sl], iters[sl], residual[sl], p2[sl], p3[sl],
                            transmission[sl], condition[sl], _take(rates, sl), _take(motions, sl),
                            _take(reactions, sl)))
    return out


def iter_analyses(cases: Sequence[Case], cranks: Sequence[CrankState] | None = None,
                  chunk_positions: int = CHUNK_POSITIONS) -> Iterator[Analysis]:
    """Analyse many cases, batching up to ``chunk_positions`` positions at a time; yields one per case.

    Crank states are built chunk by chunk, so memory stays bounded by the chunk
    size (plus the case list) however many positions there are in all.
    """
    def crank(i: int) -> CrankState:
        c = cases[i]
        return c.motion.state(c.geometry.crank_axial_shift) if cranks is None else cranks[i]

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


def slider_axis(case: Case) -> tuple[np.ndarray, np.ndarray]:
    """``F`` and ``k4`` of a case, ``(3,)`` each."""
    a = case.geometry.slider_twist
    return np.array([-case.geometry.slider_offset, 0.0, 0.0]), np.array([0.0, math.sin(a), math.cos(a)])


def no_assembly_ranges(theta_deg: np.ndarray, mask: np.ndarray) -> list[tuple[float, float]]:
    """Contiguous runs of ``mask`` as (first, last) crank angles in degrees."""
    edges = np.diff(np.concatenate([[0], mask.astype(int), [0]]))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
    return [(float(theta_deg[a]), float(theta_deg[b])) for a, b in zip(starts, ends)]


def to_table(an: Analysis) -> ResultTable:
    """The common result table of an :class:`Analysis`, settled by :func:`~dualmech.core.status.settle`.

    Every column a row's status word does not give is NaN; a row claiming a
    non-finite value becomes ``not_finite`` (e.g. ``crank_rpm = 1e308``).
    """
    r = an.reactions
    cols = {
        "theta1_deg": np.degrees(an.crank.theta), "S1": an.crank.s, "S4": an.s4,
        "S4_dot": an.rates.q_dot[:, 0], "S4_ddot": an.rates.q_ddot[:, 0],
        "slider_load": r.slider_load, "drive_torque": r.drive_torque,
        "transmission": an.transmission, "residual": an.closure_residual,
        "closure_condition": an.closure_condition,
    }
    for name, arr in (("j1_f", r.j1_force), ("j1_m", r.j1_moment), ("j2_f", r.j2), ("j3_f", r.j3),
                      ("j4_f", r.j4_force), ("j4_m", r.j4_moment)):
        for k, axis in enumerate("xyz"):
            cols[f"{name}{axis}"] = arr[:, k]
    cols = {c: np.array(cols[c], dtype=float) for c in NUMERIC_COLUMNS}
    status = settle(cols, an.status, REACTION_COLUMNS)
    meta = {"iterations": an.iterations, "dynamics_residual": r.residual,
            "messages": status_messages(cols["theta1_deg"], status)}
    return ResultTable("dualmech", an.case.name, cols, status, meta)


def status_messages(theta_deg: np.ndarray, status: np.ndarray) -> list[str]:
    """The in-house engine's messages about a case's rows: where it cannot assemble, ``(n,)`` arrays in."""
    return no_assembly_message(no_assembly_ranges(theta_deg, status == Status.NO_ASSEMBLY))


def no_assembly_message(ranges: list[tuple[float, float]]) -> list[str]:
    """The message naming the crank-angle ranges (degrees) where the rod cannot reach the slider line."""
    if not ranges:
        return []
    text = ", ".join(f"{a:g}..{b:g}" for a, b in ranges)
    return [f"no_assembly: the rod cannot reach the slider line at crank angles {text} deg"]


def solve_case(case: Case) -> ResultTable:
    """In-house engine: every position of ``case`` by the compiled kernel, as the common result table.

    :func:`~dualmech.models.slider_crank_kernel.solve_case` runs the same algorithm as
    :func:`analyze` (which stays: it returns the body motions and rates that forward dynamics,
    balancing and the findings use, and it is the kernel's test oracle).
    """
    from dualmech.models.slider_crank_kernel import solve_case as solve_compiled  # numba loads on first use

    return solve_compiled(case)
