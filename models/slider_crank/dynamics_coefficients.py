"""Coefficients of the crank's equation of motion, tabulated from the in-house solver.

The generalized inertia :math:`I(\\psi)`, its derivative :math:`I'`, the gravity force
:math:`\\tau^G`, :math:`S_4` and :math:`S_4' = dS_4/d\\psi` (``core/generalized_inertia.py``,
Sinatra–Angeles eq. 39–43, in space) come from the in-house velocity and acceleration
analysis at :math:`\\dot\\psi = 1`, :math:`\\ddot\\psi = 0` (``models/slider_crank/analysis.py``).
With a universal joint at the slider (``[joints] rod_slider``) the rod's angular velocity there includes
the spin the joint fixes, so its axial inertia enters :math:`I` (the IFToMM benchmark's energy,
``tests/models/slider_crank/test_iftomm.py``); with two ball joints the zero-spin gauge leaves it out.
One in-house call costs milliseconds, so for a periodic mechanism they are sampled at ``N``
crank angles and evaluated by their trigonometric interpolant; ``N`` doubles until the
interpolant matches fresh in-house values at the ``N`` midpoints to ``interpolation_tol``
(relative), which converges geometrically for these analytic periodic functions (``N`` =
128–256 for the bundled cases).  A non-periodic axial motion (non-integer ``axial_cycles``)
falls back to calling the in-house solver at every evaluation (:class:`CoefficientModel`).
:mod:`dualmech.models.slider_crank.forward_dynamics` integrates the equation.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from dualmech.core import generalized_inertia as gi
from dualmech.core.assembly import reach
from dualmech.core.status import RATES_GIVEN, is_status
from dualmech.models.angle_ranges import format_angle_ranges, no_assembly_ranges
from dualmech.models.case import Case
from dualmech.models.mechanism import crank_pin
from dualmech.models.slider_crank.analysis import Analysis, analyze

#: Largest number of samples of the coefficient table before falling back to direct evaluation.
MAX_TABLE_SIZE = 2**15
#: Names of the tabulated coefficients, in row order.
COEFFICIENT_NAMES = ("inertia", "inertia_derivative", "gravity_force", "s4", "s4_rate")


def influence_coefficients(an: Analysis) -> tuple[np.ndarray, np.ndarray, gi.InfluenceCoefficients]:
    """Masses ``(3,)``, world inertias ``(3, n, 3, 3)`` and influence coefficients of an analysis.

    ``an`` must have been computed with :math:`\\dot\\psi = 1, \\ddot\\psi = 0`
    (:meth:`~dualmech.models.case.Case.crank_state` with those rates): its centre-of-mass velocities and
    angular velocities are then the influence coefficients and its accelerations
    their :math:`\\psi`-derivatives.
    """
    bodies = an.case.bodies.ordered
    masses = np.array([b.mass for b in bodies])
    inertia = np.stack([m.rotation @ b.inertia @ np.swapaxes(m.rotation, 1, 2)
                        for b, m in zip(bodies, an.motions)])
    coeffs = gi.InfluenceCoefficients(
        com_rate=np.stack([m.com_vel for m in an.motions]),
        omega_rate=np.stack([m.omega for m in an.motions]),
        com_rate_prime=np.stack([m.com_acc for m in an.motions]),
        omega_rate_prime=np.stack([m.omega_dot for m in an.motions]),
    )
    return masses, inertia, coeffs


@dataclass(frozen=True)
class Coefficients:
    """ODE coefficients at ``n`` crank angles, each ``(n,)`` (rows of :data:`COEFFICIENT_NAMES`).

    ``inertia`` :math:`I`, ``inertia_derivative`` :math:`I'`, ``gravity_force``
    :math:`\\tau^G`, ``s4`` :math:`S_4`, ``s4_rate`` :math:`S_4'`; ``status`` the in-house status words.
    """

    theta: np.ndarray
    inertia: np.ndarray
    inertia_derivative: np.ndarray
    gravity_force: np.ndarray
    s4: np.ndarray
    s4_rate: np.ndarray
    status: np.ndarray

    def stacked(self) -> np.ndarray:
        """The coefficient rows as one ``(5, n)`` array."""
        return np.stack([getattr(self, name) for name in COEFFICIENT_NAMES])


def coefficients(case: Case, theta: np.ndarray) -> Coefficients:
    """Generalized inertia, its derivative, gravity force and slider rate from the in-house solver."""
    theta = np.atleast_1d(np.asarray(theta, dtype=float))
    n = theta.shape[0]
    an = analyze(case, case.crank_state(theta, np.ones(n), np.zeros(n)))
    masses, inertia, coeffs = influence_coefficients(an)
    return Coefficients(
        theta=theta,
        inertia=gi.generalized_inertia(masses, inertia, coeffs),
        inertia_derivative=gi.generalized_inertia_derivative(masses, inertia, coeffs),
        gravity_force=gi.gravity_force(masses, case.loads.gravity, coeffs),
        s4=an.s4,
        s4_rate=an.rates.q_dot[:, 0],
        status=an.status,
    )


def _checked(case: Case, theta: np.ndarray) -> np.ndarray:
    """Coefficient rows ``(5, n)``; ValueError where the mechanism cannot be assembled."""
    c = coefficients(case, theta)
    bad = ~is_status(c.status, *RATES_GIVEN)
    if bad.any():
        deg = np.degrees(np.mod(theta, 2 * np.pi))
        order = np.argsort(deg)
        where = format_angle_ranges(no_assembly_ranges(deg[order], bad[order]))
        raise ValueError(f"case {case.name}: the crank cannot turn through {where} deg "
                         f"({', '.join(sorted(set(c.status[bad])))}); forward dynamics needs a full "
                         "revolution")
    return c.stacked()


class TrigInterpolant:
    """Trigonometric interpolant of 2π-periodic samples ``(F, N)`` at ``theta_j = 2πj/N`` (``N`` even)."""

    def __init__(self, samples: np.ndarray) -> None:
        n = samples.shape[1]
        c = np.fft.rfft(samples, axis=1) / n
        c[:, 1:(n + 1) // 2] *= 2.0
        self.coefficients = c
        self.size = n
        self._k = np.arange(c.shape[1])

    def __call__(self, theta: np.ndarray | float) -> np.ndarray:
        """Values ``(F, m)`` at ``theta`` ``(m,)`` (radians, any range)."""
        th = np.atleast_1d(np.asarray(theta, dtype=float))
        return (self.coefficients @ np.exp(1j * np.outer(self._k, th))).real


@dataclass(frozen=True)
class CoefficientModel:
    """How the ODE coefficients are evaluated: ``"table"`` (interpolant) or ``"direct"`` (in-house each call).

    ``size`` is the number of samples of the table (0 when direct) and
    ``error`` the largest interpolation error found at the midpoints of the
    next-coarser table, relative to each coefficient's largest magnitude.
    """

    case: Case
    mode: str
    size: int = 0
    error: float = 0.0
    interpolant: TrigInterpolant | None = field(default=None, repr=False)

    def __call__(self, theta: np.ndarray | float) -> np.ndarray:
        """Coefficient rows ``(5, m)`` at ``theta`` (order :data:`COEFFICIENT_NAMES`)."""
        if self.interpolant is not None:
            return self.interpolant(theta)
        return _checked(self.case, np.atleast_1d(np.asarray(theta, dtype=float)))


def _require_full_revolution(case: Case, count: int = 3600) -> None:
    """ValueError unless the rod reaches the slider line at every crank angle (a reach test by geometry,
    :func:`~dualmech.core.assembly.reach`, before any solver runs)."""
    theta = 2 * np.pi * np.arange(count) / count
    g = case.geometry
    p2 = crank_pin(g.crank_length, theta, case.crank_state(theta, 0.0, 0.0).s)
    bad = reach(p2, g.foot, g.k4, g.rod_length) >= 1.0
    if bad.any():
        where = format_angle_ranges(no_assembly_ranges(np.degrees(theta), bad))
        raise ValueError(f"case {case.name}: the rod cannot reach the slider line at crank angles {where} "
                         "deg; "
                         "forward dynamics needs a crank that turns through a full revolution")


def _periodic(case: Case) -> bool:
    m = case.motion
    return m.axial_amplitude == 0.0 or float(m.axial_cycles).is_integer()


def coefficient_model(case: Case, tol: float = 1e-12, start: int = 64,
                      max_size: int = MAX_TABLE_SIZE) -> CoefficientModel:
    """Tabulate the ODE coefficients of ``case`` (module docstring), or fall back to direct evaluation.

    Raises
    ------
    ValueError
        If the crank cannot make a full revolution.
    """
    _require_full_revolution(case)
    if not _periodic(case):
        return CoefficientModel(case, "direct")
    n = start
    theta = 2 * np.pi * np.arange(n) / n
    values = _checked(case, theta)
    while True:
        mid = theta + np.pi / n
        fresh = _checked(case, mid)
        scale = np.maximum(np.abs(values).max(axis=1), np.abs(fresh).max(axis=1))
        scale[scale == 0.0] = 1.0
        err = float((np.abs(TrigInterpolant(values)(mid) - fresh).max(axis=1) / scale).max())
        both = np.empty((values.shape[0], 2 * n))
        both[:, 0::2], both[:, 1::2] = values, fresh
        if err <= tol:
            return CoefficientModel(case, "table", 2 * n, err, TrigInterpolant(both))
        if 2 * n >= max_size:
            return CoefficientModel(case, "direct", 0, err)
        n *= 2
        values = both
        theta = 2 * np.pi * np.arange(n) / n
