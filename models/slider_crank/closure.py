"""Loop closure of the generalized slider crank: start estimates, the branch, retries and continuation.

:func:`close_loop` is the displacement analysis of a :class:`~dualmech.models.slider_crank.loop.Batch`:
positions whose crank pin is beyond the rod's reach are ``no_assembly`` by geometry; the others
are closed by Newton with its DFP fallback (:func:`~dualmech.core.closure.solve_closure`) from the
plane-geometry estimate, retried from the rod laid along the slider line, then by continuation
in the geometry from the planar mechanism.  A solution off the conventions' assembly branch
(:func:`~dualmech.core.assembly.on_branch`) is refused.
"""

from __future__ import annotations

import math

import numpy as np

from dualmech.core.assembly import on_branch
from dualmech.core.closure import ClosureStatus, refine, solve_closure
from dualmech.core.loop import LoopState, closure_residual, evaluate
from dualmech.core.motion import CrankState
from dualmech.core.status import Status
from dualmech.core.thresholds import ASSEMBLY_LIMIT_CONDITION, ASSEMBLY_REACH, EDGE_REFINE_CONDITION
from dualmech.models.slider_crank.loop import CONTINUATION_STEPS, LOOP, Batch


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
    f, k4 = batch.slider_line()
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
    f, k4 = batch.slider_line()
    return batch.a2 - np.einsum("ni,ni->n", batch.crank_pin() - f, k4)


def slider_on_branch(batch: Batch, s4: np.ndarray) -> np.ndarray:
    """Whether the slider at ``s4`` ``(n,)`` puts each position on the conventions' assembly branch
    (:func:`~dualmech.core.assembly.on_branch`), ``(n,)``."""
    f, k4 = batch.slider_line()
    return on_branch(batch.crank_pin(), f - s4[:, None] * k4, k4)


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
        ok[idx] = (res.status == ClosureStatus.OK) & slider_on_branch(b, res.state.scalars[:, 0])
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
    # near an edge of assembly (geometric c = sqrt(1 - rho^2) small), not at its limit: on to rounding
    c2 = 1.0 - rho**2
    edge = np.flatnonzero((status == Status.OK.value) & (c2 >= ASSEMBLY_LIMIT_CONDITION.value**2)
                          & (c2 < EDGE_REFINE_CONDITION.value**2))
    if edge.size:
        sub_state, more, residual[edge] = refine(LOOP, batch.take(edge).inputs(), state.take(edge))
        state, iters[edge] = state.put(edge, sub_state), iters[edge] + more
    return state, status, iters, residual


def _close_reachable(batch: Batch) -> tuple[LoopState, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`close_loop` at positions within reach.

    Newton (with its DFP fallback) from the plane-geometry estimate; positions that
    did not converge or landed on the other branch are retried from
    :func:`along_slider_estimate`, then by :func:`continuation`.  Positions where DFP found a non-zero
    stationary
    closure error are ``no_assembly`` (the rod cannot reach the slider line).
    """
    res = solve_closure(LOOP, batch.inputs(), state_from_slider(batch, planar_estimate(batch)))
    state, iters, residual, codes = res.state, res.iterations.copy(), res.residual.copy(), res.status.copy()
    wrong = (codes == ClosureStatus.OK) & ~slider_on_branch(batch, state.scalars[:, 0])
    retry = np.flatnonzero((codes == ClosureStatus.NOT_CONVERGED) | wrong)
    if retry.size:  # second estimate: the rod laid along the slider line
        sub_batch = batch.take(retry)
        second = state_from_slider(sub_batch, along_slider_estimate(sub_batch))
        again = solve_closure(LOOP, sub_batch.inputs(), second)
        fixed = (again.status != ClosureStatus.NOT_CONVERGED) & ~(
            (again.status == ClosureStatus.OK) & ~slider_on_branch(sub_batch, again.state.scalars[:, 0]))
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
