"""Forward dynamics of a one-degree-of-freedom linkage (RSSR, RCCC) from its own inverse dynamics.

The drive torque the in-house engine returns for a given output torque is affine in the input
acceleration and quadratic in its rate:

.. math:: \\tau(\\theta, \\dot\\theta, \\ddot\\theta) = I(\\theta)\\,\\ddot\\theta
          + C(\\theta)\\,\\dot\\theta^2 + Q(\\theta)

so three inverse-dynamics solves per input angle (rate 0 and acceleration 0, rate 1, acceleration 1)
give the generalized inertia :math:`I` about the input axis, the velocity coefficient
:math:`C = \\tfrac12 I'` and the load term :math:`Q` (gravity and the output torque), batched over a
0.5 deg grid of a full turn (:data:`POINTS`), with the output link's rate per unit input rate
:math:`r` (the output torque's work).  One function serves every mechanism: :func:`coefficients`
takes the mechanism's analysis at given input states (:data:`Analyze`: the loop engine on the RSSR's and
RCCC's preset tables, :mod:`dualmech.models.loop.preset_dynamics`, which this module does not import).
Under a drive torque
:math:`\\tau^A` (a number, an expression in ``t, psi, psidot`` or a function) and a viscous input
bearing :math:`c_1` the motion is

.. math:: \\ddot\\theta = (\\tau^A - c_1\\dot\\theta - C\\dot\\theta^2 - Q) / I

integrated by ``scipy``'s ``solve_ivp`` on a periodic spline of the coefficients
(:data:`SPLINE_DEGREE`), by every kind's integrator, budget and input checks
(:mod:`dualmech.models.integration`), together with the drive's and the output torque's work and the energy
dissipated.  Along the result the same analysis gives the pose, rates, reactions and
energies (``docs/conventions.md``, "Linkages", simulate).
A linkage whose input does not turn fully is refused.
"""

from __future__ import annotations

import ast
import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Callable

import numpy as np
from scipy.interpolate import BSpline, make_interp_spline

from dualmech.core.motion import CrankState
from dualmech.core.reactions import BodyMotion, kinetic_energy
from dualmech.core.status import Status
from dualmech.core.table import write_csv
from dualmech.models.expressions import LoadFunction
from dualmech.models.inputs import TORQUE, check_number
from dualmech.models.integration import (  # every kind's integrator, budget and checks
    CRANK_ANGLE,
    CRANK_SPEED,
    MAX_EVALUATIONS,
    TIME_LIMIT,
    Budget,
    Progress,
    as_load,
    checked_settings,
    integrate,
)
from dualmech.models.linkages.rssr_case import RssrCase
from dualmech.models.simulation_summary import simulation_summary
from dualmech.models.tables import LinkageTable

#: Input angles of the coefficient table over a turn: a 0.5 deg grid.
POINTS = 721
#: Degree of the periodic interpolating spline of the table (error ~h^8): at 0.5 deg it misses the
#: coefficients by <= 3.4e-13 of the largest (RSSR), 6.5e-14 (RCCC), the table's own rounding, where a
#: cubic one misses by 7.1e-9 and 8.3e-8 (measured at the midpoints against direct solves).
SPLINE_DEGREE = 7
#: Names of a load expression that mean the slider crank's slider; a linkage's drive torque may not use them.
SLIDER_NAMES = ("s4", "s4dot")


@dataclass(frozen=True)
class StatesAnalysis:
    """The in-house answer of a linkage at given input states ``(n,)``: ``table`` the mechanism's result
    table there (its ``drive_torque`` the drive torque, its ``status`` the mechanism's words),
    ``output_rate`` the output link's rate about its axis ``(n,)`` rad/s, ``motions`` the three links'
    motions in the mechanism's own body frames (``docs/conventions.md``, "RSSR", "RCCC")."""

    table: LinkageTable
    output_rate: np.ndarray
    motions: tuple[BodyMotion, ...]


#: The in-house analysis of a linkage case at given input states (:class:`~dualmech.core.motion.CrankState`;
#: its ``s`` and rates are not read): :func:`dualmech.models.loop.preset_dynamics.at_states`.
Analyze = Callable[[Any, CrankState], StatesAnalysis]


def loads(case: Any) -> tuple[float, float]:
    """``(default drive torque, output torque)`` of a case: an RSSR case in drive-torque mode gives the
    first (and no output torque), every other case its output torque (and no drive torque)."""
    drive = getattr(case, "drive_torque", None)
    return (0.0, float(case.output_torque)) if drive is None else (float(drive), 0.0)


def inverse_case(case: Any) -> Any:
    """``case`` with the output torque of :func:`loads` given and the drive torque solved (an RSSR case in
    drive-torque mode is turned into output-torque mode)."""
    return replace(case, drive_torque=None, output_torque=loads(case)[1]) if isinstance(case, RssrCase) \
        else case


@dataclass(frozen=True)
class Coefficients:
    """``theta`` ``(m,)`` rad (a full turn, both ends) and there ``inertia`` (F·L·s²), ``velocity``
    (F·L·s²), ``load`` (F·L), ``ratio`` (the output link's rate per unit input rate): the drive torque is
    ``inertia * theta_ddot + velocity * theta_dot^2 + load``.  ``periodic``: ``theta`` spans a turn whose
    ends are the same pose; ``False``: only the range a loop table's drive assembles over
    (:mod:`dualmech.models.loop.forward_dynamics`)."""

    theta: np.ndarray
    inertia: np.ndarray
    velocity: np.ndarray
    load: np.ndarray
    ratio: np.ndarray
    periodic: bool = True

    def stacked(self) -> np.ndarray:
        """``(m, 4)``: inertia, velocity, load, ratio."""
        return np.stack([self.inertia, self.velocity, self.load, self.ratio], axis=1)

    def spline(self, step: int = 1) -> BSpline:
        """The spline (:data:`SPLINE_DEGREE`; periodic if :attr:`periodic`, else not-a-knot) of
        :meth:`stacked` on every ``step``-th angle."""
        return make_interp_spline(self.theta[::step], self.stacked()[::step], k=SPLINE_DEGREE,
                                  bc_type="periodic" if self.periodic else None)


def coefficients(case: Any, analyze: Analyze, points: int = POINTS) -> Coefficients:
    """:class:`Coefficients` of ``case`` at ``points`` input angles over a turn, from three inverse-dynamics
    solves each by ``analyze`` of :func:`inverse_case`.

    Raises ``ValueError`` if the linkage does not assemble (or reaches an edge of assembly) somewhere on
    the turn: its input cannot turn fully."""
    theta = np.linspace(0.0, 2 * np.pi, points)
    n = points
    rates = np.concatenate([np.zeros(n), np.ones(n), np.zeros(n)])
    accels = np.concatenate([np.zeros(n), np.zeros(n), np.ones(n)])
    zero = np.zeros(3 * n)
    with np.errstate(all="ignore"):  # rows off the turn are refused below
        an = analyze(inverse_case(case), CrankState(np.tile(theta, 3), zero, rates, zero, accels, zero))
    if not (an.table.status == Status.OK.value).all():
        words = sorted(set(an.table.status))
        raise ValueError(f"simulate: {case.name!r} does not turn fully (statuses {words} on the turn); the "
                         "forward dynamics of a linkage needs an input that does")
    torque = an.table["drive_torque"].reshape(3, n).copy()
    ratio = an.output_rate[n:2 * n].copy()
    torque[:, -1], ratio[-1] = torque[:, 0], ratio[0]  # 2 pi is 0: the same pose, equal to rounding
    return Coefficients(theta, torque[2] - torque[0], torque[1] - torque[0], torque[0], ratio)


def interpolation_error(c: Coefficients) -> float:
    """A bound on the spline's largest error over the largest ``|coefficient|``: how far the spline on every
    other angle misses the skipped ones (the full table's error is smaller, by ``2^(k+1)`` down to the
    table's rounding, ~1e-14).  Measured 2.5e-13 (RSSR), 3.2e-12 (RCCC) on the bundled cases."""
    data = c.stacked()
    scale = np.maximum(np.abs(data).max(axis=0), np.finfo(float).tiny)
    return float((np.abs(c.spline(2)(c.theta[1::2]) - data[1::2]) / scale).max())


@dataclass(frozen=True)
class EquationOfMotion:
    """The right-hand side for ``y = (theta, theta_dot, W^A, W^O, D)``: the input angle and rate, the work
    of the drive and of the output torque, and the energy the input bearing dissipated.  ``model(theta)``
    ``(4, k)`` is the coefficients' interface of :func:`dualmech.models.integration.integrate`."""

    spline: BSpline
    torque: LoadFunction
    output_torque: float
    damping: float

    def model(self, theta: float | np.ndarray) -> np.ndarray:
        return self.spline(np.mod(np.atleast_1d(theta), 2 * np.pi)).T

    def __call__(self, t: float, y: np.ndarray) -> np.ndarray:
        theta, w = y[0], y[1]
        inertia, velocity, load, ratio = self.model(theta)[:, 0]
        ta = self.torque(t, theta, w, math.nan, math.nan)
        acc = (ta - self.damping * w - velocity * w * w - load) / inertia
        return np.array([w, acc, ta * w, self.output_torque * ratio * w, self.damping * w * w])


def drive_load(torque: float | str | LoadFunction | None, default: float) -> LoadFunction:
    """The drive torque as a function of ``(t, psi, psidot, s4, s4dot)`` (``s4``, ``s4dot`` are NaN: a
    linkage has no slider): :func:`~dualmech.models.integration.as_load`, and an expression that
    names ``s4`` or ``s4dot`` is a one-line ``ValueError``."""
    load = as_load(torque, default, "torque", TORQUE)
    if isinstance(torque, str):
        names = {n.id for n in ast.walk(ast.parse(torque.strip(), mode="eval")) if isinstance(n, ast.Name)}
        used = [s for s in SLIDER_NAMES if s in names]
        if used:
            raise ValueError(f"torque: {torque.strip()!r} uses {', '.join(used)}, the slider crank's slider; "
                             "a linkage's drive torque may use t, psi, psidot")
    return load


def simulate(case: Any, analyze: Analyze, duration: float, torque: float | str | LoadFunction | None = None,
             psi0: float | None = None, psidot0: float | None = None, damping: float = 0.0,
             samples: int = 1001, method: str = "DOP853", rtol: float = 1e-12, atol: float = 1e-12,
             coeffs: Coefficients | None = None, max_evaluations: int = MAX_EVALUATIONS,
             time_limit: float = TIME_LIMIT, progress: Progress | None = None) -> "LinkageSimulation":
    """Integrate the input's equation of motion of a linkage case from ``t = 0`` to ``duration`` s, its
    coefficients and the table along the motion by ``analyze`` (:data:`Analyze`).

    ``torque``: the drive torque about ``+z`` on the input link (default: an RSSR case's ``drive_torque``,
    else 0; :func:`drive_load`); the output torque is the case's (:func:`loads`).  ``psi0`` (rad),
    ``psidot0`` (rad/s): the start, default the case's first angle and ``crank_rpm``; ``damping``: the
    input bearing's viscous coefficient (F·L·s); ``samples`` equally spaced output times; ``method``,
    ``rtol``, ``atol``, ``max_evaluations``, ``time_limit`` as for the slider crank
    (:func:`dualmech.models.slider_crank.forward_dynamics.simulate`, same ranges, and its ``progress``);
    ``coeffs`` a table built before.

    Raises
    ------
    ValueError
        One line: an input out of range, an input that does not turn fully, a load that is not a finite
        real number, the budget used up, or a motion that runs away.
    """
    duration, damping, _, rtol, atol, _ = checked_settings(duration, damping, 0.0, rtol, atol, 1e-12,
                                                             samples, method)
    budget = Budget(max_evaluations, time_limit)
    default, output_torque = loads(case)
    tau = drive_load(torque, default)
    psi0 = float(np.radians(case.motion.angles_deg[0])) if psi0 is None else check_number("psi0", psi0,
                                                                                          CRANK_ANGLE)
    psidot0 = case.motion.speed if psidot0 is None else check_number("psidot0", psidot0, CRANK_SPEED)
    c = coefficients(case, analyze) if coeffs is None else coeffs
    rhs = EquationOfMotion(c.spline(), tau, output_torque, damping)
    sol = integrate(rhs, budget, np.array([psi0, psidot0, 0.0, 0.0, 0.0]),
                     np.linspace(0.0, duration, int(samples)), method, rtol, atol, progress)
    info = {"method": method, "rtol": rtol, "atol": atol, "nfev": int(sol.nfev), "coefficients": "table",
            "table_size": c.theta.shape[0], "interpolation_error": interpolation_error(c),
            "message": sol.message}
    return trajectory(case, analyze, rhs, sol.t, sol.y, info)


@dataclass(frozen=True)
class LinkageSimulation:
    """A simulated motion of a linkage at ``n`` output times; arrays ``(n,)``.

    ``t`` s; ``psi``, ``psi_dot``, ``psi_ddot`` the input angle ``theta1`` (rad) and its rates;
    ``torque`` the applied drive torque :math:`\\tau^A`; ``output_torque`` the case's (constant);
    ``kinetic``, ``potential`` (:math:`V = -\\sum m_b g\\cdot c_b`, world origin) from the in-house motion;
    ``work_drive``, ``work_output``, ``dissipated`` integrated with the ODE; ``table`` the mechanism's
    result table along the motion (inverse dynamics with the simulated ``psi_ddot`` and the output
    torque given: its ``drive_torque`` is ``torque - damping * psi_dot``); ``info`` integrator facts.
    """

    case: Any
    t: np.ndarray
    psi: np.ndarray
    psi_dot: np.ndarray
    psi_ddot: np.ndarray
    torque: np.ndarray
    output_torque: float
    kinetic: np.ndarray
    potential: np.ndarray
    work_drive: np.ndarray
    work_output: np.ndarray
    dissipated: np.ndarray
    table: LinkageTable
    info: dict

    def energy_residual(self) -> np.ndarray:
        """Work-energy balance :math:`\\Delta(T + V) - (W^A + W^O - D)`, ``(n,)`` (zero when exact)."""
        e = self.kinetic + self.potential
        return (e - e[0]) - (self.work_drive + self.work_output - self.dissipated)

    def columns(self) -> dict[str, np.ndarray]:
        """Output columns in CSV order: :data:`SIMULATION_COLUMNS`, then the mechanism's table columns after
        ``theta1_deg`` (``docs/conventions.md``, "Linkages", simulate)."""
        cols = {"t": self.t, "theta1_deg": np.degrees(self.psi), "psi": self.psi, "psi_dot": self.psi_dot,
                "psi_ddot": self.psi_ddot, "torque_applied": self.torque,
                "output_torque_applied": np.full(self.t.shape, self.output_torque),
                "kinetic_energy": self.kinetic, "potential_energy": self.potential,
                "work_drive": self.work_drive, "work_output": self.work_output, "dissipated": self.dissipated}
        return cols | {k: v for k, v in self.table.columns.items() if k != "theta1_deg"}

    def to_csv(self, path: str | Path | None = None) -> str:
        """CSV text of :meth:`columns` plus ``status`` (:func:`~dualmech.core.table.write_csv`)."""
        return write_csv(self.columns(), self.table.status, path)


#: The first columns of :meth:`LinkageSimulation.columns` (then the table's, then ``status``).
SIMULATION_COLUMNS: tuple[str, ...] = (
    "t", "theta1_deg", "psi", "psi_dot", "psi_ddot", "torque_applied", "output_torque_applied",
    "kinetic_energy", "potential_energy", "work_drive", "work_output", "dissipated",
)


def energies(case: Any, an: StatesAnalysis) -> tuple[np.ndarray, np.ndarray]:
    """Kinetic :math:`\\sum \\tfrac12 m v_G^2 + \\tfrac12\\omega\\cdot I_G\\omega` and potential
    :math:`-\\sum m g\\cdot G` energy of the three links of an analysis ``an``, each ``(n,)``."""
    kinetic = sum(kinetic_energy(b, m) for b, m in zip(case.bodies, an.motions))
    potential = -sum(b.mass * m.com @ case.gravity for b, m in zip(case.bodies, an.motions))
    return kinetic, potential


def energy(case: Any, analyze: Analyze, theta: np.ndarray, theta_dot: np.ndarray) -> np.ndarray:
    """Kinetic plus potential energy of the links at the input states ``(n,)`` (:func:`energies`)."""
    zero = np.zeros_like(theta)
    an = analyze(inverse_case(case), CrankState(theta, zero, theta_dot, zero, zero, zero))
    return sum(energies(case, an))


def trajectory(case: Any, analyze: Analyze, rhs: EquationOfMotion, t: np.ndarray, y: np.ndarray,
               info: dict) -> LinkageSimulation:
    """The in-house pose, rates, reactions and energies along an integrated motion ``y`` ``(5, n)``."""
    psi, w = y[0], y[1]
    acc = np.array([rhs(ti, yi)[1] for ti, yi in zip(t, y.T)])
    torque = np.array([rhs.torque(ti, p, v, math.nan, math.nan) for ti, p, v in zip(t, psi, w)])
    zero = np.zeros_like(psi)
    an = analyze(inverse_case(case), CrankState(psi, zero, w, zero, acc, zero))
    kinetic, potential = energies(case, an)
    return LinkageSimulation(case, t, psi, w, acc, torque, rhs.output_torque, kinetic, potential, y[2], y[3],
                             y[4], an.table, info)


def linkage_summary(sim: LinkageSimulation) -> str:
    """What ``dualmech simulate`` prints about ``sim``
    (:func:`~dualmech.models.simulation_summary.simulation_summary`): the output torque and its work in
    place of the
    slider crank's slider."""
    middle = (f"output torque {sim.output_torque:.6g} (the case's): work {sim.work_output[-1]:.6g}; "
              f"dissipated {sim.dissipated[-1]:.6g}")
    return simulation_summary(sim, middle, (sim.work_drive, sim.work_output))
