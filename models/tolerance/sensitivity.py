"""Exact first derivatives of every design output with respect to every varied key, at the nominal design.

Method (stated, as the issue asks): **a second nilpotent unit, carried through the solver's own code.**

* **The unit.**  Numbers :math:`x + \\delta x'` with :math:`\\delta = ih`, ``h =`` :data:`STEP`:
  :math:`\\delta^2 = -h^2 = -10^{-200}` vanishes against 1 in double precision, so wherever the
  arithmetic is analytic the imaginary part over ``h`` is the forward-mode derivative, with no
  subtraction and no truncation error (the complex step, Squire & Trapp 1998).  One direction per key.
* **Into the case.**  The case's numbers are built by the case loader's own
  :func:`~dualmech.models.case.case_numbers`, reading the varied key as its checked value plus
  :math:`\\delta`: the speed from the rpm, the bodies' masses and inertias from their shapes and
  densities carry the derivative by the loader's code.
* **Through the closure: the implicit function theorem by Newton's step.**  The real nominal
  positions are closed by the numpy solver (:func:`~dualmech.models.slider_crank.closure.close_loop`,
  the compiled kernel's oracle); two Newton steps of the solver's own loop equation, screws and
  LU solve in complex arithmetic (:func:`~dualmech.core.closure.polish`) then give the unknowns
  :math:`x + \\delta\\, dx/dp` with :math:`dx/dp = -J_x^{-1} g_p`.
* **Everything downstream by the same unit**: the solver's rates and accelerations
  (:func:`~dualmech.core.rates.solve_rates`), body motions, dual momentum and D'Alembert reactions
  (:func:`~dualmech.core.reactions.solve_reactions`), the whole of
  :func:`~dualmech.models.slider_crank.analysis.analyze_closed`, whose numpy core is generic in the scalar
  type
  (:func:`~dualmech.core.dual.scalar_type`).
* **Peaks.**  The derivative of a peak is the derivative of the output at the crank position of
  the maximum (of ``stroke``: at the positions of max and min ``S4``), the positions being those
  of :func:`~dualmech.models.tolerance.outputs.peak_positions` on the solver's nominal table; it is
  the derivative of the sampled output wherever the maximising position does not change.
  ``assembled_fraction`` is piecewise constant: not differentiated.
* **Tied to the solver.**  The real parts must reproduce the compiled solver's outputs at those
  positions to :data:`VALUE_AGREEMENT`, with the same position statuses (else
  :class:`SensitivityError`).  ``tests/models/tolerance/test_sensitivity.py`` holds the derivatives to
  central differences of the solver's outputs.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from dualmech.core.closure import polish
from dualmech.core.loop import LoopState
from dualmech.core.table import ResultTable
from dualmech.models.case import Case, case_numbers
from dualmech.models.inputs import Range, check_number
from dualmech.models.slider_crank.analysis import Analysis, analyze_closed, solve_case
from dualmech.models.slider_crank.closure import close_loop
from dualmech.models.slider_crank.loop import LOOP, Batch
from dualmech.models.tolerance.outputs import (
    FORCES,
    LOAD_GROUPS,
    MOMENTS,
    SOLVED_LOAD,
    design_outputs,
    group_of,
    output_names,
    peak_positions,
)
from dualmech.models.tolerance.spec import Spec, design_case, nominal_values

#: Imaginary step ``h``: h^2 = 1e-200 is below double precision against 1, and products of two
#: imaginary parts (~1e-200 x values) stay far above the smallest normal float.
STEP = 1e-100
#: Relative agreement required between the real parts and the compiled solver's outputs (the numpy
#: core is the kernel's oracle to 1e-12 of the case peak; this leaves room for the outputs' own scale).
VALUE_AGREEMENT = 1e-9


class SensitivityError(RuntimeError):
    """The derivative run does not reproduce the solver's outputs at the nominal design."""


@dataclass(frozen=True)
class Sensitivities:
    """``d output / d key`` at the nominal design: ``values[output][key]`` (output units per key unit)."""

    values: dict[str, dict[str, float]]
    nominal_outputs: dict[str, float]
    positions_deg: dict[str, list[float]]  # crank angle(s) each derivative is taken at


def _seeded(key: str):
    """A :data:`~dualmech.models.inputs.NumberReader`: the checked number, plus ``i h`` on ``key``."""
    def number(name: str, value: Any, limits: Range) -> float | complex:
        checked = check_number(name, value, limits)
        return checked + 1j * STEP if name == key else checked
    return number


def _seeded_case(design: Case, key: str) -> Case:
    """``design`` with its numbers read again, ``key`` carrying the imaginary step."""
    geometry, motion, bodies, loads = case_numbers(design.raw, _seeded(key))
    return design.with_parts(geometry=geometry, motion=motion, bodies=bodies, loads=loads)


def _derivative_runs(design: Case, keys: tuple[str, ...], angles_deg: np.ndarray) -> list[Analysis]:
    """The analysis of ``design`` at ``angles_deg``, once per key with that key seeded (module docstring)."""
    crank = design.own_crank_states(angles_deg)
    state, status, iters, residual = close_loop(Batch.of([design], [crank]))
    seeded = [_seeded_case(design, key) for key in keys]
    cranks = [c.own_crank_states(angles_deg) for c in seeded]
    batch = Batch.of(seeded, cranks)
    k = len(keys)
    start = LoopState(np.tile(state.scalars, (k, 1)).astype(complex),
                      np.tile(state.rotations, (k, 1, 1, 1)).astype(complex))
    closed = (polish(LOOP, batch.inputs(), start), *(np.tile(a, k) for a in (status, iters, residual)))
    return analyze_closed(seeded, cranks, batch, closed)


def _outputs(an: Analysis, at: dict[int, int], where: dict[str, tuple[np.ndarray, ...]],
             mode: str) -> dict[str, complex]:
    """Every output of the design from ``an`` (rows ``at[table row]``), complex: value + i h derivative."""
    cols = an.reactions.columns()
    out: dict[str, complex] = {}
    hi, lo = (int(w[0]) for w in where["stroke"])
    out["stroke"] = an.s4[at[hi]] - an.s4[at[lo]] if min(hi, lo) >= 0 else complex("nan")
    for name, prefix in FORCES + MOMENTS:
        i = int(where[name][0][0])
        vec = [cols[f"{prefix}{axis}"][at[i]] for axis in "xyz"] if i >= 0 else None
        out[name] = np.sqrt(sum(v * v for v in vec)) if vec else complex("nan")
    name, column = SOLVED_LOAD[mode]
    i = int(where[name][0][0])
    value = cols[column][at[i]] if i >= 0 else complex("nan")
    out[name] = value * np.sign(value.real)
    return out


def output_group(name: str, mode: str) -> tuple[str, ...]:
    """The outputs of ``name``'s unit (length, force or moment) in load mode ``mode``: a value near 0 is
    judged by their peak (:func:`~dualmech.models.tolerance.outputs.group_of`)."""
    return tuple(n for n in group_of(name, LOAD_GROUPS) if n in output_names(mode))


def sensitivities(case: Case, spec: Spec, table: ResultTable | None = None) -> Sensitivities:
    """``d output / d key`` of every output of :func:`~dualmech.models.tolerance.outputs.output_names`
    and every key of ``spec`` at the nominal ``case`` (module docstring).

    ``table`` is the solver's nominal result table (solved here if not given).
    """
    mode = case.loads.mode
    table = solve_case(case) if table is None else table
    where = {name: tuple(w[:1] for w in idx) for name, idx in peak_positions([table], mode).items()}
    rows = np.unique(np.concatenate([np.concatenate(w) for w in where.values()]))
    rows = rows[rows >= 0]
    at = {int(r): i for i, r in enumerate(rows)}
    design = design_case(case, spec, nominal_values(case, spec), case.name)
    runs = _derivative_runs(design, spec.keys, table["theta1_deg"][rows])
    solved = design_outputs([table], mode)
    solver = {n: float(solved[n][0]) for n in output_names(mode)}
    values: dict[str, dict[str, float]] = {n: {} for n in output_names(mode)}
    for key, run in zip(spec.keys, runs):
        if list(run.status) != list(table.status[rows]):
            raise SensitivityError(f"sensitivity: the statuses at the peak positions {run.status.tolist()} "
                                   f"differ from the solver's {table.status[rows].tolist()}")
        out = _outputs(run, at, where, mode)
        for name in values:
            _check_value(name, out[name].real, solver, mode)
            values[name][key] = float(out[name].imag / STEP)
    theta = table["theta1_deg"]
    positions = {n: [float(theta[int(w[0])]) for w in idx if int(w[0]) >= 0] for n, idx in where.items()}
    return Sensitivities(values, solver, positions)


def _check_value(name: str, got: float, solver: dict[str, float], mode: str) -> None:
    """The derivative run's value of output ``name`` must be the compiled solver's (:data:`VALUE_AGREEMENT`
    of its output group's peak)."""
    want = solver[name]
    scale = max(abs(solver[n]) for n in output_group(name, mode) if np.isfinite(solver[n]))
    if np.isfinite(want) and not abs(got - want) <= VALUE_AGREEMENT * scale:
        raise SensitivityError(f"sensitivity: {name} = {got!r} in the derivative run differs from the "
                               f"solver's {want!r}")
