"""Which assembly a search starts from when no joint of the table gives ``start``: the one nearest zero.

A loop may assemble in several ways at one drive position (an RSSR two; a universal joint beside a ball
two more, its angles ``(theta, eta)`` and ``(theta + 180°, 180° - eta)`` pointing its link the same way; a
general 7R up to sixteen), and a search from random poses finds them in an arbitrary order.  Each engine
searches by its own means (the in-house engine, the Pinocchio judge and the MuJoCo judge: random poses
closed by its own Newton method, never another engine's answer), and each takes, among the distinct
assemblies it closed at the first drive position where it closed any, the one nearest the zero pose:

.. math:: d = \\sum_\\varphi \\operatorname{wrap}(\\varphi)^2, \\qquad
          \\operatorname{wrap}(\\varphi) \\in [-\\pi, \\pi]

over every angle coordinate ``theta_i``, ``eta_i`` of the pose (radians; slides and the balls' rotations do
not count).  Engines whose searches found that assembly then follow the same one along the drive.  Equal
distances (a loop symmetric about its zero pose) keep the first found; an assembly that a search misses
(a loop with many assemblies) can make the engines start apart: give the joints' ``start`` values to choose
the assembly (``docs/conventions.md``, "Loop tables", "Closure and branch").
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

#: Name prefixes of the angle coordinates (``theta3``, ``eta2``; ``s4`` is a slide).
ANGLES: tuple[str, ...] = ("theta", "eta")


def zero_distance(values: Mapping[str, float]) -> float:
    """``d`` of a pose (module docstring): the sum of its wrapped angle coordinates squared, rad²."""
    total = 0.0
    for name, value in values.items():
        if name.rstrip("0123456789") in ANGLES:
            wrapped = math.remainder(float(value), 2.0 * math.pi)
            total += wrapped * wrapped
    return total


def wrapped(values: Mapping[str, float]) -> dict[str, float]:
    """``values`` with every angle coordinate wrapped to [-pi, pi] (the same pose: a search's Newton steps
    may end a turn or more away, and the table then starts there)."""
    return {name: (math.remainder(float(v), 2.0 * math.pi) if name.rstrip("0123456789") in ANGLES
                   else float(v)) for name, v in values.items()}


def nearest_to_zero(poses: Sequence[Mapping[str, float]]) -> int:
    """The index of the pose of ``poses`` (coordinate name -> value, angles in rad) nearest the zero pose
    (:func:`zero_distance`; the first of equal ones).

    Raises
    ------
    ValueError
        If ``poses`` is empty.
    """
    if not poses:
        raise ValueError("poses: expected at least one closed pose to choose from, got none")
    distances = [zero_distance(p) for p in poses]
    return distances.index(min(distances))
