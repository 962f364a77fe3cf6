"""The in-house engine on any loop table: closure, rates, every joint's reaction, statuses.

The generic pieces of ``core/`` on a :class:`~dualmech.models.loop.description.LoopMechanism`:
:func:`~dualmech.models.loop.translate.to_loop` (the table),
:func:`~dualmech.core.continuation.continue_closure`
(closure from a start pose along the drive, the branch followed by continuity),
:func:`~dualmech.core.rates.solve_rates` (velocities, accelerations) and
:func:`~dualmech.core.loop_reactions.solve_joint_wrenches` (Newton-Euler of every moving link).

Statuses (:mod:`dualmech.core.status`): ``no_assembly`` where the closure's DFP fallback stops at a non-zero
stationary error, ``not_converged`` where it stops otherwise, ``branch_jump`` where the loop closed on another
branch than the start pose's, ``dead_centre`` where the solved effort's transmission is below
:data:`~dualmech.core.thresholds.DEAD_CENTRE_TRANSMISSION` (its reactions are then NaN), else ``ok``.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace
from functools import cached_property

import numpy as np

from dualmech.core.closure import ROUNDING_TOL, ClosureStatus
from dualmech.core.continuation import (
    SEARCH_STARTS,
    branch_sign,
    close_min_norm,
    closure_jacobian,
    continue_closure,
    cross_lock,
    interpolate,
    search_assembly,
)
from dualmech.core.kernel.loop_engine import solve_loop
from dualmech.core.loop import Chain, Loop, LoopState, evaluate
from dualmech.core.loop_reactions import JointWrenches, solve_joint_wrenches
from dualmech.core.rates import Rates, solve_rates
from dualmech.core.status import Status, is_status
from dualmech.core.thresholds import DEAD_CENTRE_TRANSMISSION, LOCK_ROWS, LOCK_SUBSTEPS, REGULAR_POSE
from dualmech.models.loop.description import LoopMechanism
from dualmech.models.loop.mobility import check_mobility
from dualmech.models.loop.start import nearest_to_zero, wrapped
from dualmech.models.loop.translate import (
    SCALE,
    DriveState,
    drive_state,
    start_state,
    to_loop,
    variable,
)


@dataclass(frozen=True)
class LoopAnalysis:
    """The in-house answer at the ``n`` drive positions of a loop.

    Attributes
    ----------
    mechanism : LoopMechanism
    loop : Loop
        Its table (:func:`~dualmech.models.loop.translate.to_loop`).
    drive : DriveState
    state : LoopState
        The closed joint variables (meaningful where the status assembles).
    rates : Rates
        ``q_dot``, ``q_ddot`` in the order of ``loop.unknowns`` (then 3 per ball); link twists.
    wrenches : JointWrenches
    status : numpy.ndarray of str, shape (n,)
    residual : numpy.ndarray, shape (n,)
        Closure residual (lengths over the loop's length scale).
    iterations : numpy.ndarray of int, shape (n,)
    """

    mechanism: LoopMechanism
    loop: Loop
    drive: DriveState
    state: LoopState
    rates: Rates
    wrenches: JointWrenches
    status: np.ndarray
    residual: np.ndarray
    iterations: np.ndarray

    def coordinate(self, joint: int, name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Value, rate and acceleration ``(n,)`` each of joint ``joint``'s (0-based) coordinate ``name``
        (``theta``, ``s`` or ``eta``), prescribed or solved."""
        key = variable(joint, name)
        if key in self.drive.values:
            return self.drive.values[key], self.drive.rates[key], self.drive.accels[key]
        j = self.loop.unknowns.index(key)
        return self.state.scalars[:, j], self.rates.q_dot[:, j], self.rates.q_ddot[:, j]

    @cached_property
    def chain(self) -> Chain:
        """The table evaluated at ``state`` (:func:`~dualmech.core.loop.evaluate`), at the first use: few
        readers need it, and it costs a fifth of the compiled engine's time on a long case."""
        return evaluate(self.loop, self.drive.values, self.state)


def efforts_of(mechanism: LoopMechanism, n: int) -> tuple[dict[str, np.ndarray | None], str]:
    """Given and solved efforts by variable name (``None``: solved), and the name of the solved load that
    decides the transmission.  A C joint's prescribed slide has its axial force solved (a reaction)."""
    d = mechanism.drive
    efforts: dict[str, np.ndarray | None] = {
        variable(d.joint, d.coordinate): None if d.effort is None else np.full(n, d.effort)}
    if mechanism.joints[d.joint].type == "C":
        efforts[variable(d.joint, "s")] = None
    solved = variable(d.joint, d.coordinate) if d.effort is None else ""
    for load in mechanism.loads:
        name = variable(load.joint, load.coordinate)
        efforts[name] = None if load.value is None else np.full(n, load.value)
        if load.value is None:
            solved = name
    return efforts, solved


#: Drive positions tried, evenly spread, when searching for an assembled start pose.
SEARCH_POSITIONS = 8


def find_start(mechanism: LoopMechanism, loop: Loop, drive: DriveState,
               seed: int = 0) -> tuple[LoopState, int]:
    """A start pose and the drive position it belongs to: the joints' ``start`` values at the first position
    if any joint gives one, else, among the assemblies found
    (:func:`~dualmech.core.continuation.search_assembly`) at the first of :data:`SEARCH_POSITIONS` evenly
    spread positions where one exists, the one nearest the zero pose
    (:func:`~dualmech.models.loop.start.nearest_to_zero`)."""
    if any(j.start for j in mechanism.joints):
        return start_state(mechanism, loop), 0
    n = drive.values[variable(*mechanism.driven_coordinate)].shape[0]
    for at in np.unique(np.linspace(0, n - 1, min(n, SEARCH_POSITIONS)).round().astype(int)):
        values = drive.take(slice(at, at + 1)).values
        found = search_assembly(loop, values, seed, size=mechanism.length)
        if found.scalars.shape[0]:
            poses = [wrapped(dict(zip(loop.unknowns, row))) for row in found.scalars]
            k = nearest_to_zero(poses)
            scalars = np.array([[poses[k][name] for name in loop.unknowns]])
            return LoopState(scalars, found.rotations[k:k + 1]), int(at)
    raise ValueError(f"start: no assembled pose found at {min(n, SEARCH_POSITIONS)} drive positions "
                     f"({SEARCH_STARTS} random poses each): the loop may not assemble there (check its "
                     "lengths and the drive's range), or give the joints' start values")


def analyze_loop(mechanism: LoopMechanism, start: LoopState | None = None, at: int = 0, *,
                 compiled: bool = True, drive: DriveState | None = None) -> LoopAnalysis:
    """Closure, rates, reactions and statuses at every drive position of ``mechanism``.

    ``start`` ``(1,)`` positions: a pose at drive position ``at`` (0-based; assembled or nearly), whose
    branch is followed; default :func:`find_start`.  ``compiled``: by the compiled kernel
    (:func:`dualmech.core.kernel.loop_engine.solve_loop`, the same algorithm per position but for the start
    estimates on a fine grid), else by the numpy solver (the reference the kernel is tested against).
    ``drive``: the prescribed coordinates with their own rate and acceleration at each position, e.g. a
    simulated motion's (default :func:`~dualmech.models.loop.translate.drive_state` of the mechanism's drive:
    one speed and acceleration at every position).
    """
    check_mobility(mechanism)
    loop = to_loop(mechanism)
    drive = drive_state(mechanism) if drive is None else drive
    n = drive.values[variable(*mechanism.driven_coordinate)].shape[0]
    pose, at = find_start(mechanism, loop, drive) if start is None else (start, at)
    efforts, solved = efforts_of(mechanism, n)
    if compiled:
        closed, rates, wrenches = solve_loop(loop, drive.values, drive.rates, drive.accels, pose, at,
                                             mechanism.bodies, mechanism.gravity, efforts, solved)
    else:
        closed = continue_closure(loop, drive.values, pose, at)
        chain = evaluate(loop, drive.values, closed.state)
        rates = solve_rates(chain, loop, drive.rates, drive.accels)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            wrenches = solve_joint_wrenches(chain, loop, drive.values, rates, mechanism.bodies,
                                            mechanism.gravity, efforts, solved, drive.values[SCALE])
    status = np.full(n, Status.OK.value, dtype=object)
    status[(wrenches.transmission < DEAD_CENTRE_TRANSMISSION.value)] = Status.DEAD_CENTRE.value
    status[closed.branch_jump] = Status.BRANCH_JUMP.value
    status[closed.status == ClosureStatus.NOT_CONVERGED] = Status.NOT_CONVERGED.value
    status[closed.status == ClosureStatus.NO_ASSEMBLY] = Status.NO_ASSEMBLY.value
    analysis = LoopAnalysis(mechanism, loop, drive, closed.state, rates, wrenches, status, closed.residual,
                            closed.iterations)
    if not compiled:  # the numpy path evaluated the chain already: it is the cached one, not evaluated again
        analysis.__dict__["chain"] = chain
    return through_locks(analysis, at, compiled)


def through_locks(an: LoopAnalysis, at: int, compiled: bool) -> LoopAnalysis:
    """``an`` (closed from position ``at``) with its branch followed through every joint lock
    (:func:`~dualmech.core.continuation.cross_lock`): where the rows closed on the branch end before a branch
    jump, the lock test walks from the last of them whose pose is regular (:func:`regular`) to each of the
    next ``LOCK_ROWS`` rows (``core/thresholds.py``) in turn; the first it reaches smoothly on a regular pose
    with the determinant's sign turned starts the rest of the rows that way (:func:`analyze_loop` of them
    from there, which follows later locks the same way).  A row between whose pose is singular (at the lock
    itself: its determinant's sign is rounding) is closed again (:func:`_at_lock`)."""
    n = an.status.shape[0]
    for step in (1, -1):
        end = _run_end(is_status(an.status, Status.OK, Status.DEAD_CENTRE), at, step)
        if not (0 <= end + step < n and an.status[end + step] == Status.BRANCH_JUMP.value):
            continue
        i = end
        while i != at and not regular(an, i):
            i -= step
        sign = branch_sign(an.loop, an.drive.take(slice(i, i + 1)).values, an.state.take(slice(i, i + 1)))[0]
        for j in range(end + step, end + step * (LOCK_ROWS + 1), step):
            if not 0 <= j < n:
                break
            pose = cross_lock(an.loop, an.drive.values, i, j, an.state.take(slice(i, i + 1)),
                              LOCK_SUBSTEPS * abs(j - i) + 1)
            here = an.drive.take(slice(j, j + 1)).values
            if pose is None or branch_sign(an.loop, here, pose)[0] != -sign \
                    or not _regular(an.loop, here, pose)[0]:
                continue
            rows = np.arange(j, n) if step == 1 else np.arange(0, j + 1)
            rest = analyze_loop(an.mechanism, pose, 0 if step == 1 else j, compiled=compiled,
                                drive=an.drive.take(rows))
            an = _with_rows(an, rows, rest)
            an = _at_lock(an, i, j)
            break
    return an


def _run_end(good: np.ndarray, at: int, step: int) -> int:
    """The last position from ``at`` (included) in the direction ``step`` (1 or -1) before the first that
    is not ``good`` ``(n,)``; ``at`` itself if the next one is not."""
    ahead = good[at + 1:] if step == 1 else good[:at][::-1]
    stops = np.flatnonzero(~ahead)
    return at + step * (int(stops[0]) if stops.size else ahead.size)


def _at_lock(an: LoopAnalysis, i: int, j: int) -> LoopAnalysis:
    """``an`` with its closed rows strictly between ``i`` and ``j`` whose poses are singular (at the lock
    itself, on any branch by the rounding of the determinant's sign, anywhere along the lock's own motion)
    closed again, from the interpolation between the poses at ``i`` and ``j``, with minimum-norm steps
    (:func:`~dualmech.core.continuation.close_min_norm`: the lock's own motion left alone) and called ``ok``:
    on no branch, the limit rule names them."""
    step = 1 if j > i else -1
    closed = (Status.OK.value, Status.DEAD_CENTRE.value, Status.BRANCH_JUMP.value)
    rows = np.array([k for k in range(i + step, j, step) if an.status[k] in closed and not regular(an, k)],
                    dtype=int)
    if not rows.size:
        return an
    t = (rows - i) / (j - i)
    guess = interpolate(an.state.take(np.full(rows.size, i)), an.state.take(np.full(rows.size, j)), t)
    values = an.drive.take(rows).values
    pose, residual = close_min_norm(an.loop, values, guess)
    closed = (residual <= ROUNDING_TOL) & ~_regular(an.loop, values, pose)  # at the lock: no rates given
    rows, status = rows[closed], an.status.copy()
    status[rows] = Status.OK.value
    return replace(an, state=an.state.put(rows, pose.take(np.flatnonzero(closed))), status=status,
                   residual=_rows_put(an.residual, rows, residual[closed]))


def _regular(loop: Loop, inputs: dict[str, np.ndarray], pose: LoopState) -> np.ndarray:
    """Whether each of the ``n`` positions' ``pose`` is regular ``(n,)``: its closure Jacobian's singular
    values' ratio at least ``REGULAR_POSE`` (``core/thresholds.py``)."""
    sv = np.linalg.svd(closure_jacobian(loop, inputs, pose), compute_uv=False)
    return sv[:, -1] >= REGULAR_POSE.value * sv[:, 0]


def regular(an: LoopAnalysis, i: int) -> bool:
    """Whether ``an``'s pose at position ``i`` is regular (:func:`_regular`)."""
    return bool(_regular(an.loop, an.drive.take(slice(i, i + 1)).values, an.state.take(slice(i, i + 1)))[0])


def _rows_put(mine: object, rows: np.ndarray, theirs: object) -> object:
    """``mine`` with its rows ``rows`` (the leading axis of every array in it) taken from ``theirs``, of the
    same structure (arrays, dicts, lists, tuples and dataclasses of them)."""
    if isinstance(mine, np.ndarray):
        out = mine.copy()
        out[rows] = theirs
        return out
    if isinstance(mine, dict):
        return {k: _rows_put(v, rows, theirs[k]) for k, v in mine.items()}
    if isinstance(mine, (list, tuple)):
        return type(mine)(_rows_put(a, rows, b) for a, b in zip(mine, theirs))
    return replace(mine, **{f.name: _rows_put(getattr(mine, f.name), rows, getattr(theirs, f.name))
                            for f in fields(mine)})


def _with_rows(an: LoopAnalysis, rows: np.ndarray, rest: LoopAnalysis) -> LoopAnalysis:
    """``an`` with the answer at positions ``rows`` taken from ``rest`` (an analysis of those rows)."""
    parts = ("state", "rates", "wrenches", "status", "residual", "iterations")
    return replace(an, **{name: _rows_put(getattr(an, name), rows, getattr(rest, name)) for name in parts})
