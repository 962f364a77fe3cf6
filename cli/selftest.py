"""``dualmech selftest``: the validation gate proves it can fail (:mod:`dualmech.validation.selftest`).

Registered in :data:`dualmech.cli.COMMANDS`.
"""

from __future__ import annotations

import sys
from pathlib import Path

import click

from dualmech.cli.errors import one_line_errors
from dualmech.cli.progress import note, progress
from dualmech.validation.arguments import MAX_JOBS
from dualmech.validation.selftest import (
    CATALOGUE,
    Outcome,
    check_source,
    format_report,
    load_catalogue,
    run_selftest,
    source_root,
)


@click.command()
@click.option("--catalogue", type=click.Path(dir_okay=False), help=f"Fault catalogue [default: {CATALOGUE}].")
@click.option("--jobs", type=click.IntRange(1, MAX_JOBS), default=2, show_default=True,
              help="Mutants gated side by side.")
@click.option("--timeout", type=float, default=600.0, show_default=True,
              help="Seconds each gate step may take (a step that outlives it counts as killed by timeout).")
@click.option("--only", multiple=True, metavar="ID", help="Run only these mutants (repeatable).")
@click.option("--source", type=click.Path(file_okay=False, exists=True),
              help="Source tree to copy [default: the checkout dualmech runs from].")
@click.option("--keep", type=click.Path(file_okay=False), help="Keep the scratch copies and runs here.")
@one_line_errors
def selftest(catalogue, jobs, timeout, only, source, keep) -> None:
    """Apply every deliberate fault of the catalogue to a scratch copy and require the gate to FAIL.

    Prints one row per fault (which part of the gate killed it, seconds) and the
    mutation score; exits 1 below 100 % or when the gate fails without a fault.
    """
    root = check_source(Path(source) if source else source_root())
    cat = load_catalogue(Path(catalogue) if catalogue else root / CATALOGUE)
    total = len(only) if only else len(cat.mutants)
    with progress("selftest", unit="mutants") as bar:
        outcomes: list[Outcome] = []

        def finished(o: Outcome) -> None:
            outcomes.append(o)
            note(f"  {o.mutant.id}: {o.run.verdict} ({o.run.seconds:.1f} s)")
            bar(len(outcomes), total, o.mutant.id)

        report = run_selftest(cat, root, jobs=jobs, timeout=timeout, only=tuple(only),
                              keep=Path(keep) if keep else None, progress=finished)
    click.echo(format_report(report, jobs))
    if not report.passed:
        sys.exit(1)
