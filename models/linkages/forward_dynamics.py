"""Forward dynamics of a one-degree-of-freedom linkage from its own inverse dynamics (generalized inertia).

The drive torque the in-house engine returns for a given load (output-torque mode) is affine in the
input acceleration and quadratic in its rate:

.. math:: \\tau(\\theta, \\dot\\theta, \\ddot\\theta) = I(\\theta)\\,\\ddot\\theta
          + C(\\theta)\\,\\dot\\theta^2 + Q(\\theta)

so three inverse-dynamics solves per crank angle give the generalized inertia :math:`I`, the
velocity coefficient :math:`C = \\tfrac12 I'` and the load term :math:`Q` (gravity and the given
output torque), batched over a grid of angles.  Given a drive torque :math:`\\tau_d` the motion is
:math:`\\ddot\\theta = (\\tau_d - C\\dot\\theta^2 - Q)/I`, integrated by ``scipy``'s DOP853 on periodic
cubic splines of the coefficients (an RSSR case whose input turns fully).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicSpline

from dualmech.core.motion import CrankState
from dualmech.core.status import Status
from dualmech.models.linkages.rssr import analyze_rssr
from dualmech.models.linkages.rssr_case import RssrCase


@dataclass(frozen=True)
class Coefficients:
    """``theta`` ``(m,)`` rad (a full turn) and ``inertia``, ``velocity``, ``load`` there: the drive torque
    is ``inertia * theta_ddot + velocity * theta_dot^2 + load``."""

    theta: np.ndarray
    inertia: np.ndarray
    velocity: np.ndarray
    load: np.ndarray


def coefficients(case: RssrCase, points: int = 721) -> Coefficients:
    """:class:`Coefficients` of ``case`` at ``points`` crank angles over a turn (output-torque mode: the
    case's output torque and gravity are the load).  Raises ``ValueError`` if the linkage does not
    assemble (or reaches an edge of assembly) somewhere on the turn: its input cannot turn fully."""
    if case.mode != "output":
        raise ValueError("coefficients: the drive torque is the unknown of the inverse dynamics here; give "
                         f"loads.output_torque (got drive_torque = {case.drive_torque!r})")
    theta = np.linspace(0.0, 2 * np.pi, points)
    n = points
    rates = np.concatenate([np.zeros(n), np.ones(n), np.zeros(n)])
    accels = np.concatenate([np.zeros(n), np.zeros(n), np.ones(n)])
    zero = np.zeros(3 * n)
    crank = CrankState(np.tile(theta, 3), zero, rates, zero, accels, zero)
    an = analyze_rssr(case, crank=crank)
    if not (an.status == Status.OK).all():
        raise ValueError(f"coefficients: {case.name!r} does not turn fully (statuses "
                         f"{sorted(set(an.status))}); forward dynamics needs a crank that does")
    torque = an.reactions.moment["j1"][:, 2].reshape(3, n)
    torque[:, -1] = torque[:, 0]  # 2 pi is 0: the same pose, equal to rounding
    return Coefficients(theta, torque[2] - torque[0], torque[1] - torque[0], torque[0])


def simulate(case: RssrCase, drive_torque: float, times: np.ndarray,
             coeffs: Coefficients | None = None) -> np.ndarray:
    """The crank's motion under a constant ``drive_torque`` from the case's first angle and speed, at
    ``times`` ``(m,)`` s (increasing, from 0): states ``(m, 2)`` (``theta1`` rad, ``theta1_dot`` rad/s),
    DOP853 at ``rtol = atol = 1e-12``."""
    c = coefficients(case) if coeffs is None else coeffs
    splines = [CubicSpline(c.theta, v, bc_type="periodic") for v in (c.inertia, c.velocity, c.load)]

    def rhs(_: float, y: np.ndarray) -> list[float]:
        angle = np.mod(y[0], 2 * np.pi)
        inertia, velocity, load = (float(s(angle)) for s in splines)
        return [y[1], (drive_torque - velocity * y[1] ** 2 - load) / inertia]

    start = [np.radians(case.motion.angles_deg[0]), case.motion.speed]
    sol = solve_ivp(rhs, (0.0, float(times[-1])), start, method="DOP853", t_eval=times, rtol=1e-12,
                    atol=1e-12)
    return sol.y.T


def energy(case: RssrCase, theta: np.ndarray, theta_dot: np.ndarray) -> np.ndarray:
    """Kinetic plus potential energy, ``sum(1/2 m v_G^2 + 1/2 omega · I omega - m g · G)`` of the three
    links at the states ``(n,)``."""
    zero = np.zeros_like(theta)
    an = analyze_rssr(replace(case, gravity=np.zeros(3)),
                      crank=CrankState(theta, zero, theta_dot, zero, zero, zero))
    total = np.zeros_like(theta)
    for body, m in zip(case.bodies, an.motions):
        i_world = m.rotation @ body.inertia @ np.swapaxes(m.rotation, 1, 2)
        total += 0.5 * body.mass * np.einsum("ni,ni->n", m.com_vel, m.com_vel)
        total += 0.5 * np.einsum("ni,nij,nj->n", m.omega, i_world, m.omega) - body.mass * m.com @ case.gravity
    return total
