r"""Every study's exact sensitivities checked against central differences of the compiled solver.

The exact derivatives (:mod:`~dualmech.models.tolerance.sensitivity`) go through the numpy
solver's own code in complex arithmetic; their values are tied to the compiled solver's at the
nominal design.  This check ties their derivatives to the compiled solver too, on every run: each
output is evaluated by
:func:`~dualmech.models.slider_crank_kernel.start_positions` (through
:func:`~dualmech.models.tolerance.designs.design_arrays`, the study's own path) at the crank
angle(s) its derivative is taken at, for the nominal design with one key moved by ``+-h`` and
``+-h/2``, the two central differences combined by Richardson's extrapolation:

.. math:: D_j(h) = \frac{y(x_0 + h e_j) - y(x_0 - h e_j)}{2 h}, \qquad
          D_j = \frac{4 D_j(h_j/2) - D_j(h_j)}{3}, \qquad
          h_j = \mathrm{STEP}\,\min(\sigma_j, |x_{0,j}|)\ (\sigma_j \text{ alone where } x_{0,j} = 0)

with :math:`\sigma_j` the key's standard deviation in the SPEC: a step on the key's own scale,
whatever the unit, and never large enough to flip a positive quantity.  (Richardson because a
peak near a dead centre grows like 1/t: on the thesis mechanism with a4 = 30 the plain central
difference with h = 1e-5 sigma is off by 2e-3, converging as h^2.)  A derivative ``g`` passes
when :math:`|g - D| \le` ``RTOL`` :math:`|D| +` ``ATOL`` :math:`Y / \sigma_j`, ``Y`` the
peak of the output's unit group at the nominal design (a discrepancy whose effect over one
standard deviation of the key is below ``ATOL`` of the peak changes no statistic).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from dualmech.models.case import Case
from dualmech.models.tolerance.designs import analyse_designs, design_arrays
from dualmech.models.tolerance.sensitivity import Sensitivities, output_group
from dualmech.models.tolerance.spec import Spec, nominal_values

#: Step relative to the key's scale: round-off ~ 1e-13 (the solver's relative noise) / 1e-6 = 1e-7 of the
#: peak per sigma; the truncation left by Richardson is of order (h/scale)^4.
STEP = 1e-6
#: Relative agreement required: the issue's bar for the sensitivities.  Worst measured 0.31 of the whole
#: tolerance (tests' force- and torque-mode cases, thesis a4 = 20 and 30 with the bundled SPEC).
RTOL = 1e-6
#: Absolute floor, a share of the output group's peak per standard deviation of the key: the round-off
#: of the differences (1e-7, STEP above).  A derivative 1e-4 off is caught (the tests' deliberate fault).
ATOL = 1e-7


@dataclass(frozen=True)
class DifferenceCheck:
    """The worst disagreement between the exact sensitivities and the solver's central differences."""

    passed: bool
    worst_ratio: float  # |g - D| / (RTOL |D| + ATOL Y / sigma): <= 1 passes
    output: str
    key: str
    exact: float
    difference: float  # the central difference D
    steps: dict[str, float]  # h per key (key units)

    def to_dict(self) -> dict:
        """JSON-ready form (``summary.json``, ``sensitivity_check``)."""
        return {"passed": self.passed, "worst_ratio": self.worst_ratio, "output": self.output,
                "key": self.key,
                "exact": self.exact, "central_difference": self.difference, "steps": self.steps,
                "rtol": RTOL, "atol": ATOL, "method": "central differences of the compiled solver"}


def steps(spec: Spec, x0: np.ndarray) -> np.ndarray:
    """``h`` per key ``(k,)``, key units (module docstring)."""
    sd = np.sqrt([t.variance() for t in spec.tolerances])
    return STEP * np.where(x0 != 0.0, np.minimum(sd, np.abs(x0)), sd)


def central_differences(case: Case, spec: Spec, sens: Sensitivities) -> dict[str, np.ndarray]:
    """``D`` ``(k,)`` per output, at the crank angles of ``sens.positions_deg`` (module docstring)."""
    x0 = nominal_values(case, spec)
    h = steps(spec, x0)
    k = x0.size
    x = np.concatenate([x0 + np.kron(np.eye(k) * h, [[1.0], [-1.0]]) / f for f in (1.0, 2.0)])
    mode = case.loads.mode
    out = {}
    for name, angles in sens.positions_deg.items():
        if not angles:
            out[name] = np.full(k, np.nan)
            continue
        at = case.with_parts(motion=replace(case.motion, angles_deg=np.asarray(angles, dtype=float)))
        y = analyse_designs(design_arrays(at, spec, x), mode)[name].reshape(2, k, 2)
        d = (y[..., 0] - y[..., 1]) / (2.0 * h / np.array([[1.0], [2.0]]))
        out[name] = (4.0 * d[1] - d[0]) / 3.0
    return out


def check_sensitivities(case: Case, spec: Spec, sens: Sensitivities) -> DifferenceCheck:
    """The exact sensitivities against :func:`central_differences` (module docstring)."""
    diffs = central_differences(case, spec, sens)
    sd = np.sqrt([t.variance() for t in spec.tolerances])
    mode = case.loads.mode
    worst = (0.0, "", "", math.nan, math.nan)
    for name, d in diffs.items():
        peaks = [abs(sens.nominal_outputs[n]) for n in output_group(name, mode)]
        scale = max((p for p in peaks if math.isfinite(p)), default=math.nan)
        g = np.array([sens.values[name][key] for key in spec.keys])
        with np.errstate(invalid="ignore"):
            ratio = np.abs(g - d) / (RTOL * np.abs(d) + ATOL * scale / sd)
        # NaN on both sides: no position to differentiate at; on one side only: a failure
        ratio = np.where(np.isnan(g) & np.isnan(d), 0.0, np.nan_to_num(ratio, nan=np.inf))
        j = int(np.argmax(ratio))
        if ratio[j] > worst[0]:
            worst = (float(ratio[j]), name, spec.keys[j], float(g[j]), float(d[j]))
    h = steps(spec, nominal_values(case, spec))
    return DifferenceCheck(worst[0] <= 1.0, *worst, dict(zip(spec.keys, map(float, h))))
