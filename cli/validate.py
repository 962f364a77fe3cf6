"""``dualmech validate`` and ``dualmech report``: the suite's main job, as a thin shell.

``validate`` runs a matrix (:mod:`dualmech.validation.run.runner`), compares every judge
with the reference (:mod:`dualmech.validation.compare`), optionally writes JUnit XML
and checks or writes a baseline, writes the report, prints a one-screen summary and
exits with one of :data:`dualmech.validation.exit_codes.EXIT_CODES`.
"""

from __future__ import annotations

import sys
from typing import IO, TYPE_CHECKING, NamedTuple

import click

from dualmech.cli.errors import on_interrupt, one_line_errors
from dualmech.cli.progress import progress
from dualmech.cli.solve import warn_units
from dualmech.validation.arguments import MAX_JOBS
from dualmech.validation.engines import ENGINES
from dualmech.validation.exit_codes import exit_code
from dualmech.validation.report.console import SHOWN_FAILURES

if TYPE_CHECKING:
    from rich.console import Console


def _engine_list(values: tuple[str, ...]) -> tuple[str, ...]:
    names = tuple(n.strip() for v in values for n in v.split(",") if n.strip())
    for n in names:
        if n not in ENGINES:
            raise ValueError(f"--engines: {n!r} is not an engine (valid: {', '.join(ENGINES)})")
    return names


#: Console width when stdout is a pipe or a file: wide enough that no table cell is ever cut or wrapped.
UNBOUNDED_WIDTH = 100_000


def summary_console(terminal: bool, file: IO[str] | None = None) -> Console:
    """The console ``validate`` prints its summary on.

    On a terminal, the terminal's width (rich may abbreviate cells to fit).  Into a pipe
    or a file (CI logs), :data:`UNBOUNDED_WIDTH`: every row and cell prints whole, the table
    at its natural width and each message on one line.
    """
    from rich.console import Console

    return Console(file=file, width=None if terminal else UNBOUNDED_WIDTH)


class Gate(NamedTuple):
    """The CI gate's files of a run: JUnit XML to write, a baseline to compare with, one to write."""

    junit: str | None
    baseline: str | None
    write_baseline: str | None


@click.command()
@click.argument("matrix_file", required=False, metavar="[MATRIX.toml]")
@click.option("-o", "--output", "outdir", type=click.Path(file_okay=False),
              help="Run directory: one result file per case, run.json, the report "
                   "[default: runs/<matrix name>].")
@click.option("--jobs", type=click.IntRange(1, MAX_JOBS), default=None,
              help="Worker processes [default: all cores].")
@click.option("--resume", is_flag=True, help="Keep finished cases stored in the run directory; run the rest.")
@click.option("--scheduler", metavar="ADDRESS", help="Run the cases on a Dask distributed scheduler (tcp://host:port).")
@click.option("--junit", "junit_file", type=click.Path(dir_okay=False),
              help="Write JUnit XML (one test per case x engine).")
@click.option("--baseline", "baseline_file", type=click.Path(dir_okay=False),
              help="Fail on any regression against this baseline summary.")
@click.option("--write-baseline", "write_baseline_file", type=click.Path(dir_okay=False),
              help="Write this run's summary as the new baseline.")
@click.option("--engines", "engines", multiple=True, metavar="NAMES",
              help=f"Run only these engines (comma-separated or repeated; the reference must be one). "
                   f"Known: {', '.join(ENGINES)}.")
@click.option("--report-dir", type=click.Path(file_okay=False),
              help="Write the report here [default: the run directory].")
@one_line_errors
def validate(matrix_file, outdir, jobs, resume, scheduler, junit_file, baseline_file, write_baseline_file,
             engines, report_dir) -> None:
    """Run every case of MATRIX.toml (default: the thesis's study) on every engine and compare.

    Exits 1 when any judge disagrees with the reference beyond tolerance, an engine
    fails, or (with --baseline) anything regressed.  The other linkages: `validate rssr`,
    `validate rccc`, `validate linkages`, a loop table (`validate rscr`, `validate loops`), a linkage
    case or matrix file, or a matrix whose base is a linkage case, with every option.
    """
    from dualmech.validation.compare import baseline as regression
    from dualmech.validation.report.console import one_design
    from dualmech.validation.report.derived import findings_ahead
    from dualmech.validation.rundir import check_output_folder
    from dualmech.verbs import open_run, run_and_compare

    gate = Gate(junit_file, baseline_file, write_baseline_file)
    matrix, outdir = open_run(matrix_file, outdir, _engine_list(engines))
    on_interrupt(f"finished results are kept in {outdir}; re-run with --resume to finish")
    warn_units(*one_design(matrix))
    baseline = regression.read_baseline(baseline_file, matrix.name) if baseline_file else None  # first
    if report_dir:
        check_output_folder(report_dir)
    console = summary_console(sys.stdout.isatty())
    progress_title = f"{matrix.name}: {len(matrix.cases)} cases x {len(matrix.engines)} engines"
    findings = findings_ahead(matrix)  # the report's in-house sections, solved while the judges run
    with progress(progress_title, unit="results") as bar:  # interrupted, or workers lost: cli.errors
        run = run_and_compare(matrix, outdir, jobs=jobs, resume=resume, scheduler=scheduler, progress=bar)
    on_interrupt(f"the run in {outdir} is complete, its report not finished; dualmech report {outdir} "
                 "writes it")
    try:  # the run is compared in the report, once its first figures are being drawn
        with progress(f"report of {matrix.name}", unit="figures") as bar:
            files = run.write_report(report_dir, jobs=jobs or _cores(), progress=bar, findings=findings)
    finally:  # also after a failed report: the JUnit file and the baseline of the run
        summary = run.baseline()
        regressions = regression.compare_baseline(summary, baseline) if baseline is not None else []
        if junit_file:
            run.write_junit(junit_file, regressions)
        if write_baseline_file:
            regression.write_baseline(write_baseline_file, summary)

    how = f"Dask {scheduler}" if scheduler else f"{jobs or _cores()} jobs"
    for part in run.console_summary(how, str(files.markdown)):
        console.print(part, highlight=False)
    _print_gate(console, gate, regressions)
    console.print(f"report: {files.html} and {files.markdown} ({files.seconds:.1f} s)")
    sys.exit(exit_code(run.verdict, regressions))


def _print_gate(console: Console, gate: Gate, regressions: list) -> None:
    """The baseline's regressions and the gate's files written."""
    if gate.baseline:
        if regressions:
            console.print(f"[red]REGRESSION[/] against {gate.baseline}: {len(regressions)}")
            for r in regressions[:SHOWN_FAILURES]:
                console.print(f"  [red]✗[/] {r}", highlight=False)
        else:
            console.print(f"baseline {gate.baseline}: no regression")
    if gate.write_baseline:
        console.print(f"baseline written: {gate.write_baseline}")
    if gate.junit:
        console.print(f"JUnit: {gate.junit}")


def _cores() -> int:
    from dualmech.validation.run.runner import default_jobs

    return default_jobs()


@click.command()
@click.argument("rundir", type=click.Path(file_okay=False, exists=True))
@click.option("-o", "--output", "outdir", type=click.Path(file_okay=False),
              help="Write the report here [default: RUNDIR].")
@click.option("--jobs", type=click.IntRange(1, MAX_JOBS), default=None,
              help="Processes for the figures [default: all cores].")
@one_line_errors
def report(rundir, outdir, jobs) -> None:
    """Write the report (HTML, Markdown, figures, summary.json) of the run stored in RUNDIR."""
    from dualmech.verbs import report_run

    on_interrupt(f"the report in {outdir or rundir} is not finished; run dualmech report again")
    files = report_run(rundir, outdir, jobs=jobs or _cores())
    click.echo(f"{files.verdict}: report {files.html} and {files.markdown} "
               f"({len(files.figures)} figures, {files.seconds:.1f} s)")
    sys.exit(exit_code(files.verdict, []))
