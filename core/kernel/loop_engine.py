"""Any single loop analysed by the compiled kernel: the numpy solver's continuation, rates and joint wrenches.

:func:`solve_loop` gives what :func:`~dualmech.core.continuation.continue_closure`,
:func:`~dualmech.core.rates.solve_rates` and :func:`~dualmech.core.loop_reactions.solve_joint_wrenches`
give, by the same algorithm: the start pose and the stations closed in turn, walking the positions between
two stations where Newton cannot reach the next (one position at a time on the kernel,
:func:`~dualmech.core.kernel.continuation_nb.close_one`), then every position from its estimate, closed,
refined, its rates and its joint wrenches (:func:`~dualmech.core.kernel.loop_engine_nb.analyze_block`), in
blocks of whole segments of positions on the kernel's threads (:mod:`~dualmech.core.kernel.pool`), then the
positions that missed the branch closed again one after the other from their closed neighbour (the numpy
solver's repair).  One difference from the numpy solver, for speed: within a segment a position's estimate
is extrapolated from the one closed before it (its rates and accelerations, second order), where the numpy
solver interpolates between the stations (:mod:`~dualmech.core.kernel.loop_engine_nb`), and the branch sign
and the rates use the LU factors of the refine's last step where it began closed to rounding
(:func:`~dualmech.core.kernel.continuation_nb.close_position`); both refine to the rounding level, so the
answers differ by rounding.  Every
position's answer is the same whatever the blocks: it depends on the stations and its segment only.

The table becomes data here: :func:`~dualmech.core.kernel.loop_nb.flatten` and a
:class:`~dualmech.core.kernel.wrenches_nb.WrenchSpec` (the wrench columns in the numpy solver's order);
nothing is compiled per table.  The blocks' scratch is the spare scratch of earlier calls on tables of the
same sizes (:func:`~dualmech.core.kernel.pool.take_scratch`), given back at the end.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from dualmech.core.closure import ClosureStatus
from dualmech.core.continuation import STATIONS, Continuation, start_not_closed, station_positions
from dualmech.core.dual import Dual
from dualmech.core.kernel.closure_nb import Work, closure_tols, make_work
from dualmech.core.kernel.compiles import compile_session
from dualmech.core.kernel.continuation_nb import branch_sign, close_one, close_stations, refine_one
from dualmech.core.kernel.dfp_nb import solve_closure
from dualmech.core.kernel.loop_engine_nb import (
    CODE,
    DYNAMICS_RESIDUAL,
    ITERATIONS,
    RESIDUAL,
    SEGMENT,
    SIGN,
    TRANSMISSION,
    analyze_block,
    outputs_at,
)
from dualmech.core.kernel.loop_nb import COLUMN, VALUE_INDEX, FlatLoop, flatten, state_size, value_names
from dualmech.core.kernel.pool import give_scratch, kernel_pool, take_scratch, threads
from dualmech.core.kernel.wrenches_nb import (
    FORCE,
    MOMENT,
    SLIDE,
    TURN,
    WrenchSpec,
    WrenchWork,
    make_wrench_work,
)
from dualmech.core.loop import Loop, LoopState, Var
from dualmech.core.loop_reactions import JointWrenches, effort_slots, joint_freedoms
from dualmech.core.rates import Rates
from dualmech.core.reactions import Body

#: Fewest positions worth a block (a thread's task) of their own: a table of two blocks' positions (a
#: turn in degrees: 360) keeps both threads of a 2-core machine busy.
BLOCK = 128
#: Blocks per thread: uneven work (DFP near an edge of assembly) evens out.
BLOCKS_PER_THREAD = 4


def screw_of(fl: FlatLoop, loop: Loop, var: Var, names: tuple[str, ...]) -> int:
    """The index in ``fl.screws`` of the screw of an input or unknown slot ``var`` (``names``: the loop's
    :func:`~dualmech.core.kernel.loop_nb.value_names`)."""
    if var.kind == "unknown":
        return int(np.flatnonzero(fl.screws[:, COLUMN] == loop.unknowns.index(var.name))[0])
    index = names.index(var.name)
    return int(np.flatnonzero((fl.screws[:, COLUMN] < 0) & (fl.screws[:, VALUE_INDEX] == index))[0])


def _moving(v: float | Var) -> bool:
    return isinstance(v, Var) and v.kind != "param"


def wrench_spec(fl: FlatLoop, loop: Loop, bodies: Sequence[Body], gravity: np.ndarray,
                efforts: dict[str, np.ndarray | None], transmission_effort: str,
                n: int) -> tuple[WrenchSpec, np.ndarray, list[tuple[str | None, str, int]]]:
    """The :class:`WrenchSpec` of ``loop``, the given efforts ``(n, g)``, and per unknown column its effort
    name (``None`` for a constraint component), its label and its row -- the columns of
    :func:`dualmech.core.loop_reactions.solve_joint_wrenches`, in its order."""
    columns, labels = [], []
    for r in range(len(loop.rows)):
        turns, slides = joint_freedoms(loop, r)
        for k in range(3):
            if k not in slides:
                columns.append((r, FORCE, k))
                labels.append((None, "f" + "xyz"[k], r))
            if k not in turns:
                columns.append((r, MOMENT, k))
                labels.append((None, "m" + "xyz"[k], r))
    solved, given, values, names = [], [], [], value_names(loop)
    for r, name, slide in effort_slots(loop):
        var = next(getattr(loop.rows[r], f) for f in ("theta", "s", "eta")
                   if _moving(getattr(loop.rows[r], f)) and getattr(loop.rows[r], f).name == name)
        column = (r, SLIDE if slide else TURN, screw_of(fl, loop, var, names))
        value = efforts.get(name, np.zeros(n))
        if value is None:
            solved.append((column, (name, name, r)))
        else:
            given.append(column)
            values.append(np.broadcast_to(np.asarray(value, dtype=float), (n,)))
    solved.sort(key=lambda c: c[1][0] == transmission_effort)
    columns += [c for c, _ in solved]
    labels += [label for _, label in solved]
    eta = [screw_of(fl, loop, row.eta, names) if _moving(row.eta) else -1 for row in loop.rows]
    spec = WrenchSpec(
        np.array(columns, dtype=np.int64).reshape(-1, 3),
        np.array(given, dtype=np.int64).reshape(-1, 3),
        np.array(eta, dtype=np.int64),
        np.array([float(b.mass) for b in bodies]),
        np.array([np.asarray(b.com, dtype=float) for b in bodies]).reshape(-1, 3),
        np.array([np.asarray(b.inertia, dtype=float) for b in bodies]).reshape(-1, 3, 3),
        np.array(np.broadcast_to(np.asarray(gravity, dtype=float), (3,))),
    )
    given_values = np.ascontiguousarray(np.stack(values, axis=1)) if values else np.zeros((n, 0))
    return spec, given_values, labels


#: Whether :func:`_warm` was true once in this process.
_WARMED = False


def _warm() -> bool:
    """Whether this process holds the block pass's and the repairs' entry points (loaded or compiled):
    calling them once inside the compile session is then needless.  Once true, true for the process (a
    dispatcher's ``signatures`` cost a millisecond, a tenth of a short case)."""
    global _WARMED
    _WARMED = _WARMED or bool(analyze_block.signatures and outputs_at.signatures and refine_one.signatures)
    return _WARMED


def _flat_state(state: LoopState) -> np.ndarray:
    """The first position of ``state`` as the kernel's flat state (scalars, then rotations row-major)."""
    return np.concatenate([state.scalars[0], state.rotations[0].reshape(-1)]).astype(float)


def _by_value(names: tuple[str, ...], values: dict[str, np.ndarray], n: int) -> np.ndarray:
    """``(n, V)``: each name's values (0 where ``values`` has none: a parameter's rate)."""
    out = np.zeros((n, len(names)))
    for k, name in enumerate(names):
        if name in values:
            out[:, k] = values[name]
    return out


class _Closer:
    """One position at a time on the kernel, for the sequential parts of the continuation: the start, the
    stations and the walks between them, the repairs (``_close_one``, ``_walk``, ``_repair`` of
    :mod:`dualmech.core.continuation`, step for step)."""

    def __init__(self, fl: FlatLoop, vals: np.ndarray, work: Work) -> None:
        self.fl, self.vals, self.work, self.tols = fl, vals, work, closure_tols()
        self.branch = 0

    def start(self, start: LoopState, at: int) -> np.ndarray:
        """The start pose closed at position ``at``, whose branch is followed (raises where it does not
        close)."""
        x = _flat_state(start)
        code, _, residual = solve_closure(self.fl, self.vals[at], x, self.tols, self.work)
        if code != ClosureStatus.OK:
            raise start_not_closed(at, residual)
        self.branch = branch_sign(self.fl, self.vals[at], x, self.work)
        return x

    def one(self, i: int, guess: np.ndarray) -> tuple[np.ndarray | None, int, float]:
        """Position ``i`` closed from ``guess`` on the branch (``None`` if not), its iterations, residual."""
        x = guess.copy()
        closed, iters, residual = close_one(self.fl, self.tols, self.vals[i], x, self.branch, self.work)
        return (x if closed else None), iters, residual

    def refine(self, i: int, x: np.ndarray) -> tuple[int, float]:
        return refine_one(self.fl, self.tols._replace(closure=0.0), self.vals[i], x, self.work)


def _stations(closer: _Closer, n: int, start: LoopState, at: int,
              stations: int) -> tuple[np.ndarray, np.ndarray]:
    """The start and the stations closed in turn, walking the positions between where Newton cannot reach
    a station (:func:`~dualmech.core.kernel.continuation_nb.close_stations`, one compiled call each way):
    the good positions (sorted) and their states."""
    states, good = np.empty((n, state_size(closer.fl))), np.zeros(n, dtype=bool)
    states[at], good[at] = closer.start(start, at), True
    idx = station_positions(n, stations)
    for way in (idx[idx > at], idx[idx < at][::-1]):
        close_stations(closer.fl, closer.tols, closer.vals, closer.branch, at, np.ascontiguousarray(way),
                       states, good, closer.work)
    good_pos = np.flatnonzero(good)
    return good_pos, states[good_pos]


def _repair(closer: _Closer, out: tuple, at: int) -> np.ndarray:
    """Positions the block pass did not close on the branch, closed again one after the other from the
    closed neighbour on the start's side, until one does not close on the branch; returns the rows
    repaired (their rates and wrenches are still to be computed)."""
    xs, ints, reals = out[0], out[5], out[6]
    good = (ints[:, CODE] == ClosureStatus.OK) & (ints[:, SIGN] == closer.branch)
    if good.all() or not good.any():
        return np.zeros(0, dtype=np.int64)
    n, repaired = good.size, []
    for step in (1, -1):
        for i in np.flatnonzero(good & ((np.arange(n) - at) * step >= 0)):
            j, last = i + step, xs[i]
            while 0 <= j < n and not good[j]:
                x, iters, _ = closer.one(int(j), last)
                if x is None:
                    break
                more, residual = closer.refine(int(j), x)
                xs[j], last = x, x
                ints[j, CODE], ints[j, SIGN] = ClosureStatus.OK, closer.branch
                ints[j, ITERATIONS] = iters + more
                reals[j, RESIDUAL], good[j] = residual, True
                repaired.append(j)
                j += step
    return np.array(repaired, dtype=np.int64)


def solve_loop(loop: Loop, inputs: dict[str, np.ndarray], input_rates: dict[str, np.ndarray],
               input_accels: dict[str, np.ndarray], start: LoopState, at: int, bodies: Sequence[Body],
               gravity: np.ndarray, efforts: dict[str, np.ndarray | None], transmission_effort: str,
               stations: int = STATIONS) -> tuple[Continuation, Rates, JointWrenches]:
    """The closure by continuation, the rates and the joint wrenches of ``loop`` at every position of
    ``inputs`` (module docstring): the answers of :func:`~dualmech.core.continuation.continue_closure`
    (``start`` at position ``at``), :func:`~dualmech.core.rates.solve_rates` and
    :func:`~dualmech.core.loop_reactions.solve_joint_wrenches` (``bodies``, ``gravity``, ``efforts``,
    ``transmission_effort``; the moment rows over the loop's length scale).

    Raises
    ------
    ValueError
        If the loop's closure Jacobian is not square (not one degree of freedom), or position ``at`` does
        not close from ``start``.
    """
    fl = flatten(loop)
    if 6 + fl.gauges.size != fl.n_step:
        raise ValueError(f"loop: the compiled engine needs one degree of freedom (a square closure "
                         f"Jacobian), got {6 + fl.gauges.size} equations for {fl.n_step} unknowns")
    names = value_names(loop)
    n = next(iter(inputs.values())).shape[0]
    vals = _by_value(names, inputs, n)
    spec, given, labels = wrench_spec(fl, loop, bodies, gravity, efforts, transmission_effort, n)
    values = (vals, _by_value(names, input_rates, n), _by_value(names, input_accels, n), given)
    rows, k = len(loop.rows), fl.n_step
    out = (np.empty((n, state_size(fl))), np.empty((n, 2, k)), np.empty((n, 2, rows, 2, 3)),
           np.empty((n, 3, rows, 3)), np.empty((n, len(labels))), np.empty((n, 3), np.int64),
           np.empty((n, 3)))
    tols = closure_tols()
    kind = (rows, fl.screws.shape[0], fl.gauges.size, k, state_size(fl), len(labels))  # the scratch's sizes

    def new() -> tuple[Work, WrenchWork]:
        return make_work(fl), make_wrench_work(rows, len(labels), fl.screws.shape[0])

    scratch = [take_scratch(kind, new)]
    closer = _Closer(fl, vals, scratch[0][0])
    with compile_session():  # a cold cache compiles every entry point here, as one compile
        good_pos, good_x = _stations(closer, n, start, at, stations)
        args = (fl, tols, tols._replace(closure=0.0), spec, values, good_pos, good_x, closer.branch, out)
        if not _warm():
            analyze_block(0, 0, *args, *scratch[0])
            outputs_at(np.zeros(0, dtype=np.int64), fl, spec, values, out, *scratch[0])
            closer.refine(int(good_pos[0]), good_x[0].copy())  # the repairs' entry point (the start, closed)
    parts = max(1, min(n // BLOCK, threads() * BLOCKS_PER_THREAD))
    segments = -(-n // SEGMENT)  # blocks of whole segments: the answers do not depend on the blocks
    bounds = np.unique(np.minimum(np.linspace(0, segments, parts + 1).round().astype(int) * SEGMENT, n))
    # every scratch taken before the first block starts: made meanwhile, it would wait for a free core; the
    # first block's is the closer's, which waits meanwhile
    scratch += [take_scratch(kind, new) for _ in range(bounds.size - 2)]
    blocks = [kernel_pool().submit(analyze_block, int(a), int(b), *args, work, wrench_work)
              for a, b, (work, wrench_work) in zip(bounds[:-1], bounds[1:], scratch)]
    for block in blocks:
        block.result()
    repaired = _repair(closer, out, at)
    if repaired.size:
        outputs_at(repaired, fl, spec, values, out, closer.work, scratch[0][1])
    give_scratch(kind, scratch)
    return _results(loop, out, closer.branch, efforts, labels)


def _results(loop: Loop, out: tuple, branch: int, efforts: dict[str, np.ndarray | None],
             labels: list[tuple[str | None, str, int]]) -> tuple[Continuation, Rates, JointWrenches]:
    """The kernel's outputs as the numpy solver's result objects."""
    xs, q, motion, wrench, unknowns, ints, reals = out
    n, k = xs.shape[0], len(loop.unknowns)
    state = LoopState(xs[:, :k], xs[:, k:].reshape(n, -1, 3, 3))
    status = ints[:, CODE].astype(np.int8)
    closed = status == ClosureStatus.OK
    closure = Continuation(state, status, closed & (ints[:, SIGN] != branch), reals[:, RESIDUAL],
                           ints[:, ITERATIONS], branch)
    rows = range(len(loop.rows))
    rates = Rates(q[:, 0], q[:, 1], [Dual(motion[:, 0, r, 0], motion[:, 0, r, 1]) for r in rows],
                  [Dual(motion[:, 1, r, 0], motion[:, 1, r, 1]) for r in rows])
    values = {name: np.asarray(v, dtype=float) for name, v in efforts.items() if v is not None}
    components: tuple[dict[str, np.ndarray], ...] = tuple({} for _ in rows)
    for c, (name, label, r) in enumerate(labels):
        if name is None:
            components[r][label] = unknowns[:, c]
        else:
            values[name] = unknowns[:, c]
    wrenches = JointWrenches(wrench[:, 0], wrench[:, 1], wrench[:, 2], values, reals[:, DYNAMICS_RESIDUAL],
                             reals[:, TRANSMISSION], components)
    return closure, rates, wrenches
