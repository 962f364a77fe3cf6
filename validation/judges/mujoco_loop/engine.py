"""MuJoCo as a rigid judge of any loop table: every drive position, one at a time.

The start pose is the judge's own: the joints' ``start`` values the user wrote in the table (at the first
position), or else a search (random poses, :data:`SEARCH_TRIES` of them, at up to :data:`SEARCH_POSITIONS`
evenly spread positions; of the poses closed at the first position where any closes, the one nearest the
zero pose: :func:`~dualmech.models.loop.start.nearest_to_zero`).  From there the loop is
closed position by position, forward then backward, each from its neighbour's pose (continuation; a
position that fails leaves the last closed pose as the next start), and the branch is followed by the
sign of :func:`~.closure.branch`: a position closed on the other branch is walked to again from its
neighbour in ever smaller drive steps (:func:`_walk`: near an assembly limit the two branches are close, so
one whole step may land on the other), and is a branch jump if none ends on the start's branch; except right
after positions that did not close (a gap of no assembly, where continuity is lost): there, and at every
position after such a gap that continuation does not close at all (a random RRSRR re-assembles five
positions past its gap, too far for Newton from the last closed pose), it is searched again from random
poses for one on the start's branch, and is a branch jump or unclosed only if none is found.  Where the
loop passes a joint lock the sign changes on the curve followed (``docs/conventions.md``, "Loop tables"):
a position whose walk from the last good regular pose (:func:`~.lock.cross_lock`) is smooth and ends on a
regular pose of the other sign turns the branch; a singular pose at the lock itself is held until then
(``ok``, named by the limit rule, if a walk past it turns the branch; else ``branch_jump``).
Nothing of the in-house engine is used (independence).

Statuses (:mod:`dualmech.core.status`): ``no_assembly`` / ``not_converged`` from Newton
(:func:`~.closure.close`), ``branch_jump`` where the branch sign differs from the start pose's,
``assembly_limit`` by the loop table's rule on the judge's own pose
(:func:`~dualmech.models.loop.columns.limit_words`), ``dead_centre`` where the transmission is below
:data:`~dualmech.core.thresholds.DEAD_CENTRE_TRANSMISSION` (its efforts and reactions are NaN), else ``ok``.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np

from dualmech.core.status import Status
from dualmech.core.thresholds import DEAD_CENTRE_TRANSMISSION, LOCK_ROWS, LOCK_SUBSTEPS
from dualmech.models.loop.columns import column_names, coordinate_names
from dualmech.models.loop.description import LoopMechanism
from dualmech.models.loop.mobility import check_mobility
from dualmech.models.loop.start import nearest_to_zero
from dualmech.validation.judges.mujoco_loop.closure import (
    MjLoop,
    branch,
    build,
    close,
    coordinate_values,
    positions,
    prescribe,
    scatter,
    set_start,
    variable,
)
from dualmech.validation.judges.mujoco_loop.dynamics import (
    Balance,
    balance,
    drift,
    joint_wrenches,
    set_velocity,
    solve_free,
    velocity_rows,
)
from dualmech.validation.judges.mujoco_loop.lock import Pose, cross_lock, regular

ENGINE = "mujoco-loop"
#: Drive positions tried, evenly spread, when no joint gives a start value.
SEARCH_POSITIONS = 8
#: Random poses tried at each of them.
SEARCH_TRIES = 64
#: Halvings of a drive step tried where continuation closes on the other branch (:func:`_walk`): up to 32
#: steps.
SUBSTEPS = 5


@dataclass(frozen=True)
class LoopTable:
    """The judge's answer at the ``n`` drive positions of a table.

    Attributes
    ----------
    engine, name : str
    columns : dict of str -> numpy.ndarray, shape (n,)
        :func:`~dualmech.models.loop.columns.column_names`: every scalar joint coordinate ``theta<i>``,
        ``s<i>``, ``eta<i>`` (rad, length)
        with ``_dot`` and ``_ddot``; the efforts ``effort_<coordinate><i>`` (given and solved: on link i
        from link i-1); ``joint<i>_f{x,y,z}`` and ``joint<i>_m{x,y,z}``: joint i's wrench on link i from
        link i-1, world axes, the moment about the joint's point (``docs/conventions.md``, "Loop tables").
        NaN where the status does not give them.
    status : numpy.ndarray of str, shape (n,)
    iterations : numpy.ndarray of int, shape (n,)
        Newton iterations.
    residual : numpy.ndarray, shape (n,)
        Closure gap (translations over the table's length, rotations in rad).
    dynamics_residual : numpy.ndarray, shape (n,)
        Relative least-squares residual of the inverse dynamics.
    meta : dict
        What else the judge states (the simulated judge: time step, run-in, tracking lag, ...).
    """

    engine: str
    name: str
    columns: dict[str, np.ndarray]
    status: np.ndarray
    iterations: np.ndarray
    residual: np.ndarray
    dynamics_residual: np.ndarray
    meta: dict = field(default_factory=dict)


def efforts(mechanism: LoopMechanism) -> tuple[dict[str, float], list[str]]:
    """The given efforts by variable name and the solved ones (the transmission's last): the drive's (a C
    drive's axial force is a solved reaction) and the loads'."""
    d = mechanism.drive
    given: dict[str, float] = {}
    solved, transmission = [], []
    drive = variable(d.joint, d.coordinate)
    if d.effort is None:
        transmission.append(drive)
    else:
        given[drive] = d.effort
    if mechanism.joints[d.joint].type == "C":
        solved.append(variable(d.joint, "s"))
    for load in mechanism.loads:
        name = variable(load.joint, load.coordinate)
        if load.value is None:
            transmission.append(name)
        else:
            given[name] = load.value
    return given, solved + transmission


def drive_values(mechanism: LoopMechanism, k: int) -> tuple[dict[str, float], np.ndarray, np.ndarray]:
    """The prescribed coordinates' values by name, rates and accelerations at drive position ``k``
    (:func:`drive_at`)."""
    d = mechanism.drive
    return drive_at(mechanism, float(d.positions[k]), d.speed, d.accel)


def drive_at(mechanism: LoopMechanism, value: float, speed: float,
             accel: float) -> tuple[dict[str, float], np.ndarray, np.ndarray]:
    """The prescribed coordinates' values by name, rates and accelerations where the driven coordinate is
    ``value`` with rate ``speed`` and acceleration ``accel``, floats or arrays ``(k,)`` (then the values
    are arrays and the rates and accelerations ``(m, k)``; a C drive's slide by the axial law
    :math:`S = S_0 + S_S \\sin(c\\,\\theta)`, thesis eq. 27-28)."""
    d = mechanism.drive
    theta, w, wd = value, speed, accel
    values = {variable(d.joint, d.coordinate): theta}
    rates, accels = [w], [wd]
    if mechanism.joints[d.joint].type == "C":
        amp, cyc = d.axial_amplitude, d.axial_cycles
        phase = cyc * theta
        values[variable(d.joint, "s")] = d.axial_shift + amp * np.sin(phase)
        rates.append(amp * cyc * np.cos(phase) * w)
        accels.append(amp * cyc * (np.cos(phase) * wd - cyc * np.sin(phase) * w * w))
    return values, np.array(np.broadcast_arrays(*rates)), np.array(np.broadcast_arrays(*accels))


def find_start(lp: MjLoop, seed: int = 0) -> int:
    """Set the start pose (module docstring) and return the drive position it belongs to."""
    mech = lp.mechanism
    if any(j.start for j in mech.joints):
        set_start(lp)
        prescribe(lp, drive_values(mech, 0)[0])
        return 0
    n = mech.drive.positions.shape[0]
    rng = np.random.default_rng(seed)
    for at in np.unique(np.linspace(0, n - 1, min(n, SEARCH_POSITIONS)).round().astype(int)):
        closed = []
        for _ in range(SEARCH_TRIES):
            scatter(lp, rng)
            prescribe(lp, drive_values(mech, int(at))[0])
            if close(lp)[0] == Status.OK:
                closed.append((lp.data.qpos.copy(), lp.q_cut.copy(), coordinate_values(lp)))
        if closed:
            qpos, lp.q_cut, _ = closed[nearest_to_zero([c[2] for c in closed])]
            lp.data.qpos[:] = qpos
            positions(lp)
            return int(at)
    raise ValueError(f"start: no assembled pose found at {min(n, SEARCH_POSITIONS)} drive positions; give "
                     "the joints' start values")


def _branch_search(lp: MjLoop, k: int, sign: float, rng: np.random.Generator) -> tuple[int, float] | None:
    """Close position ``k`` on the branch ``sign`` from random poses (:data:`SEARCH_TRIES`), where
    continuation did not close it there (past a gap of no assembly: on the other branch, or not at all):
    the closing try's iterations and gap if one was found (then it is the current pose), else ``None``."""
    values = drive_values(lp.mechanism, k)[0]
    for _ in range(SEARCH_TRIES):
        scatter(lp, rng)
        prescribe(lp, values)
        outcome, iterations, gap = close(lp)
        if outcome == Status.OK and branch(lp) == sign:
            return iterations, gap
    return None


def _walk(lp: MjLoop, last: tuple[np.ndarray, np.ndarray, dict[str, float]], values: dict[str, float],
          sign: float) -> tuple[int, float] | None:
    """Continuation from the closed pose ``last`` (its ``qpos``, cut coordinates and drive values) to the
    drive ``values`` in 2, 4, ... ``2**SUBSTEPS`` equal steps, where one step closed on the other branch
    (near an assembly limit the two branches are close): the last close's iterations and gap if it ends on
    branch ``sign`` (then the current pose), else ``None``."""
    for halvings in range(1, SUBSTEPS + 1):
        lp.data.qpos[:], lp.q_cut = last[0], last[1].copy()
        steps = 2 ** halvings
        for j in range(1, steps + 1):
            t = j / steps
            prescribe(lp, {name: (1.0 - t) * last[2][name] + t * value for name, value in values.items()})
            outcome, iterations, gap = close(lp)
            if outcome != Status.OK:
                break
        else:
            if branch(lp) == sign:
                return iterations, gap
    return None


def dynamics_at(lp: MjLoop, k: int, given: dict[str, float],
                solved: list[str]) -> tuple[np.ndarray, np.ndarray, Balance]:
    """Rates ``u_dot``, accelerations ``u_ddot`` ``(n_u,)`` and the balance at drive position ``k``, at the
    closed pose ``lp`` holds."""
    _, rates, accels = drive_values(lp.mechanism, k)
    positions(lp)
    rows = velocity_rows(lp)
    u_dot = solve_free(lp, rows, rates, np.zeros(rows.shape[0]))
    set_velocity(lp, u_dot)
    u_ddot = solve_free(lp, rows, accels, -drift(lp, u_dot))
    return u_dot, u_ddot, balance(lp, u_ddot, given, solved)


def judge_position(lp: MjLoop, k: int, given: dict[str, float], solved: list[str],
                   columns: dict[str, np.ndarray], coordinates: list[str]) -> tuple[float, float]:
    """Rates, efforts and wrenches at a closed pose, into ``columns[...][k]``; returns the dynamics'
    residual and the transmission (below :data:`DEAD_CENTRE_TRANSMISSION`: a dead centre, efforts and
    wrenches left out)."""
    u_dot, u_ddot, cut = dynamics_at(lp, k, given, solved)
    for name in coordinates:
        index, address = lp.coordinates[name]
        value = lp.data.qpos[address] if address >= 0 else lp.q_cut[index - lp.model.nv]
        columns[name][k], columns[name + "_dot"][k], columns[name + "_ddot"][k] = \
            value, u_dot[index], u_ddot[index]
    if cut.transmission < DEAD_CENTRE_TRANSMISSION.value:
        return cut.residual, cut.transmission
    for name, value in cut.efforts.items():
        columns[f"effort_{name}"][k] = value
    forces, moments = joint_wrenches(lp, cut)
    for i in range(forces.shape[0]):
        for a, axis in enumerate("xyz"):
            columns[f"joint{i + 1}_f{axis}"][k] = forces[i, a]
            columns[f"joint{i + 1}_m{axis}"][k] = moments[i, a]
    return cut.residual, cut.transmission


def sweep(lp: MjLoop, seed: int = 0) -> Iterator[tuple[int, str, int, float]]:
    """Close every drive position by continuation from the start pose (module docstring).

    Yields ``(k, outcome, iterations, gap)`` per position, in the order closed; ``outcome`` ``"ok"`` (then
    ``lp`` holds the closed pose, on the start's branch), ``"branch_jump"``, ``"no_assembly"`` or
    ``"not_converged"``.  What the caller does with the pose between yields does not change the sweep.
    """
    mechanism = lp.mechanism
    n = mechanism.drive.positions.shape[0]
    at = find_start(lp, seed)
    rng = np.random.default_rng(seed)
    anchor = (lp.data.qpos.copy(), lp.q_cut.copy(), drive_values(mechanism, at)[0])  # the start estimate,
    start_branch = None                                                              # then the closed pose
    for order in (range(at, n), range(at - 1, -1, -1)):
        last, gap_before, now, pending = anchor, False, start_branch, []
        steady, steady_row = anchor, at  # the last good regular pose: a walk through a lock starts there
        for k in order:
            values = drive_values(mechanism, k)[0]
            lp.data.qpos[:], lp.q_cut = last[0], last[1].copy()
            prescribe(lp, values)
            outcome, iterations, gap = close(lp)
            if outcome != Status.OK:
                found = _branch_search(lp, k, now, rng) if gap_before and now else None
                if found is None:
                    gap_before = True
                    yield k, outcome, iterations, gap
                    continue
                iterations, gap = found
            sign = branch(lp)
            if start_branch is None:
                start_branch = now = sign
                anchor = (lp.data.qpos.copy(), lp.q_cut.copy(), values)
            jumped, found = sign != now, None
            if jumped:
                held = (lp.data.qpos.copy(), lp.q_cut.copy(), values, iterations, gap)
                singular = not regular(lp)
                found = _branch_search(lp, k, now, rng) if gap_before else _walk(lp, last, values, now)
                if found is None and not gap_before:
                    if singular:  # at a lock itself, or an edge: on no branch, named once a walk passes it
                        pending.append((k, held))
                        continue
                    found = _through_lock(lp, steady, values, abs(k - steady_row), now)
                    if found is not None:
                        now = -now
                        yield from _release(lp, pending, Status.OK.value)
            gap_before = False
            if jumped and found is None:
                yield from _release(lp, pending, Status.BRANCH_JUMP.value)
                yield k, Status.BRANCH_JUMP.value, iterations, gap
                continue
            yield from _release(lp, pending, Status.BRANCH_JUMP.value)
            iterations, gap = found or (iterations, gap)
            last = (lp.data.qpos.copy(), lp.q_cut.copy(), values)
            if regular(lp):
                steady, steady_row = last, k
            yield k, Status.OK.value, iterations, gap
        yield from _release(lp, pending, Status.BRANCH_JUMP.value)


def _through_lock(lp: MjLoop, last: Pose, values: dict[str, float], rows: int,
                  sign: float) -> tuple[int, float] | None:
    """The walk from ``last`` (``rows`` drive positions back) to ``values`` through a joint lock
    (:func:`~.lock.cross_lock`, at most ``LOCK_ROWS`` rows): its iterations and gap where it is smooth and
    ends on a regular pose of the other sign than ``sign`` (then ``lp`` holds that pose), else ``None``."""
    if rows > LOCK_ROWS:
        return None
    found = cross_lock(lp, last, values, LOCK_SUBSTEPS * rows + 1)
    return found if found is not None and branch(lp) == -sign and regular(lp) else None


def _release(lp: MjLoop, pending: list, word: str) -> Iterator[tuple[int, str, int, float]]:
    """Yield the rows held at a lock (``pending``, emptied) with ``word``, each with its own pose in ``lp``
    while it is yielded; the current pose is restored after."""
    if not pending:
        return
    current = (lp.data.qpos.copy(), lp.q_cut.copy())
    for k, (qpos, q_cut, _, iterations, gap) in pending:
        lp.data.qpos[:], lp.q_cut = qpos, q_cut.copy()
        positions(lp)
        yield k, word, iterations, gap
    pending.clear()
    lp.data.qpos[:], lp.q_cut = current[0], current[1].copy()
    positions(lp)


def solve_loop(mechanism: LoopMechanism, *, seed: int = 0, xml: str | None = None) -> LoopTable:
    """Every drive position of ``mechanism`` judged by rigid MuJoCo (module docstring).

    Parameters
    ----------
    mechanism : LoopMechanism
        A one-degree-of-freedom table (:func:`~dualmech.models.loop.mobility.check_mobility`).
    seed : int
        Seed of the start search (used only when no joint gives a start value).
    xml : str, optional
        The MJCF text to compile instead of :func:`~.mjcf.loop_mjcf`'s (the same names: e.g. a hand-edited
        model, or one with a deliberate fault).
    """
    check_mobility(mechanism)
    lp = build(mechanism, xml)
    n = mechanism.drive.positions.shape[0]
    columns = {name: np.full(n, np.nan) for name in column_names(mechanism)}
    coordinates = coordinate_names(mechanism)
    given, solved = efforts(mechanism)
    status = np.full(n, Status.NOT_CONVERGED.value, dtype=object)
    iterations, residual, dyn = np.zeros(n, dtype=int), np.full(n, np.nan), np.full(n, np.nan)
    for k, outcome, iterations[k], residual[k] in sweep(lp, seed):
        status[k] = outcome
        if outcome == Status.OK:
            dyn[k], transmission = judge_position(lp, k, given, solved, columns, coordinates)
            if transmission < DEAD_CENTRE_TRANSMISSION.value:
                status[k] = Status.DEAD_CENTRE.value
    return LoopTable(ENGINE, mechanism.name, columns, status, iterations, residual, dyn)


__all__ = ["ENGINE", "LoopTable", "column_names", "drive_at", "drive_values", "dynamics_at", "efforts",
           "find_start", "judge_position", "solve_loop", "sweep"]
