"""A :class:`~dualmech.models.loop.description.LoopMechanism` as the generic link-joint table
:class:`dualmech.core.loop.Loop`, with its inputs and its start pose.

Joint ``i`` (0-based) becomes row ``i``,
:math:`Z(\\theta_i + \\varepsilon S_i)Y(\\eta_i)X(\\alpha_i + \\varepsilon a_i)` (thesis eq. 1-4): an R
row has ``theta`` unknown and ``s`` constant, a P row ``s`` unknown and ``theta`` constant, a C row both
unknown, a U row ``theta`` and ``eta`` unknown (its second axis is the y axis the first rotation turned:
perpendicular to the first and intersecting it), an S row a free rotation (not the thesis's Z-Y angles,
errata E2).  The
driven coordinates are inputs instead (a C joint driven by its angle: both).  Each S row followed by
an S row gets the zero-spin gauge (:func:`~dualmech.models.loop.mobility.idle_spins`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dualmech.core.loop import Loop, LoopState, Row, Var, inp, rodrigues, unk
from dualmech.core.motion import CrankMotion
from dualmech.models.loop.description import LoopMechanism
from dualmech.models.loop.mobility import idle_spins

#: The parameter holding the loop's length scale (``core/loop.py``: the dual residual is divided by it).
SCALE = "length_scale"


def variable(joint: int, coordinate: str) -> str:
    """Name of joint ``joint``'s (0-based) ``coordinate`` (``theta``, ``s`` or ``eta``) in the table, e.g.
    ``theta1`` for the first joint's angle (joints numbered from 1, as the thesis does)."""
    return f"{coordinate}{joint + 1}"


def to_loop(mechanism: LoopMechanism) -> Loop:
    """The generic table of ``mechanism`` (module docstring)."""
    prescribed = set(mechanism.prescribed)

    def slot(i: int, coordinate: str) -> Var:
        return (inp if (i, coordinate) in prescribed else unk)(variable(i, coordinate))

    rows = []
    for i, j in enumerate(mechanism.joints):
        name = f"joint{i + 1}"
        if j.type == "S":
            rows.append(Row(name, spherical=True, alpha=j.alpha, a=j.a))
            continue
        theta = slot(i, "theta") if j.type != "P" else j.theta
        s = slot(i, "s") if j.type in ("P", "C") else j.s
        eta = slot(i, "eta") if j.type == "U" else 0.0
        rows.append(Row(name, theta=theta, s=s, eta=eta, alpha=j.alpha, a=j.a))
    return Loop(tuple(rows), spin_gauges=idle_spins(mechanism.joints), length_scale=SCALE)


@dataclass(frozen=True)
class DriveState:
    """The prescribed coordinates at ``n`` positions: per input name of :func:`to_loop`, its value, rate and
    acceleration, each ``(n,)``."""

    values: dict[str, np.ndarray]
    rates: dict[str, np.ndarray]
    accels: dict[str, np.ndarray]

    def take(self, index: np.ndarray | slice) -> "DriveState":
        """The state at a subset of positions."""
        parts = (self.values, self.rates, self.accels)
        return DriveState(*({k: v[index] for k, v in d.items()} for d in parts))


def drive_state(mechanism: LoopMechanism, positions: np.ndarray | None = None,
                rates: np.ndarray | None = None, accels: np.ndarray | None = None) -> DriveState:
    """Prescribed values and rates at the drive's positions, plus the length-scale parameter.

    ``positions``, ``rates``, ``accels`` ``(n,)``: the driven coordinate with its own rate and acceleration
    at each position (a simulated motion's); default the drive's positions, speed and acceleration.  A C
    joint driven by its angle gets its slide from the axial law of
    :meth:`dualmech.core.motion.CrankMotion.at` (thesis eq. 27-28, errata E7).
    """
    d = mechanism.drive
    x = d.positions if positions is None else np.asarray(positions, dtype=float)
    n = x.shape[0]
    speed = np.full(n, d.speed) if rates is None else np.asarray(rates, dtype=float)
    accel = np.full(n, d.accel) if accels is None else np.asarray(accels, dtype=float)
    name = variable(d.joint, d.coordinate)
    values, rates_, accels_ = {name: x}, {name: speed}, {name: accel}
    if mechanism.joints[d.joint].type == "C":
        law = CrankMotion(np.degrees(x), d.speed, d.accel, d.axial_amplitude, d.axial_cycles)
        crank = law.at(d.axial_shift, x, speed, accel)
        slide = variable(d.joint, "s")
        values[slide], rates_[slide], accels_[slide] = crank.s, crank.s_dot, crank.s_ddot
    values[SCALE] = np.full(n, mechanism.length)
    return DriveState(values, rates_, accels_)


def start_state(mechanism: LoopMechanism, loop: Loop) -> LoopState:
    """The joints' ``start`` values as a one-position :class:`~dualmech.core.loop.LoopState` (zeros, and
    identity rotations, where a joint gives none)."""
    scalars = dict.fromkeys(loop.unknowns, 0.0)
    rotations = []
    for i, j in enumerate(mechanism.joints):
        if j.type == "S":
            rotations.append(rodrigues(np.asarray(j.start or (0.0, 0.0, 0.0), dtype=float)))
            continue
        names = {"R": ("theta",), "P": ("s",), "C": ("theta", "s"), "U": ("theta", "eta")}[j.type]
        for coordinate, value in zip(names, j.start or (0.0,) * len(names)):
            key = variable(i, coordinate)
            if key in scalars:
                scalars[key] = value
    return LoopState(np.array([[scalars[k] for k in loop.unknowns]], dtype=float).reshape(1, -1),
                     np.array(rotations, dtype=float).reshape(1, len(rotations), 3, 3))


__all__ = ["SCALE", "variable", "to_loop", "DriveState", "drive_state", "start_state"]
