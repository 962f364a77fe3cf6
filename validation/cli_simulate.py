"""``dualmech simulate``: forward dynamics of a case under a given torque (thin shell over
:func:`dualmech.models.forward_dynamics.simulate`)."""

from __future__ import annotations

import sys

import click
import numpy as np

from dualmech.models.case import load_case
from dualmech.validation.cli_errors import one_line_errors


def summarize_simulation(sim) -> str:
    """A few lines: span, final state, energy balance, integrator facts."""
    e_scale = max(float(np.abs(sim.kinetic).max()), float(np.abs(sim.work_drive).max()), 1e-300)
    info = sim.info
    lines = [
        f"case {sim.case.name}: {len(sim.t)} samples over {sim.t[-1]:.6g} s",
        f"crank: {np.degrees(sim.psi[0]):.6g} -> {np.degrees(sim.psi[-1]):.6g} deg "
        f"({(sim.psi[-1] - sim.psi[0]) / (2 * np.pi):.4g} rev), "
        f"speed {sim.psi_dot[0]:.6g} -> {sim.psi_dot[-1]:.6g} rad/s",
        f"slider S4: {np.nanmin(sim.s4):.6g} .. {np.nanmax(sim.s4):.6g}",
        f"work-energy residual: {np.abs(sim.energy_residual()).max() / e_scale:.3g} (relative to the energy scale)",
        f"integrator {info['method']} rtol={info['rtol']:g} atol={info['atol']:g}, {info['nfev']} evaluations; "
        f"coefficients: {info['coefficients']}"
        + (f" ({info['table_size']} samples, interpolation error {info['interpolation_error']:.2g})"
           if info["coefficients"] == "table" else ""),
    ]
    return "\n".join(lines)


@click.command()
@click.argument("case")
@click.option("--duration", type=float, required=True, help="Simulated time, seconds.")
@click.option("--torque", default=None,
              help="Motor torque on the crank about +z: a number or an expression in t, psi, psidot, s4, s4dot "
                   "(default: the case's drive_torque in torque mode, else 0).")
@click.option("--slider-load", default=None,
              help="k4 . (force of the ground on the slider), number or expression as --torque "
                   "(default: the case's slider_force in force mode, else 0). A spring k, free length L0: 'k*(s4-L0)'.")
@click.option("--psi0", type=float, default=None,
              help="Initial crank angle theta1, degrees (default: the case's first angle).")
@click.option("--psidot0", type=float, default=None, help="Initial crank speed, rad/s (default: the case's crank_rpm).")
@click.option("--damping", type=float, default=0.0, show_default=True,
              help="Crank-bearing viscous coefficient, torque*s/rad.")
@click.option("--slider-damping", type=float, default=0.0, show_default=True,
              help="Slider viscous coefficient, force*s/length.")
@click.option("--samples", type=int, default=1001, show_default=True, help="Equally spaced output times.")
@click.option("--rtol", type=float, default=1e-12, show_default=True)
@click.option("--atol", type=float, default=1e-12, show_default=True)
@click.option("--method", default="DOP853", show_default=True, help="scipy solve_ivp method.")
@click.option("-o", "--output", type=click.Path(dir_okay=False), help="CSV file (default: stdout).")
@one_line_errors
def simulate(case: str, duration: float, torque: str | None, slider_load: str | None, psi0: float | None,
             psidot0: float | None, damping: float, slider_damping: float, samples: int, rtol: float, atol: float,
             method: str, output: str | None) -> None:
    """Integrate the crank's equation of motion for CASE; write psi(t), S4(t) and the joint reactions."""
    from dualmech.models.forward_dynamics import simulate as run

    sim = run(load_case(case), duration, torque=torque, slider_load=slider_load,
              psi0=None if psi0 is None else float(np.radians(psi0)), psidot0=psidot0, damping=damping,
              slider_damping=slider_damping, samples=samples, method=method, rtol=rtol, atol=atol)
    if output:
        sim.to_csv(output)
    else:
        sys.stdout.write(sim.to_csv())
    click.echo(summarize_simulation(sim), err=output is None)
