"""The slider crank's :class:`~dualmech.models.tolerance.plan.TolerancePlan`: its compiled kernel's arrays
(:mod:`~dualmech.models.tolerance.designs`), its outputs (:mod:`~dualmech.models.tolerance.outputs`) and
its complex-step derivatives (:mod:`~dualmech.models.tolerance.sensitivity`)."""

from __future__ import annotations

import numpy as np

from dualmech.models.case import Case
from dualmech.models.plausibility import masses_line
from dualmech.models.tolerance import sensitivity
from dualmech.models.tolerance.designs import analyse_designs, design_arrays
from dualmech.models.tolerance.differences import slider_crank_points
from dualmech.models.tolerance.outputs import LOAD_GROUPS, design_outputs, output_names, output_units
from dualmech.models.tolerance.plan import TolerancePlan
from dualmech.models.tolerance.spec import KEYS, Spec, design_case, nominal_values


def _analyse(case: Case, spec: Spec, x: np.ndarray, first: int) -> dict[str, np.ndarray]:
    """Every output of the sampled designs ``x`` by the compiled kernel, in blocks."""
    return analyse_designs(design_arrays(case, spec, x, first), case.loads.mode)


PLAN = TolerancePlan(
    keys=lambda case: KEYS,
    nominal_values=nominal_values,
    design=design_case,
    outputs=lambda case: output_names(case.loads.mode),
    units=lambda case: output_units(case.loads.mode, case.units),
    groups=lambda case: LOAD_GROUPS,
    mode=lambda case: case.loads.mode,
    table_outputs=lambda tables, case: design_outputs(tables, case.loads.mode),
    analyse=_analyse,
    sensitivities=sensitivity.sensitivities,
    points=slider_crank_points,
    masses=masses_line,
    method="complex step through the numpy solver (exact)",
)
