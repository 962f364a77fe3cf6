"""Start estimates for any table without a closed form: continuation along the input sequence.

The closure (thesis eq. 5, solved by :func:`~dualmech.core.closure.solve_closure`: Newton on the dual loop
equation, eq. 11 and 23a, with the DFP fallback) needs a start near the wanted assembly.  Where no closed form
gives one, the pose at the first position is closed from a given estimate (or searched: many random starts,
batched), then a few *stations* along the positions are closed one after the other, each from the last; the
other positions are closed in one batch from guesses interpolated between the two stations around them.
Where Newton cannot reach a station from the last one (a sharp turn of the pose along the input), the
positions between are closed one after the other instead; where the batch misses the branch at a position,
it is closed again from its closed neighbour on the start's side, away from the start, until a position does
not close on the branch (the loop's true gaps and edges cost one solve).  Past a gap, continuity with the
start is lost: the positions there are closed from the pose before the gap, on the start's branch sign,
which a loop with more than two assemblies (a general 7R has up to sixteen) does not make unique.

**Branch.** A one-degree-of-freedom loop's closure Jacobian with its spin-gauge rows is square
(:func:`closure_jacobian`); its determinant changes sign only through a singular pose (an edge of
assembly), so its sign labels the assembly branch.  A position closed with the other sign than the start
pose's is a *branch jump*: reported, never followed (a station past it is not used as a start).

**Joint locks.** The determinant also changes sign where the loop passes smoothly through a singular pose
that the drive still moves: a *joint lock* (a universal joint whose axis lines up with a ball's, the rod of a
slider crank along its slider line), where the solution curve crosses another and a passive joint's rate is
not determined, but the curve followed goes on with bounded rates.  :func:`cross_lock` tells the two apart
between two neighbouring positions: it walks the drive from one to the other in ``LOCK_SUBSTEPS``
steps (``core/thresholds.py``), each closed from the secant through the two before it, and accepts the walk
only where every closure's correction is at most ``LOCK_CORRECTION`` of the step before it (a smooth curve:
the secant's error is second order in the step).  At an edge of assembly the branch ends, and the walk fails
to close or lands on another assembly with a correction of the order of the pose itself.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dualmech.core.closure import (
    ClosureResult,
    ClosureStatus,
    closure_system,
    gauge_block,
    refine,
    solve_closure,
)
from dualmech.core.dual import vee
from dualmech.core.loop import (
    Loop,
    LoopState,
    Var,
    closure_residual,
    evaluate,
    rodrigues,
    screw_jacobian,
)
from dualmech.core.thresholds import LOCK_CORRECTION, LOCK_SUBSTEPS

#: Stations closed one after the other (at most; fewer positions: every position is a station).
STATIONS = 24
#: Random starts of :func:`search_assembly`.
SEARCH_STARTS = 64


@dataclass(frozen=True)
class Continuation:
    """A loop closed at ``n`` positions by continuation.

    Attributes
    ----------
    state : LoopState
    status : numpy.ndarray of ClosureStatus codes, shape (n,)
    branch_jump : numpy.ndarray of bool, shape (n,)
        Closed, but on another branch than the start pose (the Jacobian's determinant changed sign).
    residual : numpy.ndarray, shape (n,)
    iterations : numpy.ndarray of int, shape (n,)
    branch : int
        Sign of the start pose's Jacobian determinant (:func:`branch_sign`).
    """

    state: LoopState
    status: np.ndarray
    branch_jump: np.ndarray
    residual: np.ndarray
    iterations: np.ndarray
    branch: int


def closure_jacobian(loop: Loop, inputs: dict[str, np.ndarray], state: LoopState) -> np.ndarray:
    """The unknowns' screws with the spin-gauge rows, ``(n, 6 + g, loop.n_unknown)`` (square for a
    one-degree-of-freedom table; dual rows over the length scale)."""
    chain = evaluate(loop, inputs, state)
    jac = screw_jacobian(chain, loop)
    return np.concatenate([jac, gauge_block(chain, loop)], axis=1) if loop.spin_gauges else jac


def branch_sign(loop: Loop, inputs: dict[str, np.ndarray], state: LoopState) -> np.ndarray:
    """Sign of the closure Jacobian's determinant, ``(n,)`` of -1, 0, 1 (module docstring)."""
    return np.sign(np.linalg.det(closure_jacobian(loop, inputs, state))).astype(int)


def _log(rotation: np.ndarray) -> np.ndarray:
    """Rotation vectors ``(..., 3)`` of rotations ``(..., 3, 3)`` by less than pi."""
    cos = np.clip((np.trace(rotation, axis1=-2, axis2=-1) - 1.0) / 2.0, -1.0, 1.0)
    angle = np.arccos(cos)
    factor = np.where(angle < 1e-8, 0.5, angle / (2.0 * np.sin(np.maximum(angle, 1e-8))))
    return vee(rotation - np.swapaxes(rotation, -1, -2)) * factor[..., None]


def interpolate(a: LoopState, b: LoopState, t: np.ndarray) -> LoopState:
    """States between ``a`` and ``b`` (each ``n`` positions) at fractions ``t`` ``(n,)``: scalars linearly,
    rotations along the shortest turn from ``a``'s to ``b``'s."""
    scalars = a.scalars + t[:, None] * (b.scalars - a.scalars)
    turn = _log(b.rotations @ np.swapaxes(a.rotations, -1, -2))
    return LoopState(scalars, rodrigues(turn * t[:, None, None]) @ a.rotations)


def _slides(loop: Loop) -> np.ndarray:
    """Which scalar unknowns of ``loop`` are lengths (in a row's ``s`` or ``a`` slot), shape
    ``(len(loop.unknowns),)``."""
    lengths = {getattr(row, f).name for row in loop.rows for f in ("s", "a")
               if isinstance(getattr(row, f), Var)}
    return np.array([name in lengths for name in loop.unknowns], dtype=bool)


def search_assembly(loop: Loop, inputs: dict[str, np.ndarray], seed: int = 0,
                    starts: int = SEARCH_STARTS, size: float = 1.0) -> LoopState:
    """Closed poses at one position (``inputs`` of length 1) from ``starts`` random estimates, batched:
    angles uniform in (-pi, pi], slides in (-size, size), rotations uniform.  Returns the distinct closed
    poses found (possibly none), ``(k,)`` positions."""
    rng = np.random.default_rng(seed)
    k = len(loop.unknowns)
    scalars = rng.uniform(-np.pi, np.pi, (starts, k))
    scalars[:, _slides(loop)] *= size / np.pi
    quats = rng.normal(size=(starts, len(loop.spherical_rows), 4))
    quats /= np.linalg.norm(quats, axis=-1, keepdims=True)
    vectors = 2.0 * np.arctan2(np.linalg.norm(quats[..., 1:], axis=-1), quats[..., 0])[..., None] * \
        quats[..., 1:] / np.maximum(np.linalg.norm(quats[..., 1:], axis=-1, keepdims=True), 1e-300)
    guess = LoopState(scalars, rodrigues(vectors))
    many = {name: np.repeat(v, starts) for name, v in inputs.items()}
    res = solve_closure(loop, many, guess)
    return res.state.take(np.flatnonzero(res.status == ClosureStatus.OK))


def station_positions(n: int, count: int = STATIONS) -> np.ndarray:
    """The positions (0-based, sorted) of at most ``count`` stations spread evenly over ``n`` positions."""
    return np.unique(np.linspace(0, n - 1, min(n, count)).round().astype(int))


def start_not_closed(at: int, residual: float) -> ValueError:
    """The error of a start pose that does not close at its position ``at`` (0-based)."""
    return ValueError(f"start: the loop does not close at position {at + 1} from the start pose "
                      f"(residual {residual:.3g}); give an assembled pose")


def continue_closure(loop: Loop, inputs: dict[str, np.ndarray], start: LoopState, at: int = 0,
                     stations: int = STATIONS) -> Continuation:
    """Close ``loop`` at every position of ``inputs`` (``(n,)`` each, in the order the input moves) from
    ``start``, an estimate at position ``at`` (module docstring): the stations after ``at`` are closed in
    turn forward from it, those before it backward.

    Raises
    ------
    ValueError
        If position ``at`` does not close from ``start`` (give or search another start pose).
    """
    n = next(iter(inputs.values())).shape[0]
    here = {k: v[at:at + 1] for k, v in inputs.items()}
    first = solve_closure(loop, here, start)
    if first.status[0] != ClosureStatus.OK:
        raise start_not_closed(at, first.residual[0])
    branch = int(branch_sign(loop, here, first.state)[0])
    idx = station_positions(n, stations)
    state = LoopState(np.repeat(first.state.scalars, n, axis=0), np.repeat(first.state.rotations, n, axis=0))
    good = np.zeros(n, dtype=bool)
    good[at] = True
    for way in (idx[idx > at], idx[idx < at][::-1]):
        last, p = first.state, at
        for i in way:  # sequential: each station from the last good one (a fixed, small number)
            closed = _close_one(loop, inputs, i, last, branch)
            if closed is not None:
                state, good[i], last, p = state.put(np.array([i]), closed.state), True, closed.state, i
            else:  # too far for Newton from the last good pose: walk the positions up to the station
                step = np.sign(i - p)
                state, p, last = _walk(loop, inputs, range(p + step, i + step, step), last, branch, state,
                                       good, p)
    # every position from the stations around it, in one batch
    ok_idx = np.flatnonzero(good)
    right = np.clip(np.searchsorted(ok_idx, np.arange(n)), 0, ok_idx.size - 1)
    left = np.clip(right - 1, 0, ok_idx.size - 1)  # before the first good station: both ends are that one
    lo, hi = ok_idx[left], ok_idx[right]
    t = np.where(hi > lo, (np.arange(n) - lo) / np.maximum(hi - lo, 1), 0.0)
    t = np.clip(t, 0.0, 1.0)
    guess = interpolate(state.take(lo), state.take(hi), t)
    res = solve_closure(loop, inputs, guess)
    closed = res.status == ClosureStatus.OK
    rows = np.flatnonzero(closed)
    polished, more, residual = refine(loop, {k: v[rows] for k, v in inputs.items()}, res.state.take(rows))
    final = res.state.put(rows, polished)
    res_all = res.residual.copy()
    res_all[rows] = residual
    iters = res.iterations.copy()
    iters[rows] += more
    jump = closed & (branch_sign(loop, inputs, final) != branch)
    status = res.status.copy()
    final = _repair(loop, inputs, final, status, jump, res_all, iters, branch, at)
    return Continuation(final, status, jump, res_all, iters, branch)


def _close_one(loop: Loop, inputs: dict[str, np.ndarray], i: int, guess: LoopState,
               branch: int) -> ClosureResult | None:
    """Position ``i`` closed from ``guess`` on the start's ``branch`` (one position), else ``None``."""
    here = {k: v[i:i + 1] for k, v in inputs.items()}
    res = solve_closure(loop, here, guess)
    if res.status[0] == ClosureStatus.OK and branch_sign(loop, here, res.state)[0] == branch:
        return res
    return None


def _walk(loop, inputs, positions, last: LoopState, branch: int, state: LoopState, good: np.ndarray,
          p: int) -> tuple[LoopState, int, LoopState]:
    """Close ``positions`` one after the other, each from the one before, until one does not close on the
    branch (an edge of assembly, or a turn too sharp even for one step).  Returns the updated ``state``, the
    last position closed (``p`` if none) and its pose; ``good`` is marked in place."""
    for j in positions:
        closed = _close_one(loop, inputs, j, last, branch)
        if closed is None:
            break
        state, last, p = state.put(np.array([j]), closed.state), closed.state, j
        good[j] = True
    return state, p, last


def _repair(loop, inputs, state: LoopState, status: np.ndarray, jump: np.ndarray, residual: np.ndarray,
            iterations: np.ndarray, branch: int, at: int) -> LoopState:
    """Positions the batch did not close on the branch (interpolated guesses between stations too far
    apart), closed again one after the other from the closed neighbour on the start's side (position
    ``at``), away from the start as the stations were, until one does not close on the branch: where the
    loop truly has no assembly, or passes an edge, it costs one solve.  Returns ``state``; ``status``,
    ``jump``, ``residual`` and ``iterations`` are updated in place."""
    good = (status == ClosureStatus.OK) & ~jump
    if good.all() or not good.any():
        return state
    n = good.size
    for step in (1, -1):
        for i in np.flatnonzero(good & ((np.arange(n) - at) * step >= 0)):
            j, last = i + step, state.take(slice(i, i + 1))
            while 0 <= j < n and not good[j]:
                res = _close_one(loop, inputs, j, last, branch)
                if res is None:
                    break
                polished, more, res_j = refine(loop, {k: v[j:j + 1] for k, v in inputs.items()}, res.state)
                state, last = state.put(np.array([j]), polished), polished
                status[j], jump[j], residual[j], good[j] = ClosureStatus.OK, False, res_j[0], True
                iterations[j] = res.iterations[0] + more[0]
                j += step
    return state


def pose_distance(loop: Loop, inputs: dict[str, np.ndarray], a: LoopState, b: LoopState) -> np.ndarray:
    """Distance ``(n,)`` between poses ``a`` and ``b``: the largest change of a scalar unknown (an angle in
    rad, a slide over the loop's length scale) or turn of a spherical joint (rad)."""
    scale = np.asarray(inputs[loop.length_scale]) if loop.length_scale else np.ones(a.scalars.shape[0])
    change = np.abs(b.scalars - a.scalars)
    change[:, _slides(loop)] /= scale[:, None]
    turns = np.linalg.norm(_log(b.rotations @ np.swapaxes(a.rotations, -1, -2)), axis=-1)
    return np.maximum(change.max(axis=1, initial=0.0), turns.max(axis=1, initial=0.0))


def cross_lock(loop: Loop, inputs: dict[str, np.ndarray], i: int, j: int, pose: LoopState,
               substeps: int = LOCK_SUBSTEPS) -> LoopState | None:
    """The pose at position ``j`` reached from ``pose``, closed at position ``i``, by a smooth walk of the
    inputs (module docstring, "Joint locks"): ``substeps`` steps along the straight line between the two
    positions' inputs, each closed from the secant through the two poses before it (the first from
    ``pose``); ``None`` where a step does not close, or its correction exceeds ``LOCK_CORRECTION`` of the
    step before it (a first step that lands on another assembly fails the second's: its secant overshoots
    by the jump)."""
    before, here = None, pose
    for k in range(1, substeps + 1):
        t = k / substeps
        at = {name: (1.0 - t) * v[i:i + 1] + t * v[j:j + 1] for name, v in inputs.items()}
        guess = here if before is None else interpolate(before, here, np.array([2.0]))
        res = solve_closure(loop, at, guess)
        if res.status[0] != ClosureStatus.OK:
            return None
        if before is not None:
            step = pose_distance(loop, at, before, here)[0]
            if pose_distance(loop, at, guess, res.state)[0] > LOCK_CORRECTION.value * step + 1e-12:
                return None
        before, here = here, res.state
    return here


#: Pseudo-inverse cut-off of :func:`close_min_norm`: singular values below this fraction of the largest are
#: the lock's own directions, which its steps leave alone.
MIN_NORM_RCOND = 1e-8
#: Gauss-Newton steps of :func:`close_min_norm`.
MIN_NORM_STEPS = 12


def close_min_norm(loop: Loop, inputs: dict[str, np.ndarray],
                   guess: LoopState) -> tuple[LoopState, np.ndarray]:
    """The poses nearest ``guess`` that close (``n`` positions): Gauss-Newton with minimum-norm steps (the
    pseudo-inverse of the closure Jacobian with its gauge rows, cut off at :data:`MIN_NORM_RCOND`).  At a
    lock a singular direction is a motion the loop may make without the drive; Newton's full step would
    run along it, the minimum-norm step does not.  Returns the poses and their closure residuals."""
    state = guess
    for _ in range(MIN_NORM_STEPS):
        jac, err = closure_system(evaluate(loop, inputs, state), loop)
        step = -np.einsum("nkm,nm->nk", np.linalg.pinv(jac, rcond=MIN_NORM_RCOND), err)
        state = state.retract(step, loop)
    return state, closure_residual(evaluate(loop, inputs, state), loop)
