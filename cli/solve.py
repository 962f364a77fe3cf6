"""``dualmech cases``, ``case-path``, ``solve``, ``mjcf`` and ``benchmark``: the commands about one case.

Registered in :data:`dualmech.cli.COMMANDS`.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import click

from dualmech.cli.errors import one_line_errors
from dualmech.cli.progress import progress
from dualmech.core.files import write_text_durable, write_with
from dualmech.models.catalogue import bundled_case_path, bundled_cases, load_mechanism
from dualmech.models.inputs import CaseError
from dualmech.models.kinds import KIND_HOMES, kind_of, resolve
from dualmech.models.plausibility import warnings_of
from dualmech.validation.engines import ENGINES, STREAMED, solve_checked
from dualmech.validation.solve_output import output_format, write_table


@click.command()
@one_line_errors
def cases() -> None:
    """List the bundled case presets of every kind (slider crank, RSSR, RCCC, loop tables)."""
    for name, kind, about in bundled_cases():
        click.echo(f"{name:28s} {kind:12s} {about}")


@click.command()
@click.argument("case")
@click.option("-o", "--output", type=click.Path(dir_okay=False),
              help="File for the table: OUT.csv or OUT.parquet (streamed row groups).")
@click.option("--engine", type=click.Choice(list(ENGINES)), default="dualmech", show_default=True)
@click.option("--frames", type=click.Choice(["world", "joint"]), default="world", show_default=True,
              help="'joint' also writes the thesis's joint-frame components (OUT.joint.csv).")
@one_line_errors
def solve(case: str, output: str | None, engine: str, frames: str) -> None:
    """Solve CASE (a TOML file or a preset name of any kind) and write one row per drive position."""
    c = load_mechanism(case)
    kind = kind_of(c)
    home = KIND_HOMES[kind]
    if frames == "joint" and not home.joint_frames:
        raise ValueError(f"--frames joint: a {kind} case's table is in world frames only (--frames world)")
    if frames == "joint" and not output:
        raise ValueError("--frames joint: the joint-frame table goes beside the -o file (OUT.joint.csv); "
                         "give -o OUT.csv")
    if output:
        output_format(output)  # before solving: OUT.csv or OUT.parquet
    warn_units(c)
    failure = resolve(home.assembly)(c) if home.assembly else None
    if failure:
        raise CaseError(failure)
    stream = STREAMED.get(kind) if output and engine == "dualmech" and frames == "world" else None
    if stream and resolve(stream[0])(c):  # long: solved chunk by chunk into the file
        with progress(f"solve {case}", unit="positions") as bar:
            click.echo(resolve(stream[1])(c, output, bar))
        return
    table = solve_checked(engine, c)
    if output:
        write_table(table, output)  # atomic: written beside, renamed
        if frames == "joint":
            joint = Path(output).with_suffix(".joint.csv")
            write_with(joint, lambda tmp: resolve(home.joint_frames)(c, table, tmp))
    else:
        sys.stdout.write(table.to_csv())
    click.echo(resolve(home.summary)(table, c), err=output is None)


def warn_units(*cases: Any) -> None:
    """One line on stderr per size of each case implausible for its units
    (:mod:`~dualmech.models.plausibility`): a warning, never an error."""
    for line in (line for case in cases for line in warnings_of(case)):
        click.echo(f"dualmech: warning: {line}", err=True)


@click.command()
@click.argument("case")
@click.option("-o", "--output", type=click.Path(dir_okay=False), required=True)
@one_line_errors
def mjcf(case: str, output: str) -> None:
    """Write a MuJoCo model of CASE that runs as written: assembled, the crank driven at the case's speed.

    The default pose and the keyframe "turning" have the loop closed at the
    case's first crank angle (found by MuJoCo itself); the keyframe sets the
    crank-speed servo to the case's speed; the time step is the largest found
    to keep the loop closed while the crank turns (validation/judges/mujoco_export.py).
    An RSSR, RCCC or loop-table case writes its loop table's model, built by the
    MuJoCo judge's own builder, with its keyframe "turning" (docs/conventions.md,
    "Loop tables").
    """
    from dualmech.validation.judges.mujoco_export import export_case

    xml, about = export_case(load_mechanism(case), Path(output).name)
    write_text_durable(Path(output), xml)
    click.echo(f"wrote {output}: {about}")
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
@click.option("--main-job", type=click.IntRange(min=0), default=5, show_default=True,
              help="Timed runs of the main job (dualmech validate, default matrix) after a warm-up; 0: skip.")
@click.option("-o", "--output", type=click.Path(dir_okay=False), default=None,
              help="Write the figures as a Markdown page (docs/performance.md) instead of printing them.")
@one_line_errors
def benchmark(cases: int, judge_cases: int, big: int, repeats: int, main_job: int,
              output: str | None) -> None:
    """Positions per second: in-house, a closed-form yardstick, Pinocchio and MuJoCo, and the main job's time,
    in one run (Markdown)."""
    from dualmech.validation.benchmark.rows import performance_page, run_benchmark

    table = run_benchmark(cases, judge_cases, big, repeats, main_job)
    if output is None:
        click.echo(table)
        return
    command = (f"dualmech benchmark --cases {cases} --judge-cases {judge_cases} --big {big} "
               f"--repeats {repeats} --main-job {main_job} -o {output}")
    write_text_durable(Path(output), performance_page(table, command))
    click.echo(f"wrote {output}")


@click.command(name="case-path")
@click.argument("name")
@one_line_errors
def case_path(name: str) -> None:
    """Print the file of a bundled preset of any kind (``dualmech cases``), to copy and edit."""
    click.echo(str(bundled_case_path(name)))

