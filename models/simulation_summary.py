"""What ``dualmech simulate`` prints about a simulation of each kind: span, final state, loads, energy.

Each kind names its function in :data:`~dualmech.models.kinds.KIND_HOMES` (``sim_summary``): the slider
crank's is here, the other kinds' beside their simulations, each through :func:`simulation_summary`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from dualmech.core.table import NUMERIC_COLUMNS, ResultTable
from dualmech.models.design_summary import design_summary
from dualmech.models.plausibility import masses_line

if TYPE_CHECKING:
    from dualmech.models.simulation import Simulation


def slider_crank_summary(sim: Simulation) -> str:
    """A few lines: span, final state, the body masses and the peak joint loads with units (over the samples;
    at their crank angle, unwrapped), energy balance, integrator facts."""
    columns, nan = sim.columns(), np.full(sim.t.shape, np.nan)
    table = ResultTable("dualmech", sim.case.name, {c: columns.get(c, nan) for c in NUMERIC_COLUMNS},
                        sim.status)
    summary = design_summary(table, sim.case.units)
    span = f"slider S4: {np.nanmin(sim.s4):.6g} .. {np.nanmax(sim.s4):.6g} {summary.length_unit}".rstrip()
    peaks = [f"peak {p}" for p in summary.peaks if np.isfinite(p.value)]
    middle = "\n".join([span, masses_line(sim.case), *peaks])
    return simulation_summary(sim, middle, (sim.work_drive,))


def simulation_summary(sim: Any, middle: str, works: tuple[np.ndarray, ...], driven: str = "crank") -> str:
    """Span, the ``driven`` angle, ``middle``, the work-energy residual over the largest of the kinetic energy
    and ``works``, the integrator."""
    e_scale = max(float(np.abs(sim.kinetic).max()), *(float(np.abs(w).max()) for w in works), 1e-300)
    info = sim.info
    lines = [
        f"case {sim.case.name}: {len(sim.t)} samples over {sim.t[-1]:.6g} s",
        f"{driven}: {np.degrees(sim.psi[0]):.6g} -> {np.degrees(sim.psi[-1]):.6g} deg "
        f"({(sim.psi[-1] - sim.psi[0]) / (2 * np.pi):.4g} rev), "
        f"speed {sim.psi_dot[0]:.6g} -> {sim.psi_dot[-1]:.6g} rad/s",
        middle,
        f"work-energy residual: {np.abs(sim.energy_residual()).max() / e_scale:.3g} (relative to the energy "
        "scale)",
        f"integrator {info['method']} rtol={info['rtol']:g} atol={info['atol']:g}, {info['nfev']} "
        "evaluations; "
        f"coefficients: {info['coefficients']}"
        + (f" ({info['table_size']} samples, interpolation error {info['interpolation_error']:.2g})"
           if info["coefficients"] == "table" else ""),
    ]
    return "\n".join(lines)
