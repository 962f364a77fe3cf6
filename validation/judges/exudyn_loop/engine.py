"""The Exudyn judge of any loop table: its own closure, then Exudyn's dynamic runs with the drive prescribed.

**Rows.**  The judge closes the loop at every drive position itself (:mod:`.closure`); each maximal run of
consecutive closed rows is one Exudyn run (:mod:`.model`), from rest at the start of its law's run-in
(:mod:`.law`) through all its rows; rows that do not close keep the closure's word, rows of a run whose
Newton iteration fails are ``not_converged``.

**Integrator.**  Newmark's method with :math:`\\beta = 1/4`, :math:`\\gamma = 1/2` (the trapezoidal rule,
spectral radius 1: no numerical damping), index-2 (velocity-level) constraints, Newton to a relative
residual of :data:`NEWTON_TOL`.  Exudyn's default, index-3 generalized-alpha, needs a spectral radius below
1 and gives multipliers polluted by the position-level constraint's :math:`1/h^2` scaling.

**Rows from a run.**  The trapezoidal rule's accelerations, and with them the multipliers, carry a
component that alternates from step to step (:math:`a_{j+1} = 2(v_{j+1} - v_j)/h - a_j` keeps any error
of the start's accelerations with factor -1), so each quantity ``X`` of a row is read at its knot's step
``j`` and its two neighbours, :math:`\\bar X = (X_{j-1} + 2X_j + X_{j+1})/4`, which cancels it and leaves an
error :math:`c\\,h^2 + O(h^4)`.  Two runs, ``h`` and ``h/2`` (:data:`STEPS_PER_ROW` steps between rows and
twice that), then give the Richardson extrapolation and its error estimate

.. math:: X = \\frac{4\\bar X_{h/2} - \\bar X_h}{3}, \\qquad E = \\frac{|\\bar X_{h/2} - \\bar X_h|}{3}

(``E`` estimates the error of :math:`\\bar X_{h/2}`; that of ``X`` is of higher order).  A prescribed
coordinate is its law's value, rate and acceleration.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import exudyn as exu
import numpy as np

from dualmech.core.status import Status
from dualmech.models.loop.description import LoopMechanism
from dualmech.validation.judges.exudyn_loop.closure import close_at, continuation
from dualmech.validation.judges.exudyn_loop.law import axial, drive_law, row_time
from dualmech.validation.judges.exudyn_loop.model import build_system
from dualmech.validation.judges.exudyn_loop.readout import read_row

#: Steps between two rows of the coarse run (the fine run takes twice as many).
STEPS_PER_ROW = 32
#: Newton's relative residual tolerance in every step.
NEWTON_TOL = 1e-12


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


def settings(steps: int, end_time: float) -> exu.SimulationSettings:
    """Exudyn's settings of one run (module docstring): nothing written to files."""
    ss = exu.SimulationSettings()
    ss.solution.file.write = False
    ss.solution.sensors.active = False
    ss.timeIntegration.numberOfSteps = steps
    ss.timeIntegration.endTime = end_time
    ss.timeIntegration.verboseMode = 0
    ss.timeIntegration.adaptiveStep = False
    alpha = ss.timeIntegration.generalizedAlpha
    alpha.useNewmark, alpha.useIndex2Constraints, alpha.spectralRadius = True, True, 1.0
    alpha.newmarkBeta, alpha.newmarkGamma = 0.25, 0.5
    ss.timeIntegration.newton.relativeTolerance = NEWTON_TOL
    ss.timeIntegration.newton.absoluteTolerance = 1e-14
    return ss


def _average(samples: list[dict]) -> dict[str, float]:
    before, at, after = samples
    return {key: (before[key] + 2.0 * at[key] + after[key]) / 4.0 for key in at}


def integrate(mechanism: LoopMechanism, pose, rows: np.ndarray, per_row: int,  # noqa: ANN001
              row: float) -> list[dict | None]:
    """One Exudyn run from rest at ``pose`` (closed at the law's start) through the drive positions
    ``rows``, ``per_row`` steps between two rows, ``row`` apart in time: each row's averaged quantities
    (module docstring), ``None`` for the rows after a failed step."""
    d = mechanism.drive
    law = drive_law(rows, d.speed, d.accel, row)
    loop = build_system(mechanism, pose, law)
    h = row / per_row
    knots = [int(round(t / h)) for t in law.knots]
    wanted = {j + offset: (m, offset + 1) for m, j in enumerate(knots) for offset in (-1, 0, 1)}
    samples: list[list] = [[None, None, None] for _ in knots]

    def pre_step(mbs: exu.MainSystem, t: float) -> bool:
        j = int(round(mbs.systemData.GetTime() / h)) - 1  # the step's end time; the state is its start's
        if j in wanted:
            m, slot = wanted[j]
            samples[m][slot] = read_row(loop)
        return True

    loop.mbs.SetPreStepUserFunction(pre_step)
    steps = knots[-1] + 2
    try:
        loop.mbs.SolveDynamic(settings(steps, steps * h))
    except RuntimeError:
        pass
    return [_average(s) if all(x is not None for x in s) else None for s in samples]


def _prescribed(mechanism: LoopMechanism) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Value, rate and acceleration of each prescribed coordinate at every row."""
    d = mechanism.drive
    x = d.positions
    out = {f"{d.coordinate}{d.joint + 1}": (x, np.full_like(x, d.speed), np.full_like(x, d.accel))}
    if len(mechanism.prescribed) == 2:
        slide = [axial((xi, d.speed, d.accel), d.axial_shift, d.axial_amplitude, d.axial_cycles) for xi in x]
        out[f"s{d.joint + 1}"] = tuple(np.array(c) for c in zip(*slide))
    return out


def _segments(ok: np.ndarray) -> list[np.ndarray]:
    """Maximal runs of consecutive ``True`` rows, as index arrays."""
    edges = np.flatnonzero(np.diff(np.r_[0, ok.astype(int), 0]))
    return [np.arange(a, b) for a, b in zip(edges[::2], edges[1::2])]


def solve_loop(mechanism: LoopMechanism, per_row: int = STEPS_PER_ROW) -> ExudynLoopTable:
    """Every drive position of ``mechanism`` judged by Exudyn (module docstring)."""
    poses, status, residual = continuation(mechanism)
    positions = mechanism.drive.positions
    n = positions.size
    row = row_time(positions, mechanism.drive.speed, mechanism.drive.accel)
    rows_out: list[tuple[dict, dict] | None] = [None] * n
    for segment in _segments(status == Status.OK.value):
        law = drive_law(positions[segment], mechanism.drive.speed, mechanism.drive.accel, row)
        pose, word, _ = close_at(mechanism, poses[segment[0]], law.at(0.0)[0])
        if word != Status.OK.value:
            status[segment] = Status.NOT_CONVERGED.value
            continue
        coarse = integrate(mechanism, pose, positions[segment], per_row, row)
        fine = integrate(mechanism, pose, positions[segment], 2 * per_row, row)
        for i, a, b in zip(segment, coarse, fine):
            if a is None or b is None:
                status[i] = Status.NOT_CONVERGED.value
                continue
            rows_out[i] = _richardson(a, b)
    names = list(next((r[0] for r in rows_out if r is not None), {}))
    columns = {name: np.full(n, np.nan) for name in names}
    errors = {name: np.full(n, np.nan) for name in names}
    for i, pair in enumerate(rows_out):
        if pair is not None:
            for name in names:
                columns[name][i], errors[name][i] = pair[0][name], pair[1][name]
    for name, (value, rate, accel) in _prescribed(mechanism).items():
        if name in columns:
            for suffix, exact in (("", value), ("_dot", rate), ("_ddot", accel)):
                ok = np.isfinite(columns[name + suffix])
                columns[name + suffix][ok] = exact[ok]
    return ExudynLoopTable(mechanism, columns, errors, status, residual)


def _richardson(coarse: dict[str, float], fine: dict[str, float]) -> tuple[dict, dict]:
    """The extrapolated row and each column's error estimate (module docstring); angles of the two runs
    taken within half a turn of each other."""
    value, error = {}, {}
    for name, b in fine.items():
        a = coarse[name]
        if name.startswith(("theta", "eta")) and not name.endswith(("_dot", "_ddot")):
            a = b + math.remainder(a - b, 2.0 * math.pi)
        value[name], error[name] = (4.0 * b - a) / 3.0, abs(b - a) / 3.0
    return value, error


__all__ = ["ExudynLoopTable", "integrate", "settings", "solve_loop"]
