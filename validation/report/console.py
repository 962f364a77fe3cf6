"""What ``dualmech validate`` prints about a slider-crank run: the table, a design's own lines, the verdict.

Each part is a list of rich renderables (a :class:`rich.table.Table`, markup strings, or
:class:`rich.text.Text` for lines printed as they are), which the command prints in order
(:meth:`dualmech.verbs.ValidationRun.console_summary`); the other linkages' are in
:mod:`dualmech.validation.linkages.report`.
"""

from __future__ import annotations

from typing import Any

from dualmech.core.table import ResultTable
from dualmech.models.kinds import SLIDER_CRANK, case_from_data, kind_of
from dualmech.validation.compare import Comparison
from dualmech.validation.matrix import Matrix

#: How many failing checks / regressions ``validate`` lists under its table.
SHOWN_FAILURES = 12
#: The verdict line's colour (rich markup) by verdict.
VERDICT_COLOURS = {"PASS": "green", "FAIL": "red", "INCOMPLETE": "yellow"}


def summary_table(matrix: Matrix, comparison: Comparison, title: str) -> Any:
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


def one_design(matrix: Matrix) -> tuple[Any, ...]:
    """The checked case of a one-case matrix (a design of one's own, whose sizes and loads are shown), of
    any kind, else none."""
    return (case_from_data(matrix.cases[0].raw),) if len(matrix.cases) == 1 else ()


def design_lines(matrix: Matrix, results: dict) -> list[Any]:
    """A slider crank of one's own (:func:`one_design`): its body masses and the reference's peak loads,
    with units (as ``solve`` prints them), as plain text."""
    from rich.text import Text

    from dualmech.models.design_summary import design_summary
    from dualmech.models.plausibility import masses_line

    out: list[Any] = []
    for case in one_design(matrix):
        if kind_of(case) != SLIDER_CRANK:
            continue
        table = results.get(matrix.cases[0].id, {}).get(matrix.reference)
        lines = [masses_line(case)]
        if isinstance(table, ResultTable):
            lines += [line for line in design_summary(table, case.units).lines() if line.startswith("peak ")]
        out.append(Text("\n".join(lines)))
    return out


def verdict_lines(comparison: Comparison, markdown: str) -> list[Any]:
    """The verdict line, the first failures (the rest: see ``markdown``), the checks passed near a joint
    lock."""
    from rich.text import Text

    failures = comparison.failures()
    n_ok = len(comparison.checks) - len(failures)
    colour = VERDICT_COLOURS[str(comparison.verdict)]
    missing = f"; {len(comparison.missing)} not run" if comparison.missing else ""
    out: list[Any] = [f"[{colour}]{comparison.verdict}[/]: {n_ok} of {len(comparison.checks)} checks passed"
                      f"{missing} (ratio = worst relative difference / tolerance; "
                      "dead c. = dead-centre rows excluded, counted)", *failure_lines(failures, markdown)]
    near_lock = [c for c in comparison.checks if c.near_joint_lock and c.passed]
    if near_lock:
        where = sorted({f"{c.case} / {c.engine}" for c in near_lock})
        out.append(Text(f"near joint lock: {len(near_lock)} passing checks with their tolerance widened "
                        f"({', '.join(where)}; see {markdown})"))
    return out


def failure_lines(failures: list, markdown: str) -> list[str]:
    """The first :data:`SHOWN_FAILURES` failing checks, one line each, and how many more (see
    ``markdown``)."""
    from dualmech.validation.compare.junit import describe

    out = [f"  [red]✗[/] {describe(c)}" for c in failures[:SHOWN_FAILURES]]
    if len(failures) > SHOWN_FAILURES:
        out.append(f"  ... and {len(failures) - SHOWN_FAILURES} more (see {markdown})")
    return out
