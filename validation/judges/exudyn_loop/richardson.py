"""The Exudyn judge's rows from its runs (:mod:`.engine`): each quantity averaged over the steps around its
knot, then Richardson-extrapolated from three step sizes, with its error estimate.

The trapezoidal rule's accelerations, and with them the multipliers, carry a component that alternates
from step to step, so each quantity ``X`` of a row is read at its knot's step ``j`` and its two
neighbours, :math:`\\bar X = (X_{j-1} + 2X_j + X_{j+1})/4` (:data:`WEIGHTS`), which cancels it and leaves a
smooth error :math:`c_2 h^2 + c_4 h^4 + \\dots`.  Three runs, with steps ``h``, ``h/2``, ``h/4``, give

.. math:: X_1 = \\frac{4\\bar X_{h/2} - \\bar X_h}{3}, \\quad X = \\frac{4\\bar X_{h/4} - \\bar X_{h/2}}{3},
          \\quad E = \\frac{|X - X_1|}{15}.
"""

from __future__ import annotations

import math

import numpy as np

#: Weights of the steps around a row's knot (binomial: they cancel a step-to-step alternation).
WEIGHTS = np.array([1.0, 2.0, 1.0]) / 4.0


def is_angle(name: str) -> bool:
    """Whether column ``name`` is a joint angle (not its rate): compared within half a turn."""
    return name.startswith(("theta", "eta")) and not name.endswith(("_dot", "_ddot"))


def average(samples: list[dict]) -> dict[str, float]:
    """The samples of one row weighted by :data:`WEIGHTS` (module docstring); angles taken within half a
    turn of the middle sample's (``atan2`` wraps at pi)."""
    middle = samples[len(samples) // 2]
    out = {}
    for key, centre in middle.items():
        values = [centre + math.remainder(s[key] - centre, 2 * math.pi) if is_angle(key) else s[key]
                  for s in samples]
        out[key] = float(sum(w * v for w, v in zip(WEIGHTS, values)))
    return out


def unit_group(name: str) -> str:
    """A column's unit group by its name: ``angle``, ``length`` with ``_dot``, ``_ddot``; ``force`` (a
    slide's effort, ``joint<i>_f*``) or ``moment``."""
    if name.startswith("effort_"):
        return "force" if name[7:].startswith("s") else "moment"
    if name.startswith("joint"):
        return "force" if "_f" in name else "moment"
    base = "length" if name.startswith("s") else "angle"
    return base + next((suffix for suffix in ("_ddot", "_dot") if name.endswith(suffix)), "")


def worst_estimate(rows: list, prescribed: dict, skip: np.ndarray) -> float:
    """The largest Richardson estimate of the rows (``(value, error)`` pairs, ``None`` where not judged; not
    the rows ``skip``, dead centres) over its unit group's largest value (:func:`unit_group`; the prescribed
    coordinates, replaced by their law, left out)."""
    judged = [r for r, dead in zip(rows, skip) if r is not None and not dead]
    exact = {name + suffix for name in prescribed for suffix in ("", "_dot", "_ddot")}
    peaks: dict[str, float] = {}
    worst: dict[str, float] = {}
    for value, error in judged:
        for name, v in value.items():
            group = unit_group(name)
            peaks[group] = max(peaks.get(group, 0.0), abs(v))
            if name not in exact:
                worst[group] = max(worst.get(group, 0.0), error[name])
    return max((w / peaks[g] for g, w in worst.items() if peaks[g] > 0.0), default=0.0)


def extrapolate(coarse: float, middle: float, fine: float) -> tuple[float, float]:
    """:math:`X` and :math:`E` of one quantity from its three runs (module docstring)."""
    first, second = (4.0 * middle - coarse) / 3.0, (4.0 * fine - middle) / 3.0
    return second, abs(second - first) / 15.0


def richardson(coarse: dict[str, float], middle: dict[str, float],
                fine: dict[str, float]) -> tuple[dict, dict]:
    """The row extrapolated from the two finer runs and each column's error estimate from the coarser pair
    (module docstring); angles of the runs taken within half a turn of the finest's."""
    value, error = {}, {}
    for name, c in fine.items():
        a, b = coarse[name], middle[name]
        if is_angle(name):
            a, b = c + math.remainder(a - c, 2.0 * math.pi), c + math.remainder(b - c, 2.0 * math.pi)
        value[name], error[name] = extrapolate(a, b, c)
    return value, error
