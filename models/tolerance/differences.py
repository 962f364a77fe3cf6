r"""Every study's exact sensitivities checked against central differences of the compiled solver.

The exact derivatives (:mod:`~dualmech.models.tolerance.sensitivity`) go through the numpy
solver's own code in complex arithmetic; their values are tied to the compiled solver's at the
nominal design.  This check ties their derivatives to the compiled solver too, on every run: each
output is evaluated by
:func:`~dualmech.models.slider_crank.kernel.start_positions` (through
:func:`~dualmech.models.tolerance.designs.design_arrays`, the study's own path) at the crank
angle(s) its derivative is taken at, for the nominal design with one key moved by ``+-h`` and
``+-h2`` (``h2 ~ h/2``), the two central differences combined by Richardson's extrapolation:

.. math:: D_j(h) = \frac{y(x_0 + h e_j) - y(x_0 - h e_j)}{2 h}, \qquad
          D_j = \frac{q^2 D_j(h_2) - D_j(h)}{q^2 - 1}, \quad q = h / h_2.

**Steps exactly representable.**  A target step
:math:`\tilde h_j = \mathrm{STEP}\,\min(\max(\sigma_j, \mathrm{MIN\_SCALE}\,|x_{0,j}|), |x_{0,j}|)`
(:math:`\sigma_j` alone where :math:`x_{0,j} = 0`; ``sigma`` the key's standard deviation in the SPEC: a
step on the key's own scale, never large enough to flip a positive quantity, never so small that the
differences keep no digits) is replaced by :math:`h = (x_0 + \tilde h) - x_0` computed in floating
point: that difference is exact (Sterbenz), so :math:`x_0 \pm h` are floats and the quotient divides by
the step actually taken (a 0.001 in tolerance on a 50 in rod asked for 50 + 1e-9, which is
50 + 1.00044e-9: 4.4e-4 off).  Likewise ``h2`` from :math:`\tilde h / 2`.

**A bound from the check's own errors.**  A derivative ``g`` passes when
:math:`|g - D| \le \mathrm{RTOL}\,|D| + T + R`:

* ``T``, the truncation: Richardson removes the :math:`h^2` term, and what it removed,
  :math:`|D(h_2) - D(h)| / (q^2 - 1)`, bounds what is left (the :math:`h^4` term is smaller by
  :math:`(h/\ell)^2`, ``l`` the output's scale of variation; near a dead centre a peak grows like 1/t and
  ``l`` is small: there ``T`` is large, as it should be);
* ``R``, the rounding: each output carries a rounding ``nu``, measured at the nominal design by
  :data:`NOISE_POINTS` evaluations a few ulps of ``x0`` apart (where the true change is linear and far
  below ``nu``), at least :data:`NOISE_FLOOR` ulps of the peak ``Y`` of the output's unit group, so
  :math:`|D(h)| \text{ errs by } \le \nu / h` and Richardson by
  :math:`R = \mathrm{NOISE\_MARGIN}\,\nu\,(q^2/h_2 + 1/h)/(q^2 - 1)`.

An output that is the solver's round-off at the nominal design (reported as 0, "not a load":
:func:`~dualmech.models.tolerance.summary.round_off_outputs`) has no derivative to check.  Neither term
depends on ``sigma``, so a large ``sd`` (1e9) no longer shrinks the bound to nothing, and a
tiny one (1e-300) no longer makes a zero step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from dualmech.models.case import Case
from dualmech.models.tolerance.designs import analyse_designs, design_arrays
from dualmech.models.tolerance.outputs import group_of
from dualmech.models.tolerance.plan import StudyCase, TolerancePlan, plan_of, record_of
from dualmech.models.tolerance.sensitivity import Sensitivities
from dualmech.models.tolerance.spec import Spec
from dualmech.models.tolerance.summary import round_off_outputs

#: Step relative to the key's scale: truncation after Richardson ~ (h/scale)^4, rounding nu/h (both bounded
#: in the check); 1e-6 keeps the h^2 term Richardson removes near a dead centre (plain central differences
#: at 1e-5 sigma were 2e-3 off on the thesis mechanism, a4 = 30) far below RTOL.
STEP = 1e-6
#: The key's scale is at least this share of its value: a tiny sd (1e-300) may not ask a step of no digits.
MIN_SCALE = 1e-3
#: Relative agreement required beyond the bound's truncation and rounding: the issue's bar.
RTOL = 1e-6
#: Evaluations beside the nominal design that measure an output's rounding nu (module docstring), and
#: their spacing in ulps of the key's value (of its step, for a key at 0).
NOISE_POINTS, NOISE_ULPS = 4, 4
_EPS = float(np.finfo(float).eps)
#: The rounding measured by NOISE_POINTS samples is a lower estimate of its largest value: this margin.
NOISE_MARGIN = 2.0
#: The least rounding of an output, in ulps of its unit group's peak Y: where a few ulps of x0 change no bit
#: of the output the samples see none, yet every value is rounded to its ulp and sums of the group's terms
#: carry a few (measured: d peak_j3_force / d rod_radius, force mode, 0.4 ulp of Y off at h = 1e-7).
NOISE_FLOOR = 4.0


@dataclass(frozen=True)
class DifferenceCheck:
    """The worst disagreement between the exact sensitivities and the solver's central differences."""

    passed: bool
    worst_ratio: float  # |g - D| / (RTOL |D| + T + R): <= 1 passes
    output: str
    key: str
    exact: float
    difference: float  # the central difference D
    steps: dict[str, float]  # h per key (key units), exactly the step taken
    bound: float = math.nan  # RTOL |D| + T + R of the worst derivative

    def to_dict(self) -> dict:
        """JSON-ready form (``summary.json``, ``sensitivity_check``)."""
        return {"passed": self.passed, "worst_ratio": self.worst_ratio, "output": self.output,
                "key": self.key,
                "exact": self.exact, "central_difference": self.difference, "steps": self.steps,
                "bound": self.bound, "rtol": RTOL,
                "method": "central differences of the solver, exact steps, Richardson; bound "
                          "RTOL |D| + truncation + rounding"}


def exact_step(x0: np.ndarray, h: np.ndarray) -> np.ndarray:
    """``(x0 + h) - x0`` in floating point, shape of ``x0``: the step actually taken, exact (Sterbenz), so
    that ``x0 + step`` and ``x0 - step`` are floats."""
    return (x0 + h) - x0


def steps(spec: Spec, x0: np.ndarray, step: float = STEP) -> tuple[np.ndarray, np.ndarray]:
    """``(h, h2)`` per key, each ``(k,)``, key units, exactly representable (module docstring); ``step`` the
    step relative to the key's scale."""
    sd = np.array([t.std() for t in spec.tolerances])
    size = np.abs(x0)
    scale = np.where(x0 != 0.0, np.minimum(np.maximum(sd, MIN_SCALE * size), size), sd)
    target = np.maximum(step * scale, 2.0 * np.finfo(float).tiny)  # never a zero step, nor its half
    return exact_step(x0, target), exact_step(x0, 0.5 * target)


@dataclass(frozen=True)
class Differences:
    """Per output, ``(k,)`` each: Richardson's ``D``, its truncation ``T`` and rounding ``R`` bounds."""

    value: dict[str, np.ndarray]
    truncation: dict[str, np.ndarray]
    rounding: dict[str, np.ndarray]


def slider_crank_points(case: Case, spec: Spec, sens: Sensitivities, x: np.ndarray) -> dict[str, np.ndarray]:
    """Every output of the slider-crank designs ``x`` ``(m, k)`` at the crank angle(s) of its derivative
    (``sens.positions_deg``), ``(m,)`` each (NaN where it has none), by the compiled kernel (the study's
    own path, :func:`~dualmech.models.tolerance.designs.design_arrays`)."""
    out = {}
    for name, angles in sens.positions_deg.items():
        if not angles:
            out[name] = np.full(x.shape[0], np.nan)
            continue
        at = case.with_parts(motion=replace(case.motion, angles_deg=np.asarray(angles, dtype=float)))
        out[name] = analyse_designs(design_arrays(at, spec, x), case.loads.mode)[name]
    return out


def central_differences(case: StudyCase, spec: Spec, sens: Sensitivities, plan: TolerancePlan,
                        step: float = STEP) -> Differences:
    """``D``, ``T`` and ``R`` per output at the drive positions of ``sens.positions_deg`` (module docstring),
    the outputs by the kind's ``plan.points``; ``step`` relative to each key's scale."""
    x0 = plan.nominal_values(case, spec)
    h, h2 = steps(spec, x0, step)
    k = x0.size
    eye = np.eye(k)
    moves = [eye * h, -eye * h, eye * h2, -eye * h2]
    ulp = NOISE_ULPS * np.spacing(np.maximum(np.abs(x0), h))  # a key at 0: ulps of its step
    moves += [eye * (m * ulp) for m in range(NOISE_POINTS + 1)]
    points = plan.points(case, spec, sens, np.concatenate([x0 + m for m in moves]))
    q2 = np.square(h / h2)
    groups = plan.groups(record_of(case))
    value, truncation, rounding = {}, {}, {}
    for name, y in points.items():
        y = y.reshape(len(moves), k)
        d1, d2 = (y[0] - y[1]) / (2.0 * h), (y[2] - y[3]) / (2.0 * h2)
        value[name] = (q2 * d2 - d1) / (q2 - 1.0)
        truncation[name] = np.abs(d2 - d1) / (q2 - 1.0)
        near = y[4:]  # at x0 + m ulp, m = 0..NOISE_POINTS: their departure from a line is rounding
        line = near[0] + np.outer(np.arange(NOISE_POINTS + 1), near[1] - near[0])
        noise = np.max(np.abs(near - line), axis=0)
        peaks = [abs(sens.nominal_outputs[n]) for n in group_of(name, groups) if n in sens.nominal_outputs]
        floor = NOISE_FLOOR * _EPS * max((p for p in peaks if math.isfinite(p)), default=0.0)
        rounding[name] = NOISE_MARGIN * np.maximum(noise, floor) * (q2 / h2 + 1.0 / h) / (q2 - 1.0)
    return Differences(value, truncation, rounding)


def check_sensitivities(case: StudyCase, spec: Spec, sens: Sensitivities) -> DifferenceCheck:
    """The sensitivities against :func:`central_differences` of the kind's solver (module docstring)."""
    plan = plan_of(case)
    diffs = central_differences(case, spec, sens, plan)
    # round-off, reported as 0: no derivative to check
    zero = round_off_outputs(sens.nominal_outputs, None, plan.groups(record_of(case)))
    worst = (0.0, "", "", math.nan, math.nan, math.nan)
    for name, d in diffs.value.items():
        if name in zero:
            continue
        g = np.array([sens.values[name][key] for key in spec.keys])
        bound = RTOL * np.abs(d) + diffs.truncation[name] + diffs.rounding[name]
        with np.errstate(invalid="ignore", divide="ignore"):
            ratio = np.abs(g - d) / bound
        # NaN on both sides: no position to differentiate at; on one side only: a failure
        ratio = np.where(np.isnan(g) & np.isnan(d), 0.0, np.nan_to_num(ratio, nan=np.inf, posinf=np.inf))
        ratio = np.where((g == d), 0.0, ratio)  # equal, whatever the bound (0 / 0 included)
        j = int(np.argmax(ratio))
        if ratio[j] > worst[0]:
            worst = (float(ratio[j]), name, spec.keys[j], float(g[j]), float(d[j]), float(bound[j]))
    h, _ = steps(spec, plan.nominal_values(case, spec))
    ratio, output, key, exact, difference, bound = worst
    return DifferenceCheck(ratio <= 1.0, ratio, output, key, exact, difference,
                           dict(zip(spec.keys, map(float, h))), bound)
