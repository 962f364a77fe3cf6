"""Which assembly a search starts from when no joint of the table gives ``start``: the one nearest zero.

A loop may assemble in several ways at one drive position (an RSSR two; a universal joint beside a ball
two more, its angles ``(theta, eta)`` and ``(theta + 180°, 180° - eta)`` pointing its link the same way; a
general 7R up to sixteen), and a search from random poses finds them in an arbitrary order.  Each engine
searches by its own means (the in-house engine, the Pinocchio judge and the MuJoCo judge: random poses
closed by its own Newton method, never another engine's answer), and each takes, among the distinct
assemblies it closed at the first drive position where it closed any, the one nearest the zero pose:

.. math:: d = \\sum_\\varphi \\operatorname{wrap}(\\varphi)^2, \\qquad
          \\operatorname{wrap}(\\varphi) \\in [-\\pi, \\pi]

over every angle coordinate ``theta_i``, ``eta_i`` of the pose (radians; the balls' rotations do not count).
Poses of equal ``d`` (:data:`SAME_DISTANCE`: assemblies that differ only in their slides) are told apart by
the least sum of their slides squared, and poses equal in that too (an RSSP's two, the slider at ``+s`` and
``-s``) by their coordinates in joint order, the greater first.  Engines whose searches found that assembly
then follow the same one along the drive.  Poses equal in every coordinate (differing only in a ball's
rotation) keep the first found; an assembly that a search misses
(a loop with many assemblies) can make the engines start apart: give the joints' ``start`` values to choose
the assembly (``docs/conventions.md``, "Loop tables", "Closure and branch").
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

#: Name prefixes of the angle coordinates (``theta3``, ``eta2``; ``s4`` is a slide).
ANGLES: tuple[str, ...] = ("theta", "eta")
#: Angle distances this close (relative to ``1 + d``) are one: poses closed to ~1e-14 that differ only in
#: their slides or balls' rotations (an RSSP's two assemblies, the slider either side) have equal angles.
SAME_DISTANCE = 1e-9


def _wrap(name: str, value: float) -> float:
    """``value`` of coordinate ``name``: an angle wrapped to [-pi, pi], a slide as it is."""
    return math.remainder(float(value), 2.0 * math.pi) if _is_angle(name) else float(value)


def _is_angle(name: str) -> bool:
    """Whether coordinate ``name`` (``theta3``, ``eta2``, ``s4``) is an angle."""
    return name.rstrip("0123456789") in ANGLES


def zero_distance(values: Mapping[str, float]) -> float:
    """``d`` of a pose (module docstring): the sum of its wrapped angle coordinates squared, rad²."""
    return sum(_wrap(name, v) ** 2 for name, v in values.items() if _is_angle(name))


def wrapped(values: Mapping[str, float]) -> dict[str, float]:
    """``values`` with every angle coordinate wrapped to [-pi, pi] (the same pose: a search's Newton steps
    may end a turn or more away, and the table then starts there)."""
    return {name: _wrap(name, v) for name, v in values.items()}


def slide_distance(values: Mapping[str, float]) -> float:
    """The sum of a pose's slide coordinates (``s<i>``) squared, in its length unit squared: the tie-break of
    poses whose angles are equally near zero (module docstring)."""
    return sum(float(v) ** 2 for name, v in values.items() if name.rstrip("0123456789") == "s")


def nearest_to_zero(poses: Sequence[Mapping[str, float]]) -> int:
    """The index of the pose of ``poses`` (coordinate name -> value, angles in rad) nearest the zero pose:
    least :func:`zero_distance`; among poses within :data:`SAME_DISTANCE` of it, least
    :func:`slide_distance`; among those, the greatest coordinates in joint order (the first coordinate that
    tells them apart decides: an RSSP's slider on its positive side); then the first.

    Raises
    ------
    ValueError
        If ``poses`` is empty.
    """
    if not poses:
        raise ValueError("poses: expected at least one closed pose to choose from, got none")
    distances = [zero_distance(p) for p in poses]
    tied = _least(list(range(len(poses))), distances)
    tied = _least(tied, [slide_distance(poses[i]) for i in tied])
    for name in sorted(poses[tied[0]], key=lambda n: (int(n.lstrip("abcdefghijklmnopqrstuvwxyz")), n)):
        tied = _least(tied, [-_wrap(name, poses[i][name]) for i in tied])
    return tied[0]


def _least(indices: list[int], keys: list[float]) -> list[int]:
    """The ``indices`` whose ``keys`` are within :data:`SAME_DISTANCE` of the least."""
    least = min(keys)
    return [i for i, k in zip(indices, keys) if k <= least + SAME_DISTANCE * (1.0 + abs(least))]
