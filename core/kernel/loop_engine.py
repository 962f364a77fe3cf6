"""Any single loop analysed by the compiled kernel: the numpy solver's continuation, rates and joint wrenches.

:func:`solve_loop` gives what :func:`~dualmech.core.continuation.continue_closure`,
:func:`~dualmech.core.rates.solve_rates` and :func:`~dualmech.core.loop_reactions.solve_joint_wrenches`
give, by the same algorithm: the start pose and the stations closed in turn
(:func:`~dualmech.core.kernel.continuation_nb.close_stations`, one thread), then every position on its
own from the estimate interpolated between the good stations around it, closed, refined, its rates and
its joint wrenches (:func:`~dualmech.core.kernel.loop_engine_nb.analyze_block`), in blocks of positions
on the kernel's threads (:mod:`~dualmech.core.kernel.pool`).  Every position's answer is the same
whatever the blocks: it depends on the stations only.

The table becomes data here: :func:`~dualmech.core.kernel.loop_nb.flatten` and a
:class:`~dualmech.core.kernel.wrenches_nb.WrenchSpec` (the wrench columns in the numpy solver's order);
nothing is compiled per table.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from dualmech.core.closure import ClosureStatus
from dualmech.core.continuation import STATIONS, Continuation, start_not_closed, station_positions
from dualmech.core.dual import Dual
from dualmech.core.kernel.closure_nb import closure_tols, make_work
from dualmech.core.kernel.compiles import compile_session
from dualmech.core.kernel.continuation_nb import close_stations
from dualmech.core.kernel.loop_engine_nb import (
    CODE,
    DYNAMICS_RESIDUAL,
    ITERATIONS,
    RESIDUAL,
    SIGN,
    TRANSMISSION,
    analyze_block,
)
from dualmech.core.kernel.loop_nb import COLUMN, VALUE_INDEX, FlatLoop, flatten, state_size, value_names
from dualmech.core.kernel.pool import kernel_pool, threads
from dualmech.core.kernel.wrenches_nb import FORCE, MOMENT, SLIDE, TURN, WrenchSpec, make_wrench_work
from dualmech.core.loop import Loop, LoopState, Var
from dualmech.core.loop_reactions import JointWrenches, effort_slots, joint_freedoms
from dualmech.core.rates import Rates
from dualmech.core.reactions import Body

#: Fewest positions worth a block (a thread's task) of their own.
BLOCK = 256
#: Blocks per thread: uneven work (DFP near an edge of assembly) evens out.
BLOCKS_PER_THREAD = 4


def screw_of(fl: FlatLoop, loop: Loop, var: Var) -> int:
    """The index in ``fl.screws`` of the screw of an input or unknown slot ``var``."""
    if var.kind == "unknown":
        return int(np.flatnonzero(fl.screws[:, COLUMN] == loop.unknowns.index(var.name))[0])
    index = value_names(loop).index(var.name)
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
    solved, given, values = [], [], []
    for r, name, slide in effort_slots(loop):
        var = next(getattr(loop.rows[r], f) for f in ("theta", "s", "eta")
                   if _moving(getattr(loop.rows[r], f)) and getattr(loop.rows[r], f).name == name)
        column = (r, SLIDE if slide else TURN, screw_of(fl, loop, var))
        value = efforts.get(name, np.zeros(n))
        if value is None:
            solved.append((column, (name, name, r)))
        else:
            given.append(column)
            values.append(np.broadcast_to(np.asarray(value, dtype=float), (n,)))
    solved.sort(key=lambda c: c[1][0] == transmission_effort)
    columns += [c for c, _ in solved]
    labels += [label for _, label in solved]
    eta = [screw_of(fl, loop, row.eta) if _moving(row.eta) else -1 for row in loop.rows]
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


def _stations(fl: FlatLoop, vals: np.ndarray, start: LoopState, at: int,
              stations: int) -> tuple[int, np.ndarray, np.ndarray]:
    """The start pose and the stations closed in turn: the branch sign, the good stations' positions
    (sorted) and states.  Raises :func:`~dualmech.core.continuation.start_not_closed`'s error."""
    idx = station_positions(vals.shape[0], stations)
    forward, backward = idx[idx > at], idx[idx < at][::-1]
    order = np.concatenate([[at], forward, backward]).astype(np.int64)
    xs = np.zeros((order.size, state_size(fl)))
    xs[0] = _flat_state(start)
    good = np.zeros(order.size, dtype=bool)
    code, residual, branch = close_stations(fl, closure_tols(), vals, order, forward.size, xs, good,
                                            make_work(fl))
    if code != ClosureStatus.OK:
        raise start_not_closed(at, residual)
    keep = np.argsort(order[good], kind="stable")
    return branch, np.ascontiguousarray(order[good][keep]), np.ascontiguousarray(xs[good][keep])


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
    with compile_session():  # a cold cache compiles both entry points here, as one compile
        branch, good_pos, good_x = _stations(fl, vals, start, at, stations)
        args = (fl, tols, tols._replace(closure=0.0), spec, values, good_pos, good_x, out)
        analyze_block(0, 0, *args, make_work(fl), make_wrench_work(rows, len(labels)))
    parts = max(1, min(n // BLOCK, threads() * BLOCKS_PER_THREAD))
    bounds = np.unique(np.linspace(0, n, parts + 1).round().astype(int))
    blocks = [kernel_pool().submit(analyze_block, int(a), int(b), *args, make_work(fl),
                                   make_wrench_work(rows, len(labels)))
              for a, b in zip(bounds[:-1], bounds[1:])]
    for block in blocks:
        block.result()
    return _results(loop, out, branch, efforts, labels)


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
