"""The Exudyn judge of any loop table: its own closure, then Exudyn's dynamic runs with the drive prescribed.

**Rows.**  The judge closes the loop at every drive position itself (:mod:`.closure`); each maximal run of
consecutive closed rows (a segment) is judged by Exudyn runs (:mod:`.model`), each from rest at the start
of its law's run-in (:mod:`.law`: the drive travels :data:`RUN_IN_TRAVEL`, or :data:`~.law.RUN_IN` rows'
time where that start does not close; the start pose is carried there from the run's first row in closed
steps of 2 degrees) through its rows; rows that do not close keep the closure's word, rows of a run whose
Newton iteration fails are ``not_converged``.

**Runs.**  A run passes the rows in time order: a drive of negative rate passes rising positions from the
last (a law through them the other way would go back and forth within every row).  The equations of
motion are even in time (gravity and the given efforts are constant, the velocity terms quadratic, the
multipliers of a prescribed motion even), so the same motion reversed in time, through the rows the other
way at the opposite rate and the same acceleration, gives the same coordinates, accelerations and
reactions and the rates negated.  A segment is one run, the table's motion or else its reversal, whose
run-in closes; where neither closes (a table that assembles only from or up to the segment's ends: the
``rrcrc`` from 125 degrees), the table's motion through the rows from the first whose run-in starts
within the segment, and the reversal through the rows before it from its far end alike; rows neither
reaches (a segment shorter than two run-ins) are ``not_converged``.

**Integrator.**  Newmark's method with :math:`\\beta = 1/4`, :math:`\\gamma = 1/2` (the trapezoidal rule,
spectral radius 1: no numerical damping), index-2 (velocity-level) constraints, Newton to a relative
residual of :data:`NEWTON_TOL`.  Exudyn's default, index-3 generalized-alpha (spectral radius 0.8 or 0.6:
numerical damping) gave reactions and accelerations ~80 times further from the in-house engine's on six
rows of the RSCR, extrapolated alike (joint 1's force 4e-7 N off, against 5e-9 N).

**Rows from a run** (:mod:`.richardson`): each quantity averaged over the steps around its row's knot,
which cancels the trapezoidal rule's step-to-step alternation, then Richardson-extrapolated from three runs
with steps ``h``, ``h/2``, ``h/4`` (:data:`LEVELS`; ``h``: the fastest joint coordinate travels
:data:`STEP_TRAVEL` per step, :func:`steps_per_row`), which also gives its error estimate ``E``.

**Step.**  The coarse step is first set by the rows (:func:`steps_per_row`); where the worst estimate over its
unit group's peak exceeds :data:`ESTIMATE_LIMIT`, the runs are made again with the step shortened for
:data:`ESTIMATE_TARGET` (:math:`E \\propto h^4`).  Every run passes a lead row, one spacing before its
first, so that each row judged has a row's span of the law on both sides: right after the run-in the error
was not a series in the step (a random RSSR's first row 4e-8 off, its estimate 6e-10).

A prescribed coordinate is its law's value, rate and acceleration.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterator
from dataclasses import dataclass

import exudyn as exu
import numpy as np

from dualmech.core.status import Status
from dualmech.core.thresholds import DEAD_CENTRE_TRANSMISSION
from dualmech.models.loop.description import LoopMechanism
from dualmech.validation.judges.exudyn_loop.closure import Pose, close_along
from dualmech.validation.judges.exudyn_loop.continuation import continuation
from dualmech.validation.judges.exudyn_loop.given import combine, solved_load, variants
from dualmech.validation.judges.exudyn_loop.law import RUN_IN, axial, drive_law, row_time
from dualmech.validation.judges.exudyn_loop.model import build_system, check_table
from dualmech.validation.judges.exudyn_loop.readout import read_row
from dualmech.validation.judges.exudyn_loop.richardson import (
    WEIGHTS,
    average,
    extrapolate,
    richardson,
    worst_estimate,
)

#: The drive's travel per step of the coarse run, rad (a slide drive: times the table's length); the fine
#: run takes steps of half of it.
STEP_TRAVEL = math.radians(10.0) / 64
#: The drive's travel in the run-in from rest to the first row, rad (a slide drive: times the table's length).
RUN_IN_TRAVEL = math.radians(90.0)
#: The runs' steps, in coarse steps: ``h``, ``h/2``, ``h/4``.
LEVELS = (1, 2, 4)
#: The coarse run's least steps between rows when the drive accelerates: the law's rate returns to the
#: table's at every row, so it wiggles on the rows' time scale (:mod:`.law`), not the motion's.
MIN_STEPS_ACCEL = 64
#: Newton's relative residual tolerance in every step, and the one of a run that stalls above it.
NEWTON_TOL, NEWTON_RETRY = 1e-12, 1e-10
#: A table whose worst Richardson estimate over its unit group's peak (:func:`worst_estimate`) is above
#: ESTIMATE_LIMIT is run again with the steps shortened for ESTIMATE_TARGET (the estimate goes with
#: :math:`h^4`): the random tables of tests/models/loop with the drive accelerating (the law's rate returns
#: to the table's at every row) had estimates up to 1e-7, and differences from the in-house engine alike.
ESTIMATE_LIMIT, ESTIMATE_TARGET = 1e-8, 2.5e-9
#: The most the steps are shortened by (a run's cost goes with it).
MAX_REFINE = 4
#: Newton's absolute residual tolerance.
NEWTON_ABSOLUTE = 1e-14


@dataclass(frozen=True)
class ExudynLoopTable:
    """The judge's answer at the ``n`` drive positions (NaN where ``status`` is not ``ok``).

    Attributes
    ----------
    mechanism : LoopMechanism
    columns : dict of str -> numpy.ndarray, shape (n,)
        Every coordinate with ``_dot``, ``_ddot``, ``effort_*`` and ``joint<i>_f*``, ``_m*`` by column name
        (``models/loop/columns.py``), Richardson-extrapolated.
    errors : dict of str -> numpy.ndarray, shape (n,)
        Each column's Richardson error estimate ``E`` (module docstring).
    status : numpy.ndarray of str, shape (n,)
    residual : numpy.ndarray, shape (n,)
        The judge's own closure residual (over the table's length) at each row.
    """

    mechanism: LoopMechanism
    columns: dict[str, np.ndarray]
    errors: dict[str, np.ndarray]
    status: np.ndarray
    residual: np.ndarray


def settings(steps: int, end_time: float, tolerance: float = 0.0) -> exu.SimulationSettings:
    """Exudyn's settings of one run (module docstring): nothing written to files."""
    ss = exu.SimulationSettings()
    ss.solution.file.write = False
    ss.solution.sensors.active = False
    ss.timeIntegration.numberOfSteps = steps
    ss.timeIntegration.endTime = end_time
    ss.timeIntegration.verboseMode = 0
    ss.show.statistics = ss.show.computationTime = False
    ss.timeIntegration.adaptiveStep = False
    alpha = ss.timeIntegration.generalizedAlpha
    alpha.useNewmark, alpha.useIndex2Constraints, alpha.spectralRadius = True, True, 1.0
    alpha.newmarkBeta, alpha.newmarkGamma = 0.25, 0.5
    ss.timeIntegration.newton.relativeTolerance = tolerance or NEWTON_TOL
    ss.timeIntegration.newton.absoluteTolerance = NEWTON_ABSOLUTE
    return ss


@contextlib.contextmanager
def silent() -> Iterator[None]:
    """Exudyn's console output off while a run solves, as it was after: ``verboseMode = 0`` does not stop
    ``SolveDynamic`` printing its "DYNAMIC SOLVER FAILED" banner through ``exudyn.Print`` before it raises;
    the global ``exudyn.config.printToConsole`` does.  A failed run is its rows' ``not_converged``."""
    before, exu.config.printToConsole = exu.config.printToConsole, False
    try:
        yield
    finally:
        exu.config.printToConsole = before


def integrate(mechanism: LoopMechanism, pose: Pose, rows: np.ndarray, per_row: int, row: float,
              run_in: int = RUN_IN, speed: float | None = None) -> list[dict | None]:
    """One Exudyn run from rest at ``pose`` (closed at the law's start) through the drive positions
    ``rows``, ``per_row`` steps between two rows, ``row`` apart in time, after ``run_in`` rows' time of
    run-in (:func:`~.law.drive_law`), at the drive rate ``speed`` (the table's by default): each row's
    averaged quantities
    (module docstring), ``None`` for the rows after a failed step.  A run whose Newton iteration stalls
    above :data:`NEWTON_TOL` (round-off of a table in millimetres) is run again to :data:`NEWTON_RETRY`."""
    out: list[dict | None] = []
    for tolerance in (NEWTON_TOL, NEWTON_RETRY):
        out = _integrate(mechanism, pose, rows, per_row, row, run_in, tolerance,
                         mechanism.drive.speed if speed is None else speed)
        if all(r is not None for r in out):
            break
    return out


def _integrate(mechanism: LoopMechanism, pose: Pose, rows: np.ndarray, per_row: int, row: float,
               run_in: int, tolerance: float, speed: float) -> list[dict | None]:
    law = drive_law(rows, speed, mechanism.drive.accel, row, run_in)
    loop = build_system(mechanism, pose, law)
    h = row / per_row
    knots = [int(round(t / h)) for t in law.knots]
    half = len(WEIGHTS) // 2
    wanted = {j + offset: (m, offset + half) for m, j in enumerate(knots)
              for offset in range(-half, half + 1)}
    samples: list[list] = [[None] * len(WEIGHTS) for _ in knots]

    def pre_step(mbs: exu.MainSystem, t: float) -> bool:
        j = int(round(mbs.systemData.GetTime() / h)) - 1  # the step's end time; the state is its start's
        if j in wanted:
            m, slot = wanted[j]
            samples[m][slot] = read_row(loop)
        return True

    loop.mbs.SetPreStepUserFunction(pre_step)
    steps = knots[-1] + half + 1
    with silent(), contextlib.suppress(RuntimeError):  # exudyn.SolverError: the rows after it are None
        loop.mbs.SolveDynamic(settings(steps, steps * h, tolerance))
    return [average(s) if all(x is not None for x in s) else None for s in samples]


def _prescribed(mechanism: LoopMechanism) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Value, rate and acceleration of each prescribed coordinate at every row."""
    d = mechanism.drive
    x = d.positions
    out = {f"{d.coordinate}{d.joint + 1}": (x, np.full_like(x, d.speed), np.full_like(x, d.accel))}
    if len(mechanism.prescribed) == 2:
        slide = [axial((xi, d.speed, d.accel), d.axial_shift, d.axial_amplitude, d.axial_cycles) for xi in x]
        out[f"s{d.joint + 1}"] = tuple(np.array(c) for c in zip(*slide))
    return out


def _segments(ok: np.ndarray, turns: list[int] = ()) -> list[np.ndarray]:
    """Maximal runs of consecutive ``True`` rows, as index arrays, split before each row of ``turns`` (past a
    joint lock, where a run's Newton iteration fails at the singular pose: each side gets runs of its own)."""
    labels = np.cumsum(ok & (np.r_[True, ~ok[:-1]] | np.isin(np.arange(ok.size), list(turns))))
    return [np.flatnonzero(ok & (labels == k)) for k in np.unique(labels[ok])]


def swing(mechanism: LoopMechanism, poses: list) -> float:
    """The largest travel of any coordinate per unit drive travel between two consecutive closed rows
    (angles in rad, slides over the table's length; at least 1): a loop whose pose swings faster than its
    drive (the ``7r``: ~10 degrees per degree near 120) needs steps as much shorter."""
    x, length = mechanism.drive.positions, mechanism.length
    scale = length if mechanism.drive.coordinate == "s" else 1.0
    out = 1.0
    for i in range(len(poses) - 1):
        a, b = poses[i], poses[i + 1]
        if a is None or b is None or x[i + 1] == x[i]:
            continue
        moves = [abs(math.remainder(b.values[key] - v, 2 * math.pi)) if key[1] != "s" else
                 abs(b.values[key] - v) / length for key, v in a.values.items()]
        out = max(out, max(moves) * scale / abs(x[i + 1] - x[i]))
    return out


def run_in_rows(mechanism: LoopMechanism) -> int:
    """The run-in's length in rows: the drive travels :data:`RUN_IN_TRAVEL` (a slide drive: that times the
    table's length) or :data:`~.law.RUN_IN` rows, whichever is longer."""
    positions = mechanism.drive.positions
    spacing = float(np.median(np.abs(np.diff(positions)))) if positions.size > 1 else 0.0
    scale = mechanism.length if mechanism.drive.coordinate == "s" else 1.0
    return max(RUN_IN, math.ceil(RUN_IN_TRAVEL * scale / spacing)) if spacing > 0.0 else RUN_IN


def steps_per_row(mechanism: LoopMechanism, poses: list, travel: float | None = None) -> int:
    """The coarse run's steps between two rows: the median row spacing times :func:`swing` over ``travel``
    (:data:`STEP_TRAVEL`), at least :data:`MIN_STEPS_ACCEL` when the drive accelerates (module docstring)."""
    positions = mechanism.drive.positions
    spacing = float(np.median(np.abs(np.diff(positions)))) if positions.size > 1 else 0.0
    scale = mechanism.length if mechanism.drive.coordinate == "s" else 1.0
    steps = math.ceil(spacing * swing(mechanism, poses) / ((travel or STEP_TRAVEL) * scale) - 1e-9)
    return max(1, steps, MIN_STEPS_ACCEL if mechanism.drive.accel else 1)


def solve_loop(mechanism: LoopMechanism, travel: float | None = None) -> ExudynLoopTable:
    """Every drive position of ``mechanism`` judged by Exudyn (module docstring); ``travel``: the drive's
    travel per coarse step."""
    check_table(mechanism)
    poses, status, residual, turns = continuation(mechanism)
    positions = mechanism.drive.positions
    n = positions.size
    per_row = steps_per_row(mechanism, poses, travel)
    row = row_time(positions, mechanism.drive.speed, mechanism.drive.accel)
    prescribed = _prescribed(mechanism)
    judged = _judge_rows(mechanism, poses, status, per_row, row, turns)
    worst = worst_estimate(judged[0], prescribed, _dead_centre(mechanism, *judged[1:3]))
    if worst > ESTIMATE_LIMIT:
        per_row = 2 * math.ceil(min(per_row * (worst / ESTIMATE_TARGET) ** 0.25, MAX_REFINE * per_row) / 2)
        judged = _judge_rows(mechanism, poses, status, per_row, row, turns)
    rows_out, transmission, transmission_error, status = judged
    status[_dead_centre(mechanism, transmission, transmission_error)] = Status.DEAD_CENTRE.value
    names = list(next((r[0] for r in rows_out if r is not None), {}))
    columns = {name: np.full(n, np.nan) for name in names}
    errors = {name: np.full(n, np.nan) for name in names}
    for i, pair in enumerate(rows_out):
        if pair is not None:
            for name in names:
                columns[name][i], errors[name][i] = pair[0][name], pair[1][name]
    for name, (value, rate, accel) in prescribed.items():
        if name in columns:
            for suffix, exact in (("", value), ("_dot", rate), ("_ddot", accel)):
                ok = np.isfinite(columns[name + suffix])
                columns[name + suffix][ok], errors[name + suffix][ok] = exact[ok], 0.0
    return ExudynLoopTable(mechanism, columns, errors, status, residual)


def _dead_centre(mechanism: LoopMechanism, transmission: np.ndarray, error: np.ndarray) -> np.ndarray:
    """Rows where a given drive effort cannot balance the loads (:mod:`.given`): the transmission within
    its estimate plus ``DEAD_CENTRE_TRANSMISSION`` of its largest value of zero."""
    if solved_load(mechanism) is None or not np.isfinite(transmission).any():
        return np.zeros(transmission.shape, dtype=bool)
    bar = DEAD_CENTRE_TRANSMISSION.value * np.nanmax(np.abs(transmission)) + error
    return np.abs(transmission) <= bar


def _judge_rows(mechanism: LoopMechanism, poses: list, status: np.ndarray, per_row: int, row: float,
                turns: list[int]) -> tuple[list, np.ndarray, np.ndarray, np.ndarray]:
    """Every segment's rows (split at the locks before ``turns``) at ``per_row`` coarse steps between rows
    (:func:`_judge_segment`): the rows, the transmission and its estimate, and the status words
    (``not_converged`` where no run reached a closed row)."""
    n = status.shape[0]
    status = status.copy()
    rows_out: list[tuple[dict, dict] | None] = [None] * n
    transmission, transmission_error = np.full(n, np.nan), np.full(n, np.nan)
    for segment in _segments(status == Status.OK.value, turns):
        for i, answer in _judge_segment(mechanism, poses, segment, per_row, row).items():
            if answer is None:
                status[i] = Status.NOT_CONVERGED.value
                continue
            rows_out[i], (transmission[i], transmission_error[i]) = answer
    return rows_out, transmission, transmission_error, status


def orders(mechanism: LoopMechanism, segment: np.ndarray) -> list[tuple[np.ndarray, float]]:
    """The rows of ``segment`` in the order a run passes them, with the run's drive rate: the table's own
    motion first (the drive passes its positions in time order: by rising position when its rate is
    positive, by falling when negative), then that motion reversed in time (module docstring)."""
    d = mechanism.drive
    x = d.positions[segment]
    rising = bool(x[-1] >= x[0])
    if d.speed == 0.0:
        return [(segment, 0.0)]
    ahead = segment if (d.speed > 0.0) == rising else segment[::-1]
    return [(ahead, d.speed), (ahead[::-1], -d.speed)]


def led(x: np.ndarray) -> np.ndarray:
    """A run's drive positions ``x`` (run order) after a lead row one spacing before the first: every row
    judged then has a row's span of the law on both sides (module docstring, "Runs")."""
    return np.r_[2.0 * x[0] - x[1], x] if x.size > 1 else x


def _run_start(mechanism: LoopMechanism, poses: list, rows: np.ndarray, speed: float, row: float,
               run_in: int) -> Pose | None:
    """The closed pose at the start of the law of a run through ``rows`` (in run order) at ``speed``, carried
    there from the first row's pose (:func:`~.closure.close_along`), or ``None`` where it does not close."""
    law = drive_law(led(mechanism.drive.positions[rows]), speed, mechanism.drive.accel, row, run_in)
    first = mechanism.drive.positions[rows[0]]
    pose, word = close_along(mechanism, poses[rows[0]], first, law.at(0.0)[0])
    return pose if word == Status.OK.value else None


def _inside(mechanism: LoopMechanism, rows: np.ndarray, speed: float, row: float, run_in: int) -> int:
    """The first index ``j`` of ``rows`` (run order) whose run-in from rest starts within the rows: the drive
    travels :math:`|w|\\,T_0/2` in it."""
    x = mechanism.drive.positions[rows]
    travel = abs(speed) * run_in * row / 2.0 + (abs(x[1] - x[0]) if x.size > 1 else 0.0)
    return int(np.searchsorted(np.abs(x - x[0]), travel - 1e-12 * max(travel, 1.0)))


def _judge_segment(mechanism: LoopMechanism, poses: list, segment: np.ndarray, per_row: int,
                   row: float) -> dict[int, tuple[tuple[dict, dict], tuple[float, float]] | None]:
    """Each row of one run of closed rows: its extrapolated row and error estimates with the transmission
    and its estimate, ``None`` where no run reached it (module docstring, "Runs").  First one run through
    every row, the table's motion or its time reversal, whose run-in closes (:func:`run_in_rows`, else
    :data:`~.law.RUN_IN` rows) and whose steps all converge (a long run-in that starts near an edge of
    assembly, where the pose swings faster than the rows' steps allow, fails; the next is tried, and the
    rows a failed run reached are kept); where none does (a table assembled only from or to its ends),
    the table's motion from the first row whose :data:`~.law.RUN_IN` run-in starts within the segment, and
    the time reversal through the rows before it from the far end alike."""
    out: dict[int, tuple | None] = {int(i): None for i in segment}
    plans = [(rows, speed, run_in) for rows, speed in orders(mechanism, segment)
             for run_in in dict.fromkeys((run_in_rows(mechanism), RUN_IN))]
    for rows, speed, run_in in plans:
        start = _run_start(mechanism, poses, rows, speed, row, run_in)
        if start is not None:
            judged = _judged(mechanism, start, rows, speed, per_row, row, run_in)
            out.update({i: a for i, a in judged.items() if out[i] is None})
            if all(a is not None for a in out.values()):
                return out
    for rows, speed in orders(mechanism, segment):
        rows = rows[_inside(mechanism, rows, speed, row, RUN_IN):]
        start = _run_start(mechanism, poses, rows, speed, row, RUN_IN) if rows.size else None
        if start is not None and any(out[int(i)] is None for i in rows):
            judged = _judged(mechanism, start, rows, speed, per_row, row, RUN_IN)
            out.update({i: a for i, a in judged.items() if out[i] is None})
    return out


def _judged(mechanism: LoopMechanism, pose: Pose, rows: np.ndarray, speed: float, per_row: int, row: float,
            run_in: int) -> dict[int, tuple[tuple[dict, dict], tuple[float, float]] | None]:
    """One run through ``rows`` (run order) at ``speed`` from the closed ``pose`` at its law's start, each
    row extrapolated (:mod:`.richardson`); a run reversed in time gives the rates back negated."""
    runs = _runs(mechanism, pose, led(mechanism.drive.positions[rows]), speed, per_row, row, run_in)
    runs = [run[-rows.size:] for run in runs]
    out: dict[int, tuple | None] = {}
    for i, *answers in zip(rows, *runs):
        if any(a is None for a in answers):
            out[int(i)] = None
            continue
        value, error = richardson(*(a for a, _ in answers))
        if speed != mechanism.drive.speed:
            value = {k: -v if k.endswith("_dot") else v for k, v in value.items()}
        out[int(i)] = (value, error), extrapolate(*(g for _, g in answers))
    return out


def _runs(mechanism: LoopMechanism, pose: Pose, rows: np.ndarray, speed: float, per_row: int, row: float,
          run_in: int) -> list[list[tuple[dict, float] | None]]:
    """Each step size's rows (:data:`LEVELS`; drive positions ``rows`` in run order at ``speed``) with the
    transmission of a given drive effort (:mod:`.given`; NaN when the drive's effort is solved)."""
    if solved_load(mechanism) is None:
        runs = (integrate(mechanism, pose, rows, level * per_row, row, run_in, speed) for level in LEVELS)
        return [[None if r is None else (r, math.nan) for r in run] for run in runs]
    zero, unit = variants(mechanism)
    out = []
    for level in LEVELS:
        steps = level * per_row
        pairs = zip(*(integrate(variant, pose, rows, steps, row, run_in, speed) for variant in (zero, unit)))
        out.append([None if a is None or b is None else combine(mechanism, a, b) for a, b in pairs])
    return out


__all__ = ["ExudynLoopTable", "integrate", "settings", "solve_loop", "steps_per_row", "swing"]
