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
and acceleration analysis, tabulated by :mod:`dualmech.models.dynamics_coefficients`.
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

import math
import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from dualmech.core import generalized_inertia as gi
from dualmech.core.planar import PlanarSliderCrank
from dualmech.core.reactions import kinetic_energy, solve_reactions
from dualmech.core.status import RATES_GIVEN, Status, is_status
from dualmech.models.case import PLANAR_TWIST_COSINE, Case
from dualmech.models.dynamics_coefficients import CoefficientModel, coefficient_model
from dualmech.models.expressions import LoadFunction, load_expression
from dualmech.models.inputs import (
    FORCE,
    MAX_ANGLE_DEG,
    MAX_CRANK_RPM,
    SCALE,
    TORQUE,
    Range,
    check_number,
    show,
)
from dualmech.models.simulation import Simulation
from dualmech.models.slider_crank import analyze

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
#: ``progress(t, duration, "")``: the simulated time reached, of the whole (the command line shows it).
Progress = Callable[[float, float, str], None]


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


# ----------------------------------------------------------------------------- simulation

class _Stopped(Exception):
    """Raised inside the right-hand side to end an integration early, with where and why."""

    def __init__(self, t: float, reason: str) -> None:
        super().__init__(reason)
        self.t, self.reason = t, reason


class Budget:
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


def simulate(case: Case, duration: float, *, torque: float | str | LoadFunction | None = None,
             psi0: float | None = None, psidot0: float | None = None, damping: float = 0.0,
             slider_damping: float = 0.0, slider_load: float | str | LoadFunction | None = None,
             samples: int = 1001, method: str = "DOP853", rtol: float = 1e-12, atol: float = 1e-12,
             interpolation_tol: float = 1e-12, model: CoefficientModel | None = None,
             max_evaluations: int = MAX_EVALUATIONS, time_limit: float = TIME_LIMIT,
             progress: Progress | None = None) -> Simulation:
    """Integrate the crank's equation of motion from ``t = 0`` to ``duration`` (module docstring).

    Parameters
    ----------
    case, duration : Case, float
        Geometry, bodies, gravity and axial motion :math:`S_1(\\psi)`; the end time (> 0), seconds.
    torque, slider_load : number, expression or function, optional
        Motor torque :math:`\\tau^A` on the crank about +z, and :math:`F = k_4\\cdot` (force of the
        ground on the slider) excluding ``slider_damping``; a function is called as
        ``f(t, psi, psidot, s4, s4dot)``, an expression may use those names (:func:`load_expression`).
        Default: the case's ``drive_torque`` (torque mode) or ``slider_force`` (force mode), else 0.
    psi0, psidot0 : float, optional
        Initial crank angle :math:`\\theta_1` (rad), speed (rad/s); default the first angle, ``crank_rpm``.
    damping, slider_damping : float
        Viscous :math:`c_1` (torque·s/rad) of the crank bearing, :math:`c_4` (force·s/length) of the guide.
    samples, method, rtol, atol : int, str, float, float
        Equally spaced output times (>= 2, both ends included) and the solve_ivp settings (``atol``
        scaled per state component).
    interpolation_tol, model : float, CoefficientModel, optional
        The relative accuracy asked of the coefficient table, or a :class:`CoefficientModel` built before.
    max_evaluations, time_limit : int, float
        The budget: right-hand-side evaluations and wall time (s), then a one-line ``ValueError``.
    progress : callable, optional
        ``progress(t, duration, "")`` at every right-hand-side evaluation (the command line's display).

    Returns
    -------
    Simulation

    Raises
    ------
    TypeError, ValueError
        One line: ``case`` is not a Case, an input out of its range (every number is checked first:
        ``docs/conventions.md``, "Input ranges"), a load that is not a finite real number, the budget
        used up, or a motion that runs away.
    """
    if not isinstance(case, Case):
        raise TypeError(f"case: expected a dualmech.Case (from dualmech.Case or load_case), got {show(case)}")
    duration, damping, slider_damping, rtol, atol, interpolation_tol = checked_settings(
        duration, damping, slider_damping, rtol, atol, interpolation_tol, samples, method)
    budget, loads = Budget(max_evaluations, time_limit), case.loads
    tau_a = as_load(torque, loads.drive_torque if loads.mode == "torque" else 0.0, "torque", TORQUE)
    force = as_load(slider_load, loads.slider_force if loads.mode == "force" else 0.0, "slider_load", FORCE)
    psi0 = (float(np.radians(case.motion.angles_deg[0])) if psi0 is None
            else check_number("psi0", psi0, CRANK_ANGLE))
    psidot0 = case.motion.speed if psidot0 is None else check_number("psidot0", psidot0, CRANK_SPEED)
    model = coefficient_model(case, interpolation_tol) if model is None else model
    rhs = _EquationOfMotion(model, tau_a, force, damping, slider_damping)
    sol = integrate(rhs, budget, np.array([psi0, psidot0, 0.0, 0.0, 0.0]),
                     np.linspace(0.0, duration, int(samples)), method, rtol, atol, progress)
    info = {"method": method, "rtol": rtol, "atol": atol, "nfev": int(sol.nfev), "coefficients": model.mode,
            "table_size": model.size, "interpolation_error": model.error, "message": sol.message}
    return _trajectory(case, rhs, sol.t, sol.y, info)


def checked_settings(duration: float, damping: float, slider_damping: float, rtol: float, atol: float,
                      interpolation_tol: float, samples: int, method: str) -> tuple[float, ...]:
    """The numbers of :func:`simulate` checked against their ranges (as floats, in order); a one-line
    ValueError unless each is in range, ``samples`` an integer and ``method`` a solve_ivp method."""
    numbers = (check_number("duration", duration, DURATION), check_number("damping", damping, DAMPING),
               check_number("slider_damping", slider_damping, DAMPING), check_number("rtol", rtol, RTOL),
               check_number("atol", atol, ATOL),
               check_number("interpolation_tol", interpolation_tol, INTERPOLATION_TOL))
    if isinstance(samples, (bool, np.bool_)) or not isinstance(samples, (int, np.integer)) \
            or not 2 <= samples <= MAX_SAMPLES:
        raise ValueError(f"samples: expected an integer from 2 to {MAX_SAMPLES:,}, got {show(samples)}")
    if method not in METHODS:
        raise ValueError(f"method: {show(method)} is not a solve_ivp method (valid: {', '.join(METHODS)})")
    return numbers


@dataclass(frozen=True)
class _EquationOfMotion:
    """The right-hand side of the equation of motion (module docstring) for the state
    ``y = (psi, psi_dot, W^A, W^S, D)``: the crank angle and speed, the work of the motor and of the
    slider load, and the energy dissipated by the dampers."""

    model: CoefficientModel
    torque: LoadFunction
    slider_load: LoadFunction
    damping: float
    slider_damping: float

    def __call__(self, t: float, y: np.ndarray) -> np.ndarray:
        psi, w = y[0], y[1]
        inertia, d_inertia, grav, s4, s4p = self.model(psi)[:, 0]
        s4dot = s4p * w
        ta = self.torque(t, psi, w, s4, s4dot)
        f = self.slider_load(t, psi, w, s4, s4dot)
        damper = gi.damping_force(w, s4p, self.damping, self.slider_damping)
        tau = ta + grav + gi.slider_force(s4p, f) + damper
        acc = gi.acceleration(inertia, d_inertia, w, tau)
        return np.array([w, acc, ta * w, -f * s4dot, self.damping * w * w + self.slider_damping * s4dot**2])


def integrate(rhs: _EquationOfMotion, budget: Budget, y0: np.ndarray, t_out: np.ndarray, method: str,
               rtol: float, atol: float, progress: Progress | None = None):
    """``solve_ivp`` of ``rhs`` from ``y0`` over ``t_out`` within ``budget`` (``atol`` scaled per state);
    a one-line ValueError where it stops early; ``progress(t, t_out[-1], "")`` at every evaluation."""
    from scipy.integrate import solve_ivp  # here: scipy costs 0.33 s of every command's start-up

    def counted_rhs(t: float, y: np.ndarray) -> np.ndarray:
        budget.spend(t)
        if progress is not None:
            progress(t, duration, "")
        dy = rhs(t, y)
        if not np.isfinite(dy).all():
            raise _Stopped(t, f"the state or its rate is not finite (psi = {y[0]:.6g} rad, "
                              f"psidot = {y[1]:.6g} rad/s): the motion runs away")
        if abs(y[1]) > CRANK_SPEED.high:
            raise _Stopped(t, f"the crank speed {y[1]:.6g} rad/s passed {CRANK_SPEED.high:.6g} rad/s, "
                              "the largest a case may have: the motion runs away")
        return dy

    duration = t_out[-1]
    w_scale = max(abs(y0[1]), 1.0)
    e_scale = max(abs(rhs.model(y0[0])[0, 0]) * w_scale**2, 1.0)
    atol_vec = atol * np.array([1.0, w_scale, e_scale, e_scale, e_scale])
    budget.start()
    try:
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):  # non-finite rates: _Stopped
            sol = solve_ivp(counted_rhs, (0.0, duration), y0, method=method, t_eval=t_out, rtol=rtol,
                            atol=atol_vec)
    except _Stopped as stop:
        raise ValueError(f"simulate: stopped at t = {stop.t:.6g} s of {duration:g} s: "
                         f"{stop.reason}") from None
    if not sol.success:
        raise ValueError(f"simulate: the integrator stopped at t = {sol.t[-1]:.6g} s of {duration:g} s: "
                         f"{str(sol.message).splitlines()[0]}")
    if progress is not None:  # the last evaluation may fall short of the end (a stage inside the last step)
        progress(duration, duration, "")
    return sol


def _trajectory(case: Case, rhs: _EquationOfMotion, t: np.ndarray, y: np.ndarray, info: dict) -> Simulation:
    """The in-house kinematics, loads, energies and reactions along an integrated motion ``y`` ``(5, n)``."""
    psi, w = y[0], y[1]
    acc = np.array([rhs(ti, yi)[1] for ti, yi in zip(t, y.T)])
    an = analyze(case, case.crank_state(psi, w, acc))
    s4dot = an.rates.q_dot[:, 0]
    ta = np.array([rhs.torque(*v) for v in zip(t, psi, w, an.s4, s4dot)])
    f = np.array([rhs.slider_load(*v) for v in zip(t, psi, w, an.s4, s4dot)])
    bodies, gravity = case.bodies.ordered, case.loads.gravity
    reactions = solve_reactions(bodies, an.motions, an.p2, an.p3, case.geometry.k4, gravity,
                                np.full(psi.shape, np.nan), f + rhs.slider_damping * s4dot, an.moment_axis)
    kinetic = sum(kinetic_energy(b, m) for b, m in zip(bodies, an.motions))
    masses = np.array([b.mass for b in bodies])
    potential = gi.potential_energy(masses, gravity, np.stack([m.com for m in an.motions]))
    status = np.where(is_status(an.status, *RATES_GIVEN), Status.OK.value, an.status).astype(object)
    return Simulation(case, t, psi, w, acc, an.crank.s, an.s4, s4dot, an.rates.q_ddot[:, 0], ta, f,
                      kinetic, potential, y[2], y[3], y[4], reactions, an.transmission, status, info)


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
    if abs(math.cos(g.slider_twist)) >= PLANAR_TWIST_COSINE:
        raise ValueError(f"geometry.slider_twist_deg: {g.slider_twist_deg!r} is not planar; expected 90 or "
                         "270")
    if g.crank_axial_shift != 0.0 or case.motion.axial_amplitude != 0.0:
        raise ValueError(f"geometry.crank_axial_shift: the planar model needs S1 = 0 (got shift "
                         f"{g.crank_axial_shift!r}, amplitude {case.motion.axial_amplitude!r})")
    f, k4 = g.foot, g.k4
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
