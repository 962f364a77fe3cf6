"""``dualmech simulate``: forward dynamics of a case under a given torque (thin shell over
:func:`dualmech.models.forward_dynamics.simulate`).

Numeric options are read as text and parsed here, so a bad one (``--rtol nan``,
``--duration 1e400``, ``--samples abc``) is one line naming the option, the value and
its range, like every other bad input, rather than click's multi-line usage error.
"""

from __future__ import annotations

import sys

import click
import numpy as np
from click.core import ParameterSource

from dualmech.cli.errors import one_line_errors
from dualmech.cli.progress import progress
from dualmech.cli.solve import warn_units
from dualmech.models.case import load_case
from dualmech.models.forward_dynamics import MAX_EVALUATIONS, TIME_LIMIT
from dualmech.models.inputs import ANGLE_DEG, Range, show
from dualmech.models.linkages import is_linkage
from dualmech.models.plausibility import masses_line

#: Longest integer option text: beyond this many digits it is out of every range anyway.
_MAX_INT_DIGITS = 18


def parse_number(option: str, text: str | None, limits: Range) -> float | None:
    """``text`` as a float within ``limits`` (``None`` stays ``None``); else a one-line ValueError."""
    if text is None:
        return None
    try:
        value = float(text)
    except ValueError:
        raise ValueError(f"{option}: expected a number, {limits.describe()}, got {show(text)}") from None
    return limits.check(option, value)


def parse_count(option: str, text: str, low: int, high: int) -> int:
    """``text`` as an integer from ``low`` to ``high``; else a one-line ValueError."""
    digits = text.strip().lstrip("+-")
    if not digits.isdigit() or len(digits) > _MAX_INT_DIGITS or not low <= int(text) <= high:
        raise ValueError(f"{option}: expected an integer from {low:,} to {high:,}, got {show(text)}")
    return int(text)


def summarize_simulation(sim) -> str:
    """A few lines: span, final state, the body masses and the peak joint loads with units (over the samples;
    at their crank angle, unwrapped), energy balance, integrator facts."""
    from dualmech.core.table import NUMERIC_COLUMNS, ResultTable
    from dualmech.models.design_summary import design_summary

    columns, nan = sim.columns(), np.full(sim.t.shape, np.nan)
    table = ResultTable("dualmech", sim.case.name, {c: columns.get(c, nan) for c in NUMERIC_COLUMNS},
                        sim.status)
    summary = design_summary(table, sim.case.units)
    span = f"slider S4: {np.nanmin(sim.s4):.6g} .. {np.nanmax(sim.s4):.6g} {summary.length_unit}".rstrip()
    peaks = [f"peak {p}" for p in summary.peaks if np.isfinite(p.value)]
    middle = "\n".join([span, masses_line(sim.case), *peaks])
    return _summary(sim, middle, (sim.work_drive,))


def summarize_linkage(sim) -> str:
    """The same for a linkage (:class:`~dualmech.models.linkages.forward_dynamics.LinkageSimulation`): the
    output torque and its work in place of the slider."""
    middle = (f"output torque {sim.output_torque:.6g} (the case's): work {sim.work_output[-1]:.6g}; "
              f"dissipated {sim.dissipated[-1]:.6g}")
    return _summary(sim, middle, (sim.work_drive, sim.work_output))


def summarize_loop(sim) -> str:
    """The same for a loop table (:class:`~dualmech.models.loop.forward_dynamics.LoopSimulation`): the work
    of its given loads in place of the slider."""
    middle = f"given loads: work {sim.work_loads[-1]:.6g}; dissipated {sim.dissipated[-1]:.6g}"
    return _summary(sim, middle, (sim.work_drive, sim.work_loads), "drive")


def _summary(sim, middle: str, works: tuple[np.ndarray, ...], driven: str = "crank") -> str:
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


@click.command()
@click.argument("case")
@click.option("--duration", required=True, help="Simulated time, seconds.")
@click.option("--torque", default=None,
              help="Motor torque on the crank about +z: a number or an expression in t, psi, psidot, s4, "
                   "s4dot "
                   "(default: the case's drive_torque in torque mode, else 0).")
@click.option("--slider-load", default=None,
              help="k4 . (force of the ground on the slider), number or expression as --torque "
                   "(default: the case's slider_force in force mode, else 0). A spring k, free length L0: "
                   "'k*(s4-L0)'.")
@click.option("--psi0", default=None,
              help="Initial crank angle theta1, degrees (default: the case's first angle).")
@click.option("--psidot0", default=None, help="Initial crank speed, rad/s (default: the case's crank_rpm).")
@click.option("--damping", default="0", show_default=True,
              help="Crank-bearing viscous coefficient, torque*s/rad.")
@click.option("--slider-damping", default="0", show_default=True,
              help="Slider viscous coefficient, force*s/length.")
@click.option("--samples", default="1001", show_default=True, help="Equally spaced output times.")
@click.option("--rtol", default="1e-12", show_default=True)
@click.option("--atol", default="1e-12", show_default=True)
@click.option("--method", default="DOP853", show_default=True, help="scipy solve_ivp method.")
@click.option("--max-evaluations", default=str(MAX_EVALUATIONS), show_default=True,
              help="Integrator budget: right-hand-side evaluations; the run stops with one line when "
                   "used up.")
@click.option("--time-limit", default=f"{TIME_LIMIT:g}", show_default=True,
              help="Integrator budget: wall time, seconds; the run stops with one line when used up.")
@click.option("-o", "--output", type=click.Path(dir_okay=False), help="CSV file (default: stdout).")
@one_line_errors
def simulate(case: str, duration: str, torque: str | None, slider_load: str | None, psi0: str | None,
             psidot0: str | None, damping: str, slider_damping: str, samples: str, rtol: str, atol: str,
             method: str, max_evaluations: str, time_limit: str, output: str | None) -> None:
    """Integrate the crank's equation of motion for CASE; write psi(t), S4(t) and the joint reactions.

    A linkage case (``[mechanism] kind`` rssr or rccc) integrates its input's equation of motion under
    --torque (an expression in t, psi, psidot) and the case's output torque, and writes its own columns
    (docs/conventions.md, "Linkages"); a loop table (``kind = "loop"``, driven by an angle) integrates its
    drive's under --torque (the drive effort) and its given loads, and writes the loop table's columns
    (docs/conventions.md, "Loop tables"); --slider-load and --slider-damping apply to neither."""
    from dualmech.models import forward_dynamics as fd

    psi0_deg = parse_number("--psi0", psi0, ANGLE_DEG)
    psi0_rad = None if psi0_deg is None else float(np.radians(psi0_deg))
    if is_linkage(case):
        _refuse_slider_options(case)
        from dualmech.models.linkages import forward_dynamics as lfd
        from dualmech.models.linkages import linkage_case
        from dualmech.models.loop import forward_dynamics as loop_fd
        from dualmech.models.loop.description import LoopMechanism

        settings = _settings(duration, psidot0, damping, None, samples, method, rtol, atol, max_evaluations,
                             time_limit)
        c = linkage_case(case)
        loop = isinstance(c, LoopMechanism)
        with progress(f"simulate {case}", unit="s") as bar:
            run = loop_fd.simulate if loop else lfd.simulate
            sim = run(c, torque=torque, psi0=psi0_rad, progress=bar, **settings)
        summary = summarize_loop(sim) if loop else summarize_linkage(sim)
    else:
        settings = _settings(duration, psidot0, damping, slider_damping, samples, method, rtol, atol,
                             max_evaluations, time_limit)
        c = load_case(case)
        warn_units(c)
        with progress(f"simulate {case}", unit="s") as bar:
            sim = fd.simulate(c, torque=torque, slider_load=slider_load, psi0=psi0_rad, progress=bar,
                              **settings)
        summary = summarize_simulation(sim)
    if output:
        sim.to_csv(output)  # atomic: written beside, renamed
    else:
        sys.stdout.write(sim.to_csv())
    click.echo(summary, err=output is None)


def _settings(duration: str, psidot0: str | None, damping: str, slider_damping: str | None, samples: str,
              method: str, rtol: str, atol: str, max_evaluations: str, time_limit: str) -> dict:
    """The numeric options parsed in order, as keyword arguments of ``simulate`` (``slider_damping`` only if
    given: a linkage has none); a one-line ValueError for a bad one."""
    from dualmech.models import forward_dynamics as fd

    settings = {"duration": parse_number("--duration", duration, fd.DURATION),
                "psidot0": parse_number("--psidot0", psidot0, fd.CRANK_SPEED),
                "damping": parse_number("--damping", damping, fd.DAMPING)}
    if slider_damping is not None:
        settings["slider_damping"] = parse_number("--slider-damping", slider_damping, fd.DAMPING)
    return settings | {
        "samples": parse_count("--samples", samples, 2, fd.MAX_SAMPLES), "method": method,
        "rtol": parse_number("--rtol", rtol, fd.RTOL), "atol": parse_number("--atol", atol, fd.ATOL),
        "max_evaluations": parse_count("--max-evaluations", max_evaluations, 1, 10**12),
        "time_limit": parse_number("--time-limit", time_limit, fd.TIME_BUDGET)}


#: Options of ``simulate`` that a linkage case refuses: it has no slider.
SLIDER_OPTIONS = {"slider_load": "--slider-load", "slider_damping": "--slider-damping"}


def _refuse_slider_options(case: str) -> None:
    """A one-line ValueError if an option in :data:`SLIDER_OPTIONS` was given for the linkage ``case``."""
    ctx = click.get_current_context()
    given = [flag for name, flag in SLIDER_OPTIONS.items()
             if ctx.get_parameter_source(name) is not ParameterSource.DEFAULT]
    if given:
        raise ValueError(f"{given[0]}: {case!r} is a linkage (no slider); its loads are the case's "
                         "(loads.output_torque, or a loop table's [[load]] rows), its options --torque, "
                         "--damping, --psi0, --psidot0 and the integrator's")
