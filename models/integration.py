"""Integrating one input's equation of motion, for every kind's forward dynamics: the inputs' ranges, load
functions, the evaluation and wall-time budget, and ``solve_ivp`` with its checks.

The slider crank's equation (:mod:`dualmech.models.slider_crank.forward_dynamics`), the RSSR's and RCCC's
(:mod:`dualmech.models.linkages.forward_dynamics`) and a loop table's
(:mod:`dualmech.models.loop.forward_dynamics`) each give a right-hand side; this module integrates it the
same way for all of them.
"""

from __future__ import annotations

import math
import time
from typing import Any, Callable

import numpy as np

from dualmech.models.expressions import LoadFunction, load_expression
from dualmech.models.inputs import MAX_ANGLE_DEG, MAX_CRANK_RPM, SCALE, TORQUE, Range, check_number, show

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


def integrate(rhs: Any, budget: Budget, y0: np.ndarray, t_out: np.ndarray, method: str,
               rtol: float, atol: float, progress: Progress | None = None):
    """``solve_ivp`` of ``rhs`` (a right-hand side ``rhs(t, y)`` of the state ``(psi, psi_dot, ...)`` with
    its coefficient ``model``, whose ``model(psi)[0, 0]`` is the inertia) from ``y0`` over ``t_out`` within
    ``budget`` (``atol`` scaled per state);
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
