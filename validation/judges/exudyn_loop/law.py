"""The prescribed drive law of one Exudyn run: through every row of a run at its table rate and acceleration.

A table states, at every drive position :math:`x_k`, the same rate :math:`w` and acceleration :math:`\\dot w`
(a snapshot, not a trajectory: with :math:`\\dot w \\ne 0` no single motion has both at every row).  The run's
law :math:`x(t)` therefore passes the rows at the knots :math:`t_k = T_0 + k\\,T` (``T`` the time between
rows, :math:`T_0` the run-in) with

.. math:: x(t_k) = x_k, \\quad \\dot x(t_k) = w, \\quad \\ddot x(t_k) = \\dot w, \\quad \\dddot x(t_k) = 0,

a septic Hermite polynomial between two knots (``C^3``, so the integrator's error stays a smooth series in
the step for the Richardson estimate).  The run-in goes from rest, :math:`x(0) = x_0 - w T_0 / 2` with no
rate, acceleration or jerk (a consistent start: the bodies at rest, only gravity and the loads acting), to
the first row; after the last row the law goes on as :math:`x_{last} + w\\tau + \\dot w\\tau^2/2`.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass

import numpy as np

#: The least run-in from rest to the first row, in times between rows (a run-in whose law changes much
#: within few steps leaves an error the undamped rule keeps: 2 rows left 25 times the error of 8).
RUN_IN = 8
#: The law's derivatives matched at every knot (``SMOOTHNESS = 5``: a ``C^5`` law of degree 11).
SMOOTHNESS = 5


def _hermite(duration: float, start: tuple[float, ...], end: tuple[float, ...]) -> np.ndarray:
    """Coefficients ``c_j`` of :math:`u^j`, :math:`u = \\tau/T`, of the polynomial of degree
    ``2 len(start) - 1`` with the value and derivatives ``start`` at :math:`\\tau = 0` and ``end`` at
    :math:`\\tau = T` (derivatives in time: the ``d``-th is scaled by :math:`T^d`)."""
    order = len(start)
    degree = 2 * order
    rows, rhs = [], []
    for u, values in ((0.0, start), (1.0, end)):
        for d, value in enumerate(values):
            rows.append([math.perm(j, d) * u ** (j - d) if j >= d else 0.0 for j in range(degree)])
            rhs.append(value * duration**d)
    return np.linalg.solve(np.array(rows), np.array(rhs))


@dataclass
class Law:
    """The drive law of a run (module docstring).

    Attributes
    ----------
    knots : numpy.ndarray, shape (m,)
        The rows' times :math:`t_k`.
    pieces : numpy.ndarray, shape (m, 8)
        Polynomial coefficients of the run-in (row 0, on :math:`[0, t_0]`) and of each span
        :math:`[t_{k-1}, t_k]` (row ``k``), in the time since the piece's start.
    tail : tuple of float
        ``(x_last, w, w_dot)`` after the last knot.
    """

    knots: np.ndarray
    pieces: np.ndarray
    tail: tuple[float, float, float]
    span: float
    _last: tuple[float, tuple[float, float, float]] | None = None

    def __post_init__(self) -> None:
        self._bounds = [float(t) for t in self.knots]
        self._coefficients = [[float(c) for c in row] for row in self.pieces]

    def at(self, t: float) -> tuple[float, float, float]:
        """Value, rate and acceleration of the law at time ``t`` (the last time's answer is kept: Exudyn
        asks for the same time many times within a step)."""
        if self._last is not None and self._last[0] == t:
            return self._last[1]
        bounds = self._bounds
        if t >= bounds[-1]:
            x, w, wd = self.tail
            tau = t - bounds[-1]
            out = (x + w * tau + 0.5 * wd * tau * tau, w + wd * tau, wd)
        else:
            k = bisect.bisect_right(bounds, t)
            duration = bounds[0] if k == 0 else self.span
            u = (t - (bounds[k - 1] if k else 0.0)) / duration
            value = rate = accel = 0.0
            for c in reversed(self._coefficients[k]):  # Horner for the value and both derivatives in u
                accel = accel * u + 2.0 * rate
                rate = rate * u + value
                value = value * u + c
            out = (value, rate / duration, accel / duration**2)
        self._last = (t, out)
        return out


def row_time(positions: np.ndarray, speed: float, accel: float) -> float:
    """The time between rows: the median row spacing over the speed (over :math:`\\sqrt{|\\dot w|\\,dx}`, or
    one second, when the drive rests)."""
    spacing = float(np.median(np.abs(np.diff(positions)))) if positions.size > 1 else 0.0
    pace = abs(speed) or math.sqrt(abs(accel) * spacing)
    return spacing / pace if spacing > 0.0 and pace > 0.0 else 1.0


def drive_law(positions: np.ndarray, speed: float, accel: float, row: float, run_in: int = RUN_IN) -> Law:
    """The law through ``positions`` (one run's rows, in order) at ``speed`` and ``accel``, ``row`` apart
    in time, after a run-in of ``run_in`` rows' time (module docstring)."""
    m = positions.size
    t0 = run_in * row
    knots = t0 + row * np.arange(m)
    at_row = (speed, accel) + (0.0,) * (SMOOTHNESS - 2)
    rest = (positions[0] - speed * t0 / 2,) + (0.0,) * SMOOTHNESS
    pieces = [_hermite(t0, rest, (positions[0], *at_row))]
    pieces += [_hermite(row, (positions[k - 1], *at_row), (positions[k], *at_row)) for k in range(1, m)]
    return Law(knots, np.array(pieces), (float(positions[-1]), speed, accel), row)


def axial(law_value: tuple[float, float, float], shift: float, amplitude: float,
          cycles: float) -> tuple[float, float, float]:
    """A C drive's slide by its axial law :math:`S = S_0 + S_S\\sin(c\\,x)` with its rate and acceleration,
    from the angle's value, rate and acceleration."""
    x, w, wd = law_value
    phase = cycles * x
    return (shift + amplitude * math.sin(phase), amplitude * cycles * math.cos(phase) * w,
            amplitude * cycles * (math.cos(phase) * wd - cycles * math.sin(phase) * w * w))
