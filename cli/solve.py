"""``dualmech cases``, ``case-path``, ``solve``, ``mjcf`` and ``benchmark``: the commands about one case.

Registered in :data:`dualmech.cli.COMMANDS`.
"""

from __future__ import annotations

import sys
from pathlib import Path

import click
import numpy as np

from dualmech.cli.errors import one_line_errors
from dualmech.cli.progress import progress
from dualmech.core.table import ResultTable
from dualmech.models.case import Case, load_case, preset_names, preset_path
from dualmech.models.linkages import is_linkage
from dualmech.models.plausibility import implausible, masses_line
from dualmech.validation.engines import ENGINES, run_engine
from dualmech.validation.solve_output import STREAM_POSITIONS, output_format, stream_solve, write_table


@click.command()
def cases() -> None:
    """List the bundled case presets."""
    for name in preset_names():
        case = load_case(name)
        g = case.geometry
        click.echo(
            f"{name:28s} a1={g.crank_length:g} a2={g.rod_length:g} a4={g.slider_offset:g} "
            f"alpha4={g.slider_twist_deg:g} S1={g.crank_axial_shift:g}  {case.raw.get('description', '')}"
        )


def summarize(table: ResultTable, case: Case) -> str:
    """What a designer reads first (:mod:`dualmech.models.design_summary`) with the body masses, the worst
    residual, the engine's notes; units from ``case.units``."""
    from dualmech.models.design_summary import design_summary

    lines = design_summary(table, case.units).lines()
    lines.insert(1, masses_line(case))
    res = table["residual"]
    if np.isfinite(res).any():
        lines.append(f"worst closure residual: {np.nanmax(res):.3g}")
    lines += list(table.meta.get("messages", []))
    return "\n".join(lines)


@click.command()
@click.argument("case")
@click.option("-o", "--output", type=click.Path(dir_okay=False),
              help="File for the table: OUT.csv or OUT.parquet (streamed row groups).")
@click.option("--engine", type=click.Choice(list(ENGINES)), default="dualmech", show_default=True)
@click.option("--frames", type=click.Choice(["world", "joint"]), default="world", show_default=True,
              help="'joint' also writes the thesis's joint-frame components (OUT.joint.csv).")
@one_line_errors
def solve(case: str, output: str | None, engine: str, frames: str) -> None:
    """Solve CASE (a TOML file or a preset name) and write one row per crank position."""
    if frames == "joint" and not output:
        raise ValueError("--frames joint: the joint-frame table goes beside the -o file (OUT.joint.csv); "
                         "give -o OUT.csv")
    if is_linkage(case):
        _solve_linkage(case, output, engine, frames)
        return
    c = load_case(case)
    warn_units(c)
    if output and output_format(output) and engine == "dualmech" and frames == "world" \
            and len(c.motion.angles_deg) > STREAM_POSITIONS:  # long: streamed, chunk by chunk, into the file
        with progress(f"solve {case}", unit="positions") as bar:
            first, *rest = stream_solve(c, output, bar).split("\n")
        click.echo("\n".join([first, masses_line(c), *rest]))
        return
    table = run_engine(engine, c)
    if output:
        write_table(table, output)
        if frames == "joint":
            from dualmech.models.joint_frames import write_joint_frame_csv

            write_joint_frame_csv(c, table, Path(output).with_suffix(".joint.csv"))
    else:
        sys.stdout.write(table.to_csv())
    click.echo(summarize(table, c), err=output is None)


def warn_units(*cases: Case) -> None:
    """One line on stderr per size of each case implausible for its units
    (:mod:`~dualmech.models.plausibility`): a warning, never an error."""
    for line in (line for case in cases for line in implausible(case)):
        click.echo(f"dualmech: warning: {line}", err=True)


def _solve_linkage(case: str, output: str | None, engine: str, frames: str) -> None:
    """A case whose ``[mechanism] kind`` is another linkage (RSSR, RCCC): its own table, as CSV, from the
    linkages' engine registry (:mod:`dualmech.validation.linkages.engines`)."""
    from dualmech.models.linkages import summary
    from dualmech.validation.linkages import solve_linkage

    if frames != "world":
        raise ValueError(f"--frames {frames}: a linkage's table is in world frames only (--frames world)")
    if output and Path(output).suffix.lower() != ".csv":
        raise ValueError(f"-o {output}: a linkage's table is written as CSV (OUT.csv)")
    table = solve_linkage(case, engine)
    if output:
        table.to_csv(output)
    else:
        sys.stdout.write(table.to_csv())
    click.echo(summary(table), err=output is None)


@click.command()
@click.argument("case")
@click.option("-o", "--output", type=click.Path(dir_okay=False), required=True)
@one_line_errors
def mjcf(case: str, output: str) -> None:
    """Write a MuJoCo model of CASE that runs as written: assembled, the crank driven at the case's speed.

    The default pose and the keyframe "turning" have the loop closed at the
    case's first crank angle (found by MuJoCo itself); the keyframe sets the
    crank-speed servo to the case's speed; the time step is the largest found
    to keep the loop closed while the crank turns (validation/mujoco_export.py).
    """
    from dualmech.models.mjcf import KEY_NAME
    from dualmech.validation.mujoco_export import export_mjcf

    c = load_case(case)
    path = Path(output)
    xml, check = export_mjcf(c, path.name)
    path.write_text(xml, encoding="utf-8")
    w = c.motion.speed
    click.echo(f"wrote {output}: loop closed at theta1 = {c.motion.angles_deg[0]:g} deg "
               f"(gap {check.assembled_gap:.2g} of a2); time step {check.timestep:.3g} s; "
               f"{check.steps} steps from key {KEY_NAME!r}: loop gap <= {check.loop_gap:.2g} of a2, "
               f"crank speed within {check.speed_error:.2g} of {w:.6g} rad/s ({w * 30.0 / np.pi:.6g} rpm)")
    if c.motion.accel != 0.0 or c.motion.axial_amplitude != 0.0:
        click.echo("note: the model turns the crank at a constant speed with S1 held; the case's crank_accel "
                   "and axial S1 law need a controller that sets ctrl over time")
    click.echo(f"open it: python -m mujoco.viewer --mjcf={output}, then Simulation > Load key")


@click.command()
@click.option("--cases", type=click.IntRange(min=1), default=1000, show_default=True,
              help="Random cases of 360 positions for the in-house solver.")
@click.option("--judge-cases", type=click.IntRange(min=0), default=5, show_default=True,
              help="How many of them the judges solve (they are slower; 0: skip the judges).")
@click.option("--big", type=click.IntRange(min=0), default=2_000_000, show_default=True,
              help="Positions of one case solved into Parquet, streamed (0: skip).")
@click.option("--repeats", type=click.IntRange(min=1), default=3, show_default=True,
              help="Runs per figure (the median is quoted).")
@one_line_errors
def benchmark(cases: int, judge_cases: int, big: int, repeats: int) -> None:
    """Positions per second: in-house, a closed-form yardstick, Pinocchio and MuJoCo, in one run
    (Markdown)."""
    from dualmech.validation.benchmark import run_benchmark

    click.echo(run_benchmark(cases, judge_cases, big, repeats))


@click.command(name="case-path")
@click.argument("name")
@one_line_errors
def case_path(name: str) -> None:
    """Print the file of a bundled preset (to copy and edit)."""
    click.echo(str(preset_path(name)))

