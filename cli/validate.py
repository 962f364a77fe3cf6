"""``dualmech validate`` and ``dualmech report``: the suite's main job, as a thin shell.

``validate`` runs a matrix (:mod:`dualmech.validation.run.runner`), compares every judge
with the reference (:mod:`dualmech.validation.compare`), optionally writes JUnit XML
and checks or writes a baseline, writes the report, prints a one-screen summary and
exits with one of :data:`dualmech.validation.exit_codes.EXIT_CODES`.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import IO, TYPE_CHECKING, NamedTuple

import click

from dualmech.cli.errors import on_interrupt, one_line_errors
from dualmech.cli.progress import progress
from dualmech.cli.solve import warn_units
from dualmech.core.table import ResultTable
from dualmech.models.case import Case, case_from_dict
from dualmech.models.plausibility import masses_line
from dualmech.validation.arguments import MAX_JOBS
from dualmech.validation.engines import ENGINES
from dualmech.validation.exit_codes import exit_code
from dualmech.validation.run.runner import run_versions

if TYPE_CHECKING:
    from rich.console import Console

    from dualmech.validation.matrix import Matrix

#: How many failing checks / regressions ``validate`` lists under its table.
SHOWN_FAILURES = 12


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


def summary_table(matrix, comparison, title: str):
    """The rich table ``validate`` prints: one row per case, one column per judge."""
    from rich.table import Table

    from dualmech.validation.report.sections import summary_rows

    table = Table(title=title, title_justify="left", pad_edge=False, show_edge=False)
    table.add_column("case", no_wrap=True)
    table.add_column(f"stroke ({matrix.reference}){_length_unit(matrix)}", justify="right")
    table.add_column("dead c.", justify="right")
    for e in matrix.judges:
        table.add_column(e, no_wrap=True)
    for row in summary_rows(matrix, comparison):
        if not row["run"]:
            table.add_row(row["case"], "[yellow]not run[/]", "",
                          *["[yellow]? missing[/]"] * len(matrix.judges))
            continue
        if row["reference_error"]:
            table.add_row(row["case"], "[red]✗ reference[/]", "",
                          *["[red]✗ no reference[/]"] * len(matrix.judges))
            continue
        cells = []
        for e in matrix.judges:
            v = row["judges"][e]
            if v["passed"] is None:
                cells.append("[dim]–[/]")
            elif v["passed"]:
                cells.append(f"[green]✓[/] {v['ratio']:.1e}")
            else:
                more = f" +{len(v['failed']) - 1}" if len(v["failed"]) > 1 else ""
                cells.append(f"[red]✗ {v['failed'][0]}{more}[/]")
        table.add_row(row["case"], f"{row['stroke']:.6f}", str(row["dead_centre"]), *cells)
    return table


def _length_unit(matrix: Matrix) -> str:
    """`` [m]`` (rich markup): the length unit of the matrix's cases when they all state one, else ``""``."""
    from dualmech.models.units import unit_system

    lengths = {unit_system(c.raw.get("units", "consistent")).length for c in matrix.cases}
    return f" \\[{lengths.pop()}]" if len(lengths) == 1 and "" not in lengths else ""  # \\[: not rich markup


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
    `validate rccc`, `validate linkages`, a loop table (`validate rscr`, `validate loops`), or a linkage
    case or matrix file, with every option (their own report).
    """
    from dualmech.validation.compare import baseline as regression
    from dualmech.validation.compare.junit import write_junit
    from dualmech.validation.linkages.matrix import is_linkage_source
    from dualmech.validation.report.derived import findings_ahead
    from dualmech.validation.report.render import write_report
    from dualmech.validation.run.runner import load_entries, timings
    from dualmech.validation.rundir import check_output_folder
    from dualmech.verbs import open_run, run_and_compare

    gate = Gate(junit_file, baseline_file, write_baseline_file)
    if is_linkage_source(matrix_file):  # rssr, rccc, linkages, a linkage case or matrix file
        _validate_linkages(matrix_file, outdir, _engine_list(engines), jobs, resume, scheduler, gate,
                           report_dir)
    matrix, outdir = open_run(matrix_file, outdir, _engine_list(engines))
    on_interrupt(f"finished results are kept in {outdir}; re-run with --resume to finish")
    warn_units(*_one_design(matrix))
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
            files = write_report(outdir, report_dir, jobs=jobs or _cores(), comparison=lambda: run.comparison,
                                 results=run.results, progress=bar, findings=findings)
    finally:  # also after a failed report: the JUnit file and the baseline of the run
        outcome, comparison = run.outcome, run.comparison
        summary = regression.baseline_summary(matrix, comparison, outcome.results)
        regressions = regression.compare_baseline(summary, baseline) if baseline is not None else []
        if junit_file:
            write_junit(junit_file, matrix, comparison, timings(load_entries(outdir, matrix)),
                        regressions=regressions, versions=run_versions(outdir))
        if write_baseline_file:
            regression.write_baseline(write_baseline_file, summary)

    how = f"Dask {scheduler}" if scheduler else f"{jobs or _cores()} jobs"
    title = (f"{matrix.name}: {len(matrix.cases)} cases, engines {', '.join(matrix.engines)} — "
             f"solved in {outcome.seconds:.1f} s ({how}; {outcome.ran} run, {outcome.skipped} resumed)")
    console.print(summary_table(matrix, comparison, title))
    _print_design(console, matrix, outcome.results)
    _print_verdict(console, comparison, files, regressions, gate)
    console.print(f"report: {files.html} and {files.markdown} ({files.seconds:.1f} s)")
    sys.exit(exit_code(comparison.verdict, regressions))


def _one_design(matrix: Matrix) -> tuple[Case, ...]:
    """The case of a one-case matrix (a design of one's own, whose sizes and loads are shown), else none."""
    return (case_from_dict(matrix.cases[0].raw),) if len(matrix.cases) == 1 else ()


def _print_design(console: Console, matrix: Matrix, results: dict) -> None:
    """A design of one's own (:func:`_one_design`): its body masses and the reference's peak loads, with
    units (as ``solve`` prints them)."""
    from dualmech.models.design_summary import design_summary

    for case in _one_design(matrix):
        table = results.get(matrix.cases[0].id, {}).get(matrix.reference)
        lines = [masses_line(case)]
        if isinstance(table, ResultTable):
            lines += [line for line in design_summary(table, case.units).lines() if line.startswith("peak ")]
        console.print("\n".join(lines), markup=False, highlight=False)


def _print_verdict(console, comparison, files, regressions: list, gate: Gate) -> None:
    """The verdict line, the first failures, the baseline's regressions and the files written."""
    from dualmech.validation.compare.junit import describe

    failures = comparison.failures()
    n_ok = len(comparison.checks) - len(failures)
    colour = {"PASS": "green", "FAIL": "red", "INCOMPLETE": "yellow"}[str(comparison.verdict)]
    missing = f"; {len(comparison.missing)} not run" if comparison.missing else ""
    console.print(f"[{colour}]{comparison.verdict}[/]: {n_ok} of {len(comparison.checks)} checks passed"
                  f"{missing} (ratio = worst relative difference / tolerance; "
                  "dead c. = dead-centre rows excluded, counted)")
    for c in failures[:SHOWN_FAILURES]:
        console.print(f"  [red]✗[/] {describe(c)}", markup=True, highlight=False)
    if len(failures) > SHOWN_FAILURES:
        console.print(f"  ... and {len(failures) - SHOWN_FAILURES} more (see {files.markdown})")
    near_lock = [c for c in comparison.checks if c.near_joint_lock and c.passed]
    if near_lock:
        where = sorted({f"{c.case} / {c.engine}" for c in near_lock})
        console.print(f"near joint lock: {len(near_lock)} passing checks with their tolerance widened "
                      f"({', '.join(where)}; see {files.markdown})", highlight=False)
    _print_gate(console, gate, regressions)


# ------------------------------------------------------------------------ the other linkages (RSSR, RCCC)

def _validate_linkages(source: str, outdir: str | None, engines: tuple[str, ...], jobs: int | None,
                       resume: bool, scheduler: str | None, gate: Gate, report_dir: str | None) -> None:
    """``validate`` of a linkage case or matrix (:mod:`dualmech.validation.linkages`): run (each result
    stored as it finishes), compare, report, print the table and the verdict, write the gate's files, exit 0
    (PASS), 1 (FAIL or a regression) or 3 (INCOMPLETE)."""
    from dualmech.validation.compare import baseline as regression
    from dualmech.validation.compare.junit import describe, write_junit
    from dualmech.validation.linkages.matrix import load_linkage_matrix
    from dualmech.validation.linkages.run import as_run_matrix
    from dualmech.validation.linkages.validate import run_linkage_validation
    from dualmech.validation.rundir import check_output_folder

    name = load_linkage_matrix(source).name
    baseline = regression.read_baseline(gate.baseline, name) if gate.baseline else None  # before the run
    if report_dir:
        check_output_folder(report_dir)
    folder = outdir or str(Path("runs") / name)
    on_interrupt(f"finished results are kept in {folder}; re-run with --resume to finish")
    with progress(f"{name}: linkage cases", unit="results") as bar:
        run, files, seconds = run_linkage_validation(source, folder, engines, jobs=jobs or _cores(),
                                                     resume=resume, scheduler=scheduler,
                                                     report_dir=report_dir, progress=bar)
    summary = run.baseline()
    regressions = regression.compare_baseline(summary, baseline) if baseline is not None else []
    if gate.junit:
        write_junit(gate.junit, as_run_matrix(run.matrix), run.comparison, run.seconds,
                    regressions=regressions, versions=run_versions(Path(folder)))
    if gate.write_baseline:
        regression.write_baseline(gate.write_baseline, summary)
    matrix = run.matrix
    console = summary_console(sys.stdout.isatty())
    title = (f"{matrix.name}: {len(matrix.cases)} linkage cases, engines {', '.join(matrix.engines)} — "
             f"solved and compared in {seconds:.1f} s")
    console.print(_linkage_table(run, title))
    failures = run.comparison.failures()
    n = len(run.comparison.checks)
    colour = {"PASS": "green", "FAIL": "red", "INCOMPLETE": "yellow"}[str(run.verdict)]
    worst = "; ".join(f"{e} {c.ratio:.2g} ({c.case} {c.quantity})" for e, c in run.worst().items())
    console.print(f"[{colour}]{run.verdict}[/]: {n - len(failures)} of {n} checks passed; worst ratio "
                  f"(relative difference / tolerance): {worst}", highlight=False)
    for c in failures[:SHOWN_FAILURES]:
        console.print(f"  [red]✗[/] {describe(c)}", highlight=False)
    if len(failures) > SHOWN_FAILURES:
        console.print(f"  ... and {len(failures) - SHOWN_FAILURES} more (see {files.markdown})")
    _print_gate(console, gate, regressions)
    console.print(f"report: {files.html} and {files.markdown}; summary {files.summary}")
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


def _linkage_table(run, title: str):
    """One row per linkage case, one column per judge: its worst ratio, or what failed; – not applicable."""
    from rich.table import Table

    table = Table(title=title, title_justify="left", pad_edge=False, show_edge=False)
    for name in ("case", "kind", f"rows ({run.matrix.reference})", *run.matrix.judges):
        table.add_column(name, no_wrap=True, justify="right" if name.startswith("rows") else "left")
    for entry in run.matrix.cases:
        ref = run.tables[entry.id].get(run.matrix.reference)
        cells = []
        for e in run.matrix.judges:
            checks = run.comparison.for_engine(entry.id, e)
            failed = [c for c in checks if not c.passed]
            if not checks:
                cells.append("[dim]–[/]")
            elif failed:
                more = f" +{len(failed) - 1}" if len(failed) > 1 else ""
                cells.append(f"[red]✗ {failed[0].quantity}{more}[/]")
            else:
                cells.append(f"[green]✓[/] {max(c.ratio for c in checks):.1e}")
        rows = "✗" if ref is None or isinstance(ref, str) else str(len(ref))
        table.add_row(entry.id, entry.kind, rows, *cells)
    return table


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
    from dualmech.validation.linkages.validate import report_linkage_run
    from dualmech.validation.report.render import write_report

    on_interrupt(f"the report in {outdir or rundir} is not finished; run dualmech report again")
    linkages = report_linkage_run(rundir, outdir)
    if linkages is not None:
        run, written, _ = linkages
        click.echo(f"{run.verdict}: report {written.html} and {written.markdown} ({len(written.figures)} "
                   "figures)")
        sys.exit(exit_code(run.verdict, []))
    files = write_report(rundir, outdir, jobs=jobs or _cores())
    click.echo(f"{files.verdict}: report {files.html} and {files.markdown} "
               f"({len(files.figures)} figures, {files.seconds:.1f} s)")
    sys.exit(exit_code(files.verdict, []))
