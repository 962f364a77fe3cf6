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
and acceleration analysis, tabulated by :mod:`dualmech.models.slider_crank.dynamics_coefficients`.
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
from dataclasses import dataclass

import numpy as np

from dualmech.core import generalized_inertia as gi
from dualmech.core.planar import PlanarSliderCrank
from dualmech.core.reactions import kinetic_energy, solve_reactions
from dualmech.core.status import RATES_GIVEN, Status, is_status
from dualmech.models import integration as ig
from dualmech.models.case import PLANAR_TWIST_COSINE, Case
from dualmech.models.expressions import LoadFunction
from dualmech.models.inputs import (
    FORCE,
    TORQUE,
    check_number,
    show,
)
from dualmech.models.integration import as_load
from dualmech.models.simulation import Simulation
from dualmech.models.slider_crank.analysis import analyze
from dualmech.models.slider_crank.dynamics_coefficients import CoefficientModel, coefficient_model


def simulate(case: Case, duration: float, *, torque: float | str | LoadFunction | None = None,
             psi0: float | None = None, psidot0: float | None = None, damping: float = 0.0,
             slider_damping: float = 0.0, slider_load: float | str | LoadFunction | None = None,
             samples: int = 1001, method: str = "DOP853", rtol: float = 1e-12, atol: float = 1e-12,
             interpolation_tol: float = 1e-12, model: CoefficientModel | None = None,
             max_evaluations: int = ig.MAX_EVALUATIONS, time_limit: float = ig.TIME_LIMIT,
             progress: ig.Progress | None = None) -> Simulation:
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
    duration, damping, slider_damping, rtol, atol, interpolation_tol = ig.checked_settings(
        duration, damping, slider_damping, rtol, atol, interpolation_tol, samples, method)
    budget, loads = ig.Budget(max_evaluations, time_limit), case.loads
    tau_a = as_load(torque, loads.drive_torque if loads.mode == "torque" else 0.0, "torque", TORQUE)
    force = as_load(slider_load, loads.slider_force if loads.mode == "force" else 0.0, "slider_load", FORCE)
    psi0 = (float(np.radians(case.motion.angles_deg[0])) if psi0 is None
            else check_number("psi0", psi0, ig.CRANK_ANGLE))
    psidot0 = case.motion.speed if psidot0 is None else check_number("psidot0", psidot0, ig.CRANK_SPEED)
    model = coefficient_model(case, interpolation_tol) if model is None else model
    rhs = _EquationOfMotion(model, tau_a, force, damping, slider_damping)
    sol = ig.integrate(rhs, budget, np.array([psi0, psidot0, 0.0, 0.0, 0.0]),
                       np.linspace(0.0, duration, int(samples)), method, rtol, atol, progress)
    info = {"method": method, "rtol": rtol, "atol": atol, "nfev": int(sol.nfev), "coefficients": model.mode,
            "table_size": model.size, "interpolation_error": model.error, "message": sol.message}
    return _trajectory(case, rhs, sol.t, sol.y, info)


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
