"""``dualmech simulate``: forward dynamics of a case under a given torque (thin shell over
:func:`dualmech.models.slider_crank.forward_dynamics.simulate`).

Numeric options are read as text and parsed here, so a bad one (``--rtol nan``,
``--duration 1e400``, ``--samples abc``) is one line naming the option, the value and
its range, like every other bad input, rather than click's multi-line usage error.
"""

from __future__ import annotations

import sys
import warnings

import click
import numpy as np
from click.core import ParameterSource

from dualmech.cli.errors import one_line_errors
from dualmech.cli.progress import progress
from dualmech.cli.solve import warn_units
from dualmech.models.catalogue import load_mechanism
from dualmech.models.inputs import ANGLE_DEG, Range, show
from dualmech.models.integration import MAX_EVALUATIONS, TIME_LIMIT
from dualmech.models.kinds import KIND_HOMES, kind_of, resolve
from dualmech.models.plausibility import ImplausibleUnitsWarning

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
    from dualmech.verbs import simulate as run

    psi0_deg = parse_number("--psi0", psi0, ANGLE_DEG)
    c = load_mechanism(case)
    home = KIND_HOMES[kind_of(c)]
    settings = _settings(duration, psidot0, damping, slider_damping, samples, method, rtol, atol,
                         max_evaluations, time_limit)
    slider = {"slider_load": slider_load, "slider_damping": settings.pop("slider_damping")}
    ctx = click.get_current_context()
    refused = [name for name in slider if name not in home.sim_options
               and ctx.get_parameter_source(name) is not ParameterSource.DEFAULT]
    if refused:
        raise ValueError(f"--{refused[0].replace('_', '-')}: {case!r} is a {kind_of(c)} case, which has no "
                         "slider; its loads are the case's (loads.output_torque, or a loop table's [[load]] "
                         "rows), its options --torque, --damping, --psi0, --psidot0 and the integrator's")
    options = settings | {name: value for name, value in slider.items() if name in home.sim_options}
    warn_units(c)  # the command's own one line each; the API's warning of the same is not repeated
    with progress(f"simulate {case}", unit="s") as bar, warnings.catch_warnings():
        warnings.simplefilter("ignore", ImplausibleUnitsWarning)
        sim = run(c, torque=torque, psi0=None if psi0_deg is None else float(np.radians(psi0_deg)),
                  progress=bar, **options)
    if output:
        sim.to_csv(output)  # atomic: written beside, renamed
    else:
        sys.stdout.write(sim.to_csv())
    click.echo(resolve(home.sim_summary)(sim), err=output is None)


def _settings(duration: str, psidot0: str | None, damping: str, slider_damping: str, samples: str,
              method: str, rtol: str, atol: str, max_evaluations: str, time_limit: str) -> dict:
    """The numeric options parsed in order, as keyword arguments of ``simulate``; a one-line ValueError for
    a bad one."""
    from dualmech.models import integration as fd

    settings = {"duration": parse_number("--duration", duration, fd.DURATION),
                "psidot0": parse_number("--psidot0", psidot0, fd.CRANK_SPEED),
                "damping": parse_number("--damping", damping, fd.DAMPING),
                "slider_damping": parse_number("--slider-damping", slider_damping, fd.DAMPING)}
    return settings | {
        "samples": parse_count("--samples", samples, 2, fd.MAX_SAMPLES), "method": method,
        "rtol": parse_number("--rtol", rtol, fd.RTOL), "atol": parse_number("--atol", atol, fd.ATOL),
        "max_evaluations": parse_count("--max-evaluations", max_evaluations, 1, 10**12),
        "time_limit": parse_number("--time-limit", time_limit, fd.TIME_BUDGET)}
