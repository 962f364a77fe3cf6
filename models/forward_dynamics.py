"""Forward dynamics of the generalized slider crank: one second-order ODE in the crank angle.

The mechanism has one degree of freedom, the crank angle :math:`\\psi = \\theta_1`
(``docs/conventions.md``); the crank's axial position follows it,
:math:`S_1(\\psi) = S_{1,0} + S_{S1}\\sin(\\alpha\\psi)` (held when the case's
``axial_amplitude`` is 0, otherwise a workless cam-like constraint).  With the
generalized inertia :math:`I(\\psi)` of ``core/generalized_inertia.py``
(Sinatra–Angeles eq. 39–43, in space) the equation of motion is

.. math:: I(\\psi)\\ddot\\psi = -\\tfrac12 I'(\\psi)\\dot\\psi^2 + \\tau^A + \\tau^G + \\tau^D + \\tau^S

* :math:`\\tau^A = T(t, \\psi, \\dot\\psi, S_4, \\dot S_4)`: motor torque on the crank about +z;
* :math:`\\tau^G = \\sum_b m_b\\, g\\cdot v_b`: gravity (``[loads].gravity``, world axes);
* :math:`\\tau^D = -(c_1 + c_4 S_4'^2)\\dot\\psi`: viscous crank bearing :math:`c_1` and slider :math:`c_4`;
* :math:`\\tau^S = -F\\,S_4'`: slider load :math:`F(t, \\psi, \\dot\\psi, S_4, \\dot S_4)`, the
  component along :math:`k_4` of the force the ground applies to the slider (a gas
  load pushing the slider toward :math:`-k_4`, i.e. toward larger ``S4``, is negative;
  a spring of stiffness ``k`` and free length ``L0`` between ``F`` and the slider
  pin is :math:`F = k(S_4 - L_0)`).

The coefficients :math:`I, I', \\tau^G, S_4, S_4'` come from the in-house velocity
and acceleration analysis (``models/slider_crank.py``, :math:`\\dot\\psi = 1`,
:math:`\\ddot\\psi = 0`).  One in-house call costs milliseconds, so for a
periodic mechanism they are sampled at ``N`` crank angles and evaluated by their
trigonometric interpolant; ``N`` doubles until the interpolant matches fresh
in-house values at the ``N`` midpoints to ``interpolation_tol`` (relative), which
converges geometrically for these analytic periodic functions (``N`` = 128–256 for
the bundled cases).  A non-periodic axial motion (non-integer ``axial_cycles``)
falls back to calling the in-house solver at every right-hand-side evaluation.
Along the computed trajectory, kinematics, energies and joint reactions are
recomputed by the in-house solver itself (inverse dynamics with :math:`\\ddot\\psi`
from the ODE, slider load given, so dead centres are regular).

Units: those of the case (SI works as is: m, kg, N, s).  Inputs for benchmark
problems written in a planar textbook frame (slider along the textbook's +x,
crank pivot at the origin, angle :math:`\\varphi` from +x): use
``slider_twist_deg = 270`` and ``slider_offset = -e`` for a slider line at
textbook height ``y = e``; then textbook ``x`` = world ``y``, textbook ``y`` = world
``-x``, :math:`\\theta_1 = \\varphi + 90°`, textbook gravity ``(0, -g)`` is world
``(g, 0, 0)`` and the slider's textbook position ``x`` is ``S4``
(:func:`planar_model` states the mapping for either planar twist).
"""

from __future__ import annotations

import csv
import io
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

from dualmech.core import generalized_inertia as gi
from dualmech.core.motion import CrankState
from dualmech.core.planar import PlanarSliderCrank
from dualmech.core.reactions import Reactions, kinetic_energy, solve_reactions
from dualmech.models.case import (FORCE, MAX_ANGLE_DEG, MAX_CRANK_RPM, SCALE, TORQUE, Case, Range,
                                  check_number, show)
from dualmech.models.expressions import LoadFunction, load_expression
from dualmech.models.slider_crank import Analysis, analyze, no_assembly_ranges, slider_axis

#: Inputs of :func:`simulate` and their ranges (``docs/conventions.md``, "Input ranges").
#: The longest simulated time, s: t is then resolved to 1e6 x 2.2e-16 = 2e-10 s, finer than any
#: step these motions need.
DURATION = Range(1e-9, 1e6, "a duration in seconds")
#: Initial crank angle, rad: the case's angle bound (MAX_ANGLE_DEG in models/case.py).
CRANK_ANGLE = Range(-math.radians(MAX_ANGLE_DEG), math.radians(MAX_ANGLE_DEG), "a crank angle in radians")
#: Initial crank speed, rad/s: the case's speed bound (MAX_CRANK_RPM in models/case.py).
CRANK_SPEED = Range(-math.pi * MAX_CRANK_RPM / 30, math.pi * MAX_CRANK_RPM / 30, "a crank speed in rad/s")
#: Viscous coefficients c1, c4 (>= 0), case units.
DAMPING = Range(0.0, SCALE, "a viscous coefficient >= 0 (case units)")
#: Relative tolerance: from 100 machine epsilons (scipy silently raises anything smaller to
#: that, with a warning) to 0.1 (looser says nothing about the motion).
RTOL = Range(100 * np.finfo(float).eps, 0.1, "a relative tolerance")
#: Absolute tolerance, multiplied by each state's scale (speed, energy): below 1e-15 of the
#: scale it is under the float resolution of the state.
ATOL = Range(1e-15, 1.0, "an absolute tolerance (per unit of each state's scale)")
#: Relative accuracy asked of the coefficient table (``coefficient_model``).
INTERPOLATION_TOL = Range(1e-15, 0.1, "a relative interpolation tolerance")
#: Most output samples: the trajectory's post-processing evaluates each sample in Python.
MAX_SAMPLES = 100_000
#: The integrators of ``scipy.integrate.solve_ivp``.
METHODS = ("RK45", "RK23", "DOP853", "Radau", "BDF", "LSODA")
#: Default integrator budget: right-hand-side evaluations (DOP853 takes 12 per step, so about
#: 17,000 steps, some 16 s at the measured 80 us per evaluation with the coefficient table;
#: 100 s of the thesis crank at 50 rpm takes ~1,000) and wall time, seconds.
MAX_EVALUATIONS = 200_000
TIME_LIMIT = 60.0
#: Range of the wall-time budget, seconds.
TIME_BUDGET = Range(1e-3, 1e6, "a time limit in seconds")
#: Largest number of samples of the coefficient table before falling back to direct evaluation.
MAX_TABLE_SIZE = 2**15
#: Names of the tabulated coefficients, in row order.
COEFFICIENT_NAMES = ("inertia", "inertia_derivative", "gravity_force", "s4", "s4_rate")


# ----------------------------------------------------------------------------- loads

def as_load(value: float | str | LoadFunction | None, default: float, name: str,
            limits: Range = TORQUE) -> LoadFunction:
    """A load function from a number (within ``limits``), an expression (:func:`load_expression`),
    a callable, or ``None`` (``default``)."""
    if value is None:
        value = default
    if callable(value):
        return value
    if isinstance(value, str):
        return load_expression(value)
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name}: expected a number, an expression or a function, got {show(value)}")
    const = check_number(name, value, limits)
    return lambda t, psi, psidot, s4, s4dot: const


# ----------------------------------------------------------------------------- coefficients

def axial_motion(case: Case, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:math:`S_1(\\theta)`, :math:`S_1'`, :math:`S_1''` of the case (thesis eq. 27), each ``(n,)``."""
    m = case.motion
    phase = m.axial_cycles * np.asarray(theta, dtype=float)
    s = case.geometry.crank_axial_shift + m.axial_amplitude * np.sin(phase)
    sp = m.axial_amplitude * m.axial_cycles * np.cos(phase)
    spp = -m.axial_amplitude * m.axial_cycles**2 * np.sin(phase)
    return s, sp, spp


def crank_state(case: Case, psi: np.ndarray, psi_dot: np.ndarray, psi_ddot: np.ndarray) -> CrankState:
    """The crank state of a motion :math:`\\psi(t)` with :math:`S_1 = S_1(\\psi)`, fields ``(n,)``."""
    psi = np.asarray(psi, dtype=float)
    psi_dot = np.broadcast_to(np.asarray(psi_dot, dtype=float), psi.shape).copy()
    psi_ddot = np.broadcast_to(np.asarray(psi_ddot, dtype=float), psi.shape).copy()
    s, sp, spp = axial_motion(case, psi)
    return CrankState(psi, s, psi_dot, sp * psi_dot, psi_ddot, spp * psi_dot**2 + sp * psi_ddot)


def _bodies(case: Case) -> tuple:
    return case.bodies.crank, case.bodies.rod, case.bodies.slider


def influence_coefficients(an: Analysis) -> tuple[np.ndarray, np.ndarray, gi.InfluenceCoefficients]:
    """Masses ``(3,)``, world inertias ``(3, n, 3, 3)`` and influence coefficients of an analysis.

    ``an`` must have been computed with :math:`\\dot\\psi = 1, \\ddot\\psi = 0`
    (:func:`crank_state` with those rates): its centre-of-mass velocities and
    angular velocities are then the influence coefficients and its accelerations
    their :math:`\\psi`-derivatives.
    """
    bodies = _bodies(an.case)
    masses = np.array([b.mass for b in bodies])
    inertia = np.stack([m.rotation @ b.inertia @ np.swapaxes(m.rotation, 1, 2) for b, m in zip(bodies, an.motions)])
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
    an = analyze(case, crank_state(case, theta, np.ones(n), np.zeros(n)))
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
    bad = ~np.isin(c.status, ["ok", "dead_centre"])
    if bad.any():
        deg = np.degrees(np.mod(theta, 2 * np.pi))
        order = np.argsort(deg)
        runs = no_assembly_ranges(deg[order], bad[order])
        where = ", ".join(f"{a:.4g}..{b:.4g}" for a, b in runs)
        raise ValueError(f"case {case.name}: the crank cannot turn through {where} deg "
                         f"({', '.join(sorted(set(c.status[bad])))}); forward dynamics needs a full revolution")
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


def assembly_margin(case: Case, theta: np.ndarray) -> np.ndarray:
    """:math:`a_2^2 - d^2`, ``d`` the distance from the crank pin to the slider line, ``(n,)`` (< 0: no assembly).

    A reach condition, not a solution of the loop: used to refuse a case whose
    crank cannot turn through a full revolution before any solver runs.
    """
    f, k4 = slider_axis(case)
    s1, _, _ = axial_motion(case, theta)
    a1 = case.geometry.crank_length
    d = np.stack([a1 * np.cos(theta), a1 * np.sin(theta), s1], 1) - f
    return case.geometry.rod_length**2 - (np.einsum("ni,ni->n", d, d) - (d @ k4) ** 2)


def _require_full_revolution(case: Case, count: int = 3600) -> None:
    theta = 2 * np.pi * np.arange(count) / count
    bad = assembly_margin(case, theta) <= 0.0
    if bad.any():
        runs = no_assembly_ranges(np.degrees(theta), bad)
        where = ", ".join(f"{a:.4g}..{b:.4g}" for a, b in runs)
        raise ValueError(f"case {case.name}: the rod cannot reach the slider line at crank angles {where} deg; "
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


# ----------------------------------------------------------------------------- simulation

class _Stopped(Exception):
    """Raised inside the right-hand side to end an integration early, with where and why."""

    def __init__(self, t: float, reason: str) -> None:
        super().__init__(reason)
        self.t, self.reason = t, reason


class _Budget:
    """Counts right-hand-side evaluations and wall time of one integration."""

    def __init__(self, max_evaluations: int, time_limit: float) -> None:
        integer = isinstance(max_evaluations, (int, np.integer)) and not isinstance(max_evaluations, bool)
        if not integer or max_evaluations < 1:
            raise ValueError(f"max_evaluations: expected a positive integer, got {show(max_evaluations)}")
        self.max_evaluations = int(max_evaluations)
        self.time_limit = check_number("time_limit", time_limit, TIME_BUDGET)
        self.start()

    def start(self) -> None:
        """Start counting (now)."""
        self.evaluations = 0
        self.deadline = time.monotonic() + self.time_limit

    def spend(self, t: float) -> None:
        """One evaluation at time ``t``; :class:`_Stopped` once the budget is used up."""
        self.evaluations += 1
        if self.evaluations > self.max_evaluations:
            raise _Stopped(t, f"used its budget of {self.max_evaluations:,} right-hand-side evaluations "
                              "(max_evaluations); a stiff or runaway motion, or too tight a tolerance")
        if time.monotonic() > self.deadline:
            raise _Stopped(t, f"used its wall-time budget of {self.time_limit:g} s (time_limit) after "
                              f"{self.evaluations:,} evaluations")


@dataclass(frozen=True)
class Simulation:
    """A simulated motion at ``n`` output times; arrays ``(n,)`` unless stated.

    Attributes
    ----------
    t : time. ``psi``, ``psi_dot``, ``psi_ddot``: crank angle :math:`\\theta_1` (rad) and rates.
    s1, s4, s4_dot, s4_ddot : crank axial position and slider coordinate with rates (in-house).
    torque, slider_load : the applied motor torque :math:`\\tau^A` and slider load ``F``
        (without damping).
    kinetic, potential : :math:`T` and :math:`V = -\\sum m_b g\\cdot c_b` (in-house motion).
    work_drive, work_slider, dissipated : :math:`\\int\\tau^A\\dot\\psi\\,dt`,
        :math:`-\\int F\\dot S_4\\,dt`, :math:`\\int (c_1\\dot\\psi^2 + c_4\\dot S_4^2)dt` (integrated with the ODE).
    reactions : Reactions
        In-house joint reactions along the trajectory (world axes; ``slider_load``
        there includes the slider damper, ``drive_torque`` = ``j1_mz`` = motor torque
        + bearing damping :math:`- j_{1z} S_1'` of the axial constraint).
    transmission, status : in-house transmission index and status words.
    info : dict
        Integrator and coefficient-model facts (``method``, ``rtol``, ``atol``,
        ``nfev``, ``coefficients``, ``table_size``, ``interpolation_error``, ``message``).
    """

    case: Case
    t: np.ndarray
    psi: np.ndarray
    psi_dot: np.ndarray
    psi_ddot: np.ndarray
    s1: np.ndarray
    s4: np.ndarray
    s4_dot: np.ndarray
    s4_ddot: np.ndarray
    torque: np.ndarray
    slider_load: np.ndarray
    kinetic: np.ndarray
    potential: np.ndarray
    work_drive: np.ndarray
    work_slider: np.ndarray
    dissipated: np.ndarray
    reactions: Reactions
    transmission: np.ndarray
    status: np.ndarray
    info: dict

    def energy_residual(self) -> np.ndarray:
        """Work–energy balance :math:`\\Delta(T + V) - (W^A + W^S - D)`, ``(n,)`` (zero for an exact solution)."""
        e = self.kinetic + self.potential
        return (e - e[0]) - (self.work_drive + self.work_slider - self.dissipated)

    def columns(self) -> dict[str, np.ndarray]:
        """Output columns in CSV order (names in :data:`SIMULATION_COLUMNS`)."""
        r = self.reactions
        cols = {
            "t": self.t, "theta1_deg": np.degrees(self.psi), "psi": self.psi, "psi_dot": self.psi_dot,
            "psi_ddot": self.psi_ddot, "S1": self.s1, "S4": self.s4, "S4_dot": self.s4_dot,
            "S4_ddot": self.s4_ddot, "torque_applied": self.torque, "slider_load_applied": self.slider_load,
            "kinetic_energy": self.kinetic, "potential_energy": self.potential, "work_drive": self.work_drive,
            "work_slider": self.work_slider, "dissipated": self.dissipated,
        }
        for name, arr in (("j1_f", r.j1_force), ("j1_m", r.j1_moment), ("j2_f", r.j2), ("j3_f", r.j3),
                          ("j4_f", r.j4_force), ("j4_m", r.j4_moment)):
            for k, axis in enumerate("xyz"):
                cols[f"{name}{axis}"] = arr[:, k]
        cols["slider_load"] = r.slider_load
        cols["drive_torque"] = r.drive_torque
        cols["transmission"] = self.transmission
        return cols

    def to_csv(self, path: str | Path | None = None) -> str:
        """CSV text of :meth:`columns` plus ``status`` (full precision); written to ``path`` if given."""
        cols = self.columns()
        buf = io.StringIO()
        writer = csv.writer(buf, lineterminator="\n")
        writer.writerow([*cols, "status"])
        data = list(cols.values())
        for i in range(self.t.shape[0]):
            writer.writerow([repr(float(c[i])) for c in data] + [self.status[i]])
        text = buf.getvalue()
        if path is not None:
            Path(path).write_text(text)
        return text


#: Column order of :meth:`Simulation.columns` (then ``status``).
SIMULATION_COLUMNS: tuple[str, ...] = (
    "t", "theta1_deg", "psi", "psi_dot", "psi_ddot", "S1", "S4", "S4_dot", "S4_ddot", "torque_applied",
    "slider_load_applied", "kinetic_energy", "potential_energy", "work_drive", "work_slider", "dissipated",
    "j1_fx", "j1_fy", "j1_fz", "j1_mx", "j1_my", "j1_mz", "j2_fx", "j2_fy", "j2_fz", "j3_fx", "j3_fy", "j3_fz",
    "j4_fx", "j4_fy", "j4_fz", "j4_mx", "j4_my", "j4_mz", "slider_load", "drive_torque", "transmission",
)


def simulate(case: Case, duration: float, torque: float | str | LoadFunction | None = None,
             psi0: float | None = None, psidot0: float | None = None, damping: float = 0.0,
             slider_damping: float = 0.0, slider_load: float | str | LoadFunction | None = None,
             samples: int = 1001, method: str = "DOP853", rtol: float = 1e-12, atol: float = 1e-12,
             interpolation_tol: float = 1e-12, model: CoefficientModel | None = None,
             max_evaluations: int = MAX_EVALUATIONS, time_limit: float = TIME_LIMIT) -> Simulation:
    """Integrate the crank's equation of motion from ``t = 0`` to ``duration`` (module docstring).

    Parameters
    ----------
    case : Case
        Geometry, bodies, gravity (``[loads].gravity``) and axial motion :math:`S_1(\\psi)`.
    duration : float
        End time (> 0), seconds.
    torque : number, expression or function, optional
        Motor torque :math:`\\tau^A` on the crank about +z; a function is called as
        ``f(t, psi, psidot, s4, s4dot)``, an expression may use those names
        (:func:`load_expression`).  Default: the case's ``drive_torque`` in torque
        mode, else 0.
    psi0, psidot0 : float, optional
        Initial crank angle :math:`\\theta_1` (rad) and speed (rad/s); default the
        case's first angle and ``crank_rpm``.
    damping, slider_damping : float
        Viscous coefficients :math:`c_1` (torque·s/rad) of the crank bearing and
        :math:`c_4` (force·s/length) of the slider guide, >= 0.
    slider_load : number, expression or function, optional
        :math:`F = k_4\\cdot` (force of the ground on the slider), excluding
        ``slider_damping``.  Default: the case's ``slider_force`` in force mode, else 0.
    samples : int
        Number of equally spaced output times (>= 2), ``t = 0`` and ``duration`` included.
    method, rtol, atol : solve_ivp settings (``atol`` is scaled per state component).
    interpolation_tol : float
        Relative accuracy asked of the coefficient table (:func:`coefficient_model`).
    model : CoefficientModel, optional
        A table built before (reused across runs of one case).
    max_evaluations, time_limit : int, float
        The integrator's budget: right-hand-side evaluations and wall time (s).  When
        either is used up the integration stops with a one-line ``ValueError`` saying
        where and why.

    Every number is checked against its range first (:data:`DURATION`, :data:`RTOL`,
    :data:`ATOL`, ... ; ``docs/conventions.md``, "Input ranges").

    Returns
    -------
    Simulation

    Raises
    ------
    ValueError
        One line: an input out of range, a load that is not a finite real number,
        the budget used up, or a motion that runs away.
    """
    duration = check_number("duration", duration, DURATION)
    damping = check_number("damping", damping, DAMPING)
    slider_damping = check_number("slider_damping", slider_damping, DAMPING)
    rtol = check_number("rtol", rtol, RTOL)
    atol = check_number("atol", atol, ATOL)
    interpolation_tol = check_number("interpolation_tol", interpolation_tol, INTERPOLATION_TOL)
    if isinstance(samples, (bool, np.bool_)) or not isinstance(samples, (int, np.integer)) \
            or not 2 <= samples <= MAX_SAMPLES:
        raise ValueError(f"samples: expected an integer from 2 to {MAX_SAMPLES:,}, got {show(samples)}")
    if method not in METHODS:
        raise ValueError(f"method: {show(method)} is not a solve_ivp method (valid: {', '.join(METHODS)})")
    budget = _Budget(max_evaluations, time_limit)
    loads = case.loads
    tau_a = as_load(torque, loads.drive_torque if loads.mode == "torque" else 0.0, "torque", TORQUE)
    force = as_load(slider_load, loads.slider_force if loads.mode == "force" else 0.0, "slider_load", FORCE)
    psi0 = (float(np.radians(case.motion.angles_deg[0])) if psi0 is None
            else check_number("psi0", psi0, CRANK_ANGLE))
    psidot0 = case.motion.speed if psidot0 is None else check_number("psidot0", psidot0, CRANK_SPEED)
    model = coefficient_model(case, interpolation_tol) if model is None else model

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        psi, w = y[0], y[1]
        inertia, d_inertia, grav, s4, s4p = model(psi)[:, 0]
        s4dot = s4p * w
        ta = tau_a(t, psi, w, s4, s4dot)
        f = force(t, psi, w, s4, s4dot)
        tau = ta + grav + gi.slider_force(s4p, f) + gi.damping_force(w, s4p, damping, slider_damping)
        acc = gi.acceleration(inertia, d_inertia, w, tau)
        return np.array([w, acc, ta * w, -f * s4dot, damping * w * w + slider_damping * s4dot**2])

    def counted_rhs(t: float, y: np.ndarray) -> np.ndarray:
        budget.spend(t)
        dy = rhs(t, y)
        if not np.isfinite(dy).all():
            raise _Stopped(t, f"the state or its rate is not finite (psi = {y[0]:.6g} rad, "
                              f"psidot = {y[1]:.6g} rad/s): the motion runs away")
        if abs(y[1]) > CRANK_SPEED.high:
            raise _Stopped(t, f"the crank speed {y[1]:.6g} rad/s passed {CRANK_SPEED.high:.6g} rad/s, "
                              "the largest a case may have: the motion runs away")
        return dy

    c0 = model(psi0)[:, 0]
    w_scale = max(abs(psidot0), 1.0)
    e_scale = max(abs(c0[0]) * w_scale**2, 1.0)
    atol_vec = atol * np.array([1.0, w_scale, e_scale, e_scale, e_scale])
    t_out = np.linspace(0.0, duration, int(samples))
    budget.start()
    try:
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):  # non-finite rates: _Stopped
            sol = solve_ivp(counted_rhs, (0.0, duration), np.array([psi0, psidot0, 0.0, 0.0, 0.0]),
                            method=method, t_eval=t_out, rtol=rtol, atol=atol_vec)
    except _Stopped as stop:
        raise ValueError(f"simulate: stopped at t = {stop.t:.6g} s of {duration:g} s: {stop.reason}") from None
    if not sol.success:
        raise ValueError(f"simulate: the integrator stopped at t = {sol.t[-1]:.6g} s of {duration:g} s: "
                         f"{str(sol.message).splitlines()[0]}")
    psi, w = sol.y[0], sol.y[1]
    acc = np.array([rhs(t, y)[1] for t, y in zip(sol.t, sol.y.T)])
    an = analyze(case, crank_state(case, psi, w, acc))
    s4dot = an.rates.q_dot[:, 0]
    ta = np.array([tau_a(t, p, v, s, sd) for t, p, v, s, sd in zip(sol.t, psi, w, an.s4, s4dot)])
    f = np.array([force(t, p, v, s, sd) for t, p, v, s, sd in zip(sol.t, psi, w, an.s4, s4dot)])
    bodies = _bodies(case)
    _, k4 = slider_axis(case)
    reactions = solve_reactions(bodies, an.motions, an.p2, an.p3, k4, loads.gravity,
                                np.full(psi.shape, np.nan), f + slider_damping * s4dot)
    kinetic = sum(kinetic_energy(b, m) for b, m in zip(bodies, an.motions))
    masses = np.array([b.mass for b in bodies])
    potential = gi.potential_energy(masses, loads.gravity, np.stack([m.com for m in an.motions]))
    status = np.where(np.isin(an.status, ["ok", "dead_centre"]), "ok", an.status).astype(object)
    info = {"method": method, "rtol": rtol, "atol": atol, "nfev": int(sol.nfev), "coefficients": model.mode,
            "table_size": model.size, "interpolation_error": model.error, "message": sol.message}
    return Simulation(case, sol.t, psi, w, acc, an.crank.s, an.s4, s4dot, an.rates.q_ddot[:, 0], ta, f,
                      kinetic, potential, sol.y[2], sol.y[3], sol.y[4], reactions, an.transmission, status, info)


# ----------------------------------------------------------------------------- the paper's planar model

def planar_model(case: Case) -> tuple[PlanarSliderCrank, float]:
    """The Sinatra–Angeles planar model of a planar case, and the angle offset :math:`\\varphi`.

    The paper's crank angle is :math:`\\psi = \\theta_1 - \\varphi`.  Its frame has
    ``i = -k4`` (the direction of increasing ``S4``) and ``j = z x i``; the slider
    line is ``y = h = F·j`` and the paper's ``s`` equals ``S4``.  With two ball
    joints and the zero-spin gauge the axisymmetric rod turns about ``z`` only, so
    the spatial model is dynamically the paper's revolute-jointed one: the rod's
    polar moment is its transverse inertia.

    Raises
    ------
    ValueError
        Unless ``slider_twist_deg`` is 90 or 270 (mod 360) and :math:`S_1 \\equiv 0`.
    """
    g = case.geometry
    if abs(math.cos(g.slider_twist)) > 1e-12:
        raise ValueError(f"geometry.slider_twist_deg: {g.slider_twist_deg!r} is not planar; expected 90 or 270")
    if g.crank_axial_shift != 0.0 or case.motion.axial_amplitude != 0.0:
        raise ValueError(f"geometry.crank_axial_shift: the planar model needs S1 = 0 (got shift "
                         f"{g.crank_axial_shift!r}, amplitude {case.motion.axial_amplitude!r})")
    f, k4 = slider_axis(case)
    i_p = -k4
    j_p = np.cross([0.0, 0.0, 1.0], i_p)
    b = case.bodies
    model = PlanarSliderCrank(
        crank_length=g.crank_length,
        rod_length=g.rod_length,
        offset=float(f @ j_p),
        masses=(b.crank.mass, b.rod.mass, b.slider.mass),
        polar_inertias=(float(b.crank.inertia[2, 2]), float(b.rod.inertia[1, 1])),
        crank_com=b.crank.com[:2],
        rod_com=np.array([b.rod.com[0], 0.0]),
        slider_com=np.array([b.slider.com @ i_p, b.slider.com @ j_p]),
        gravity=np.array([case.loads.gravity @ i_p, case.loads.gravity @ j_p]),
    )
    return model, float(math.atan2(i_p[1], i_p[0]))
