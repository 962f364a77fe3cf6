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
from dualmech.core.assembly import reach
from dualmech.core.files import write_text_durable, write_with
from dualmech.core.status import Status
from dualmech.core.table import ResultTable
from dualmech.core.thresholds import ASSEMBLY_REACH
from dualmech.models.case import Case, load_case, preset_names, preset_path
from dualmech.models.inputs import CaseError, show
from dualmech.models.kinds import SLIDER_CRANK, kind_of
from dualmech.models.linkages import bundled_names, bundled_path, is_linkage, read_linkage
from dualmech.models.mechanism import crank_pin
from dualmech.models.plausibility import implausible, masses_line
from dualmech.models.units import column_unit
from dualmech.validation.engines import ENGINES, run_engine
from dualmech.validation.solve_output import STREAM_POSITIONS, output_format, stream_solve, write_table


def bundled_cases() -> list[tuple[str, str, str]]:
    """Every bundled preset of every kind as ``(name, kind, one line about it)``: the slider crank's
    (``"thesis/ideal"``, its link-joint constants and description), then the other linkages' (``"rssr"``,
    their ``[mechanism] kind`` and description).  Each name is what ``solve`` and ``case-path`` take."""
    rows = []
    for name in preset_names():
        case = load_case(name)
        g = case.geometry
        rows.append((name, SLIDER_CRANK, f"a1={g.crank_length:g} a2={g.rod_length:g} a4={g.slider_offset:g} "
                     f"alpha4={g.slider_twist_deg:g} S1={g.crank_axial_shift:g}  "
                     f"{case.raw.get('description', '')}"))
    for name in bundled_names():
        data = read_linkage(name)
        rows.append((name, kind_of(data), str(data.get("description", ""))))
    return rows


def bundled_case_path(name: str) -> Path:
    """The file of the bundled preset ``name`` of any kind (a name of :func:`bundled_cases`, or a slider
    crank's unique stem such as ``"ideal"``).

    Raises
    ------
    CaseError
        One line naming ``name`` and every valid name, where it is none of them.
    """
    if name in bundled_names():
        return bundled_path(name)
    try:
        return preset_path(name)
    except CaseError:
        names = ", ".join(row[0] for row in bundled_cases())
        raise CaseError(f"case: {show(name)} is not a bundled preset (presets: {names})") from None


@click.command()
@one_line_errors
def cases() -> None:
    """List the bundled case presets of every kind (slider crank, RSSR, RCCC, loop tables)."""
    for name, kind, about in bundled_cases():
        click.echo(f"{name:28s} {kind:12s} {about}")


def assembly_failure(case: Case) -> str | None:
    """Why ``case`` assembles at none of its crank angles, in one line with the reach's numbers, or ``None``
    where it assembles at one at least.

    The reach test of every engine (:func:`dualmech.core.assembly.reach`, ``docs/conventions.md``, "Edges of
    assembly"): the loop closes where the crank pin ``P2`` is within ``a2 (1 + ASSEMBLY_REACH)`` of the slider
    line.  The line names the crank pin's least distance from the line and where, and, when that is the
    reason, that the offset alone puts the line out of reach (``|a4| - a1 > a2``: the distance is at least
    ``|a4| - a1`` at every crank angle).
    """
    g, crank = case.geometry, case.own_crank_states()
    rho = reach(crank_pin(g.crank_length, crank.theta, crank.s), g.foot, g.k4, g.rod_length)
    if (rho <= 1.0 + ASSEMBLY_REACH.value).any():
        return None
    i = int(np.argmin(rho))
    unit = column_unit("S4", case.units)
    at = f" {unit}" if unit else ""
    line = (f"{case.name}: the design assembles at no crank angle: the crank pin comes no nearer the slider "
            f"line than {rho[i] * g.rod_length:.6g}{at} (theta1 = {np.degrees(crank.theta[i]):g} deg), "
            f"beyond the rod's reach a2 = {g.rod_length:g}{at}")
    a1, a4 = g.crank_length, abs(g.slider_offset)
    if a4 - a1 > g.rod_length:
        line += (f" (the offset |a4| = {a4:g}{at} exceeds the rod plus crank reach "
                 f"a1 + a2 = {a1 + g.rod_length:g}{at})")
    return line


def summarize(table: ResultTable, case: Case) -> str:
    """What a designer reads first (:mod:`dualmech.models.design_summary`) with the body masses, the worst
    residual, the engine's notes; units from ``case.units``."""
    from dualmech.models.design_summary import design_summary

    lines = design_summary(table, case.units).lines()
    lines.insert(1, masses_line(case))
    res = table["residual"][table.status != Status.NO_ASSEMBLY]  # there: the reach's excess, not a closure's
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
    failure = assembly_failure(c)
    if failure:
        raise CaseError(failure)
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

            joint = Path(output).with_suffix(".joint.csv")
            write_with(joint, lambda tmp: write_joint_frame_csv(c, table, tmp))
    else:
        sys.stdout.write(table.to_csv())
    click.echo(summarize(table, c), err=output is None)


def warn_units(*cases: Case) -> None:
    """One line on stderr per size of each case implausible for its units
    (:mod:`~dualmech.models.plausibility`): a warning, never an error."""
    for line in (line for case in cases for line in implausible(case)):
        click.echo(f"dualmech: warning: {line}", err=True)


def _solve_linkage(case: str, output: str | None, engine: str, frames: str) -> None:
    """A case whose ``[mechanism] kind`` is another linkage (RSSR, RCCC, a loop table): its own table, as
    CSV or Parquet, from the engine registry (:mod:`dualmech.validation.engines`)."""
    from dualmech.models.linkages import summary
    from dualmech.validation.engines import solve_linkage

    if frames != "world":
        raise ValueError(f"--frames {frames}: a linkage's table is in world frames only (--frames world)")
    if output:
        output_format(output)  # before solving: OUT.csv or OUT.parquet
    table = solve_linkage(case, engine)
    if output:
        write_table(table, output)  # atomic: written beside, renamed
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
    to keep the loop closed while the crank turns (validation/judges/mujoco_export.py).
    An RSSR, RCCC or loop-table case writes its loop table's model, built by the
    MuJoCo judge's own builder, with its keyframe "turning" (docs/conventions.md,
    "Loop tables").
    """
    from dualmech.models.linkages import is_linkage
    from dualmech.models.mjcf import KEY_NAME
    from dualmech.validation.judges.mujoco_export import export_mjcf

    path = Path(output)
    if is_linkage(case):
        _loop_mjcf(case, path)
        return
    c = load_case(case)
    xml, check = export_mjcf(c, path.name)
    write_text_durable(path, xml)
    w = c.motion.speed
    click.echo(f"wrote {output}: loop closed at theta1 = {c.motion.angles_deg[0]:g} deg "
               f"(gap {check.assembled_gap:.2g} of a2); time step {check.timestep:.3g} s; "
               f"{check.steps} steps from key {KEY_NAME!r}: loop gap <= {check.loop_gap:.2g} of a2, "
               f"crank speed within {check.speed_error:.2g} of {w:.6g} rad/s ({w * 30.0 / np.pi:.6g} rpm)")
    if c.motion.accel != 0.0 or c.motion.axial_amplitude != 0.0:
        click.echo("note: the model turns the crank at a constant speed with S1 held; the case's crank_accel "
                   "and axial S1 law need a controller that sets ctrl over time")
    click.echo(f"open it: python -m mujoco.viewer --mjcf={output}, then Simulation > Load key")


def _loop_mjcf(case: str, path: Path) -> None:
    """``mjcf`` of a linkage case: its loop table's model (:func:`~dualmech.validation.judges.mujoco_export.
    export_loop_mjcf`), written and summed up in one line."""
    from dualmech.models.linkages import linkage_case
    from dualmech.models.mjcf import KEY_NAME
    from dualmech.validation.judges.mujoco_export import export_loop_mjcf

    xml, check = export_loop_mjcf(linkage_case(case), path.name)
    write_text_durable(path, xml)
    click.echo(f"wrote {path}: loop table closed at the first drive position (cut gap "
               f"{check.assembled_gap:.2g} of its length); time step {check.timestep:.3g} s; {check.steps} "
               f"steps from key {KEY_NAME!r}: cut gap <= {check.loop_gap:.2g}, drive rate within "
               f"{check.speed_error:.2g} of its speed")
    click.echo(f"open it: python -m mujoco.viewer --mjcf={path}, then Simulation > Load key")


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
    from dualmech.validation.benchmark import performance_page, run_benchmark

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

