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

import math
from dataclasses import dataclass

import numpy as np

#: Rows apart of the run-in from rest to the first row (in times between rows).
RUN_IN = 2


def _septic(duration: float, start: tuple[float, ...], end: tuple[float, ...]) -> np.ndarray:
    """Coefficients ``c_0 .. c_7`` (of :math:`\\tau^j`) with the value and first three derivatives
    ``start`` at :math:`\\tau = 0` and ``end`` at :math:`\\tau = T`."""
    rows, rhs = [], []
    for tau, values in ((0.0, start), (duration, end)):
        for d, value in enumerate(values):
            rows.append([math.perm(j, d) * tau ** (j - d) if j >= d else 0.0 for j in range(8)])
            rhs.append(value)
    return np.linalg.solve(np.array(rows), np.array(rhs))


@dataclass(frozen=True)
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

    def at(self, t: float) -> tuple[float, float, float]:
        """Value, rate and acceleration of the law at time ``t``."""
        if t >= self.knots[-1]:
            x, w, wd = self.tail
            tau = t - self.knots[-1]
            return x + w * tau + 0.5 * wd * tau * tau, w + wd * tau, wd
        k = int(np.searchsorted(self.knots, t, side="right"))
        tau = t - (self.knots[k - 1] if k else 0.0)
        c = self.pieces[k]
        value = ((((((c[7] * tau + c[6]) * tau + c[5]) * tau + c[4]) * tau + c[3]) * tau + c[2]) * tau
                 + c[1]) * tau + c[0]
        rate = (((((7 * c[7] * tau + 6 * c[6]) * tau + 5 * c[5]) * tau + 4 * c[4]) * tau + 3 * c[3]) * tau
                + 2 * c[2]) * tau + c[1]
        accel = ((((42 * c[7] * tau + 30 * c[6]) * tau + 20 * c[5]) * tau + 12 * c[4]) * tau + 6 * c[3]) * tau \
            + 2 * c[2]
        return float(value), float(rate), float(accel)


def row_time(positions: np.ndarray, speed: float, accel: float) -> float:
    """The time between rows: the median row spacing over the speed (over :math:`\\sqrt{|\\dot w|\\,dx}`, or
    one second, when the drive rests)."""
    spacing = float(np.median(np.abs(np.diff(positions)))) if positions.size > 1 else 0.0
    pace = abs(speed) or math.sqrt(abs(accel) * spacing)
    return spacing / pace if spacing > 0.0 and pace > 0.0 else 1.0


def drive_law(positions: np.ndarray, speed: float, accel: float, row: float) -> Law:
    """The law through ``positions`` (one run's rows, in order) at ``speed`` and ``accel``, ``row`` apart
    in time (module docstring)."""
    m = positions.size
    t0 = RUN_IN * row
    knots = t0 + row * np.arange(m)
    at_row = (speed, accel, 0.0)
    pieces = [_septic(t0, (positions[0] - speed * t0 / 2, 0.0, 0.0, 0.0), (positions[0], *at_row))]
    pieces += [_septic(row, (positions[k - 1], *at_row), (positions[k], *at_row)) for k in range(1, m)]
    return Law(knots, np.array(pieces), (float(positions[-1]), speed, accel))


def axial(law_value: tuple[float, float, float], shift: float, amplitude: float,
          cycles: float) -> tuple[float, float, float]:
    """A C drive's slide by its axial law :math:`S = S_0 + S_S\\sin(c\\,x)` with its rate and acceleration,
    from the angle's value, rate and acceleration."""
    x, w, wd = law_value
    phase = cycles * x
    return (shift + amplitude * math.sin(phase), amplitude * cycles * math.cos(phase) * w,
            amplitude * cycles * (math.cos(phase) * wd - cycles * math.sin(phase) * w * w))
