"""Prescribed crank motion: angle, axial position and their rates at each crank position.

The crank rotates about the world z axis and slides along it (cylindrical
joint 1).  At every tabulated crank angle the state is a snapshot
(:math:`\\theta_1, \\dot\\theta_1, \\ddot\\theta_1`) with the same speed and
acceleration, as in the thesis's worked example, and the axial position
follows thesis eq. (27)-(28), with a constant part added:

.. math::
    S_1 = S_{1,0} + S_{S1} \\sin(\\alpha\\theta_1)

    \\dot S_1 = S_{S1}\\,\\alpha \\cos(\\alpha\\theta_1)\\,\\dot\\theta_1

    \\ddot S_1 = S_{S1}\\,\\alpha\\,[\\cos(\\alpha\\theta_1)\\ddot\\theta_1
                 - \\alpha \\sin(\\alpha\\theta_1)\\dot\\theta_1^2]

(eq. 28a prints :math:`S_1` where the amplitude :math:`S_{S1}` belongs; see
``docs/errata.md`` E7.)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dualmech.core.dual import scalar_type


@dataclass(frozen=True)
class CrankState:
    """Crank joint coordinates and rates at each position; every field has shape ``(n,)``.

    ``theta`` [rad], ``s`` [length], ``theta_dot`` [rad/s], ``s_dot`` [length/s],
    ``theta_ddot`` [rad/s^2], ``s_ddot`` [length/s^2].
    """

    theta: np.ndarray
    s: np.ndarray
    theta_dot: np.ndarray
    s_dot: np.ndarray
    theta_ddot: np.ndarray
    s_ddot: np.ndarray

    def __len__(self) -> int:
        return self.theta.shape[0]

    def take(self, index: np.ndarray | slice) -> "CrankState":
        """The state at a subset of positions."""
        return CrankState(*(getattr(self, f)[index] for f in self.__dataclass_fields__))


@dataclass(frozen=True)
class CrankMotion:
    """How the crank is driven (the ``[motion]`` table of a case).

    Attributes
    ----------
    angles_deg : numpy.ndarray, shape (n,)
        Crank angles at which the mechanism is analysed, degrees.
    speed : float
        :math:`\\dot\\theta_1`, rad/s (from ``crank_rpm``).
    accel : float
        :math:`\\ddot\\theta_1`, rad/s^2.
    axial_amplitude, axial_cycles : float
        :math:`S_{S1}` and :math:`\\alpha` of eq. (27)-(28).
    """

    angles_deg: np.ndarray
    speed: float
    accel: float = 0.0
    axial_amplitude: float = 0.0
    axial_cycles: float = 0.0

    def state(self, axial_shift: float, angles_deg: np.ndarray | None = None) -> CrankState:
        """Crank state at ``angles_deg`` (default: the case's angles) for constant shift :math:`S_{1,0}`."""
        deg = self.angles_deg if angles_deg is None else np.asarray(angles_deg, dtype=float)
        theta = np.radians(deg)
        n = theta.shape[0]
        # numpy scalars: overflow gives inf, not an error
        w, wd = (np.asarray(v, dtype=scalar_type(v))[()] for v in (self.speed, self.accel))
        return self.at(axial_shift, theta, np.full(n, w), np.full(n, wd))

    def at(self, axial_shift: float, theta: np.ndarray, theta_dot: np.ndarray,
           theta_ddot: np.ndarray) -> CrankState:
        """Crank state of any motion :math:`\theta_1(t)`, with :math:`S_1` following it (eq. 27-28).

        ``theta`` [rad], ``theta_dot`` [rad/s], ``theta_ddot`` [rad/s^2], each ``(n,)`` (or
        broadcastable to ``theta``'s shape); the one home of the axial law
        :math:`S_1(\theta_1)` (module docstring) and its rates.
        """
        theta = np.asarray(theta, dtype=scalar_type(theta))
        w = np.broadcast_to(np.asarray(theta_dot, dtype=scalar_type(theta_dot)), theta.shape).copy()
        wd = np.broadcast_to(np.asarray(theta_ddot, dtype=scalar_type(theta_ddot)), theta.shape).copy()
        amp, cyc = self.axial_amplitude, self.axial_cycles
        phase = cyc * theta
        s = axial_shift + amp * np.sin(phase)
        with np.errstate(over="ignore", invalid="ignore"):  # engines flag such rows not_finite
            s_dot = amp * cyc * np.cos(phase) * w
            s_ddot = amp * cyc * (np.cos(phase) * wd - cyc * np.sin(phase) * w**2)
        return CrankState(theta, s, w, s_dot, wd, s_ddot)
