"""The Pinocchio judge of any loop table: :func:`solve_loop` gives the in-house engine's columns.

Built from the table alone (:func:`~.model.build_model`), closed by its own search and continuation
(:func:`~.continuation.close_loop`), then per closed position the rates and the constrained inverse dynamics
(:mod:`~.dynamics`); ``dead_centre`` where the solved effort's transmission is below
:data:`~dualmech.core.thresholds.DEAD_CENTRE_TRANSMISSION` (its efforts and reactions NaN).  A Python
loop over the positions: a judge may be slow, it must be independent.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from dualmech.core.status import Status
from dualmech.core.thresholds import DEAD_CENTRE_TRANSMISSION
from dualmech.models.loop.description import LoopMechanism
from dualmech.validation.judges.pinocchio_loop.closure import prescribed_motion
from dualmech.validation.judges.pinocchio_loop.continuation import close_loop
from dualmech.validation.judges.pinocchio_loop.dynamics import (
    PoseDynamics,
    effort_name,
    inverse_dynamics,
    motion,
)
from dualmech.validation.judges.pinocchio_loop.model import build_model


@dataclass(frozen=True)
class PinocchioLoopTable:
    """The judge's answer at the ``n`` drive positions (NaN where ``status`` is not ``ok``).

    Attributes
    ----------
    mechanism : LoopMechanism
    values, rates, accels : dict of name -> numpy.ndarray, shape (n,)
        Every scalar joint coordinate (``theta1``, ``s4``, ``eta3`` ...; angles wrapped to (-pi, pi] at
        the cut joint, continuous in the tree), its rate and acceleration.
    rotations : dict of name -> numpy.ndarray, shape (n, 3, 3)
        Each S joint's rotation (``rotation2`` ...), as :class:`~.dynamics.PoseDynamics` gives it.
    efforts : dict of name -> numpy.ndarray, shape (n,)
        The effort along every scalar coordinate on its link from the previous one.
    force, moment, point : numpy.ndarray, shape (n, J, 3)
        Joint ``i``'s wrench on link ``i`` from link ``i-1`` (world axes, moment about the joint's point),
        and that point: ``docs/conventions.md``, "Loop tables".
    status : numpy.ndarray of str, shape (n,)
    residual : numpy.ndarray, shape (n,)
        Closure residual (lengths over the table's length).
    iterations : numpy.ndarray of int, shape (n,)
    dynamics_residual : numpy.ndarray, shape (n,)
        Relative residual of the inverse dynamics' least squares.
    """

    mechanism: LoopMechanism
    values: dict[str, np.ndarray]
    rates: dict[str, np.ndarray]
    accels: dict[str, np.ndarray]
    rotations: dict[str, np.ndarray]
    efforts: dict[str, np.ndarray]
    force: np.ndarray
    moment: np.ndarray
    point: np.ndarray
    status: np.ndarray
    residual: np.ndarray
    iterations: np.ndarray
    dynamics_residual: np.ndarray

    def coordinate(self, joint: int, name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Value, rate and acceleration ``(n,)`` each of joint ``joint``'s (0-based) coordinate ``name``,
        as :meth:`dualmech.models.loop.engine.LoopAnalysis.coordinate`."""
        key = effort_name(joint, name)
        if key not in self.values:
            raise ValueError(f"coordinate: joint {joint + 1} has no {name!r}; the table has "
                             f"{', '.join(sorted(self.values))}")
        return self.values[key], self.rates[key], self.accels[key]


def _flag(pose: PoseDynamics) -> tuple[PoseDynamics, bool]:
    """The pose with NaN efforts and reactions, and ``True``, where it is a dead centre."""
    if pose.transmission >= DEAD_CENTRE_TRANSMISSION.value:
        return pose, False
    return replace(pose, efforts=dict.fromkeys(pose.efforts, np.nan), force=pose.force * np.nan,
                   moment=pose.moment * np.nan), True


def solve_loop(mechanism: LoopMechanism) -> PinocchioLoopTable:
    """Every drive position of ``mechanism`` judged by Pinocchio (module docstring)."""
    lm = build_model(mechanism)
    closed = close_loop(lm)
    _, rates, accels = prescribed_motion(lm)
    n, status = closed.q.shape[0], closed.status.copy()
    poses = {}
    for i in np.flatnonzero(status == Status.OK.value):
        v, a = motion(lm, closed.q[i], rates[i], accels[i])
        poses[i], dead = _flag(inverse_dynamics(lm, closed.q[i], v, a))
        if dead:
            status[i] = Status.DEAD_CENTRE.value
    first = next(iter(poses.values()), None)
    names = tuple(first.coordinates) if first else ()
    columns = [{name: np.full(n, np.nan) for name in names} for _ in range(4)]
    rotations = {name: np.full((n, 3, 3), np.nan) for name in (first.rotations if first else ())}
    wrench = np.full((3, n, len(mechanism.joints), 3), np.nan)
    dyn_residual = np.full(n, np.nan)
    for i, pose in poses.items():
        for name in names:
            for column, value in zip(columns, (*pose.coordinates[name], pose.efforts[name])):
                column[name][i] = value
        for name, matrix in pose.rotations.items():
            rotations[name][i] = matrix
        wrench[:, i] = pose.force, pose.moment, pose.point
        dyn_residual[i] = pose.residual
    values, rate_columns, accel_columns, efforts = columns
    return PinocchioLoopTable(mechanism, values, rate_columns, accel_columns, rotations, efforts, *wrench,
                              status, closed.residual, closed.iterations, dyn_residual)
