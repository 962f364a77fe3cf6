"""What ``dualmech validate`` prints about a run of any kinds: the table, a design's own lines, the verdict.

Each part is a list of rich renderables (a :class:`rich.table.Table`, markup strings, or
:class:`rich.text.Text` for lines printed as they are), which the command prints in order
(:meth:`dualmech.verbs.ValidationRun.console_summary`).
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
    """The rich table ``validate`` prints: one row per case (its kind beside it where the matrix has kinds
    other than the slider crank; a slider crank's stroke), one column per judge: its worst ratio, what
    failed, or – where it does not solve the case."""
    from rich.table import Table

    from dualmech.validation.report.sections import summary_rows

    kinds = {mc.id: kind_of(mc.raw) for mc in matrix.cases}
    shown_kind = set(kinds.values()) != {SLIDER_CRANK}
    strokes = SLIDER_CRANK in kinds.values()
    table = Table(title=title, title_justify="left", pad_edge=False, show_edge=False)
    table.add_column("case", no_wrap=True)
    heads = [*(["kind"] if shown_kind else []),
             *([f"stroke ({matrix.reference}){_length_unit(matrix)}"] if strokes else []), "dead c."]
    for head in heads:
        table.add_column(head, no_wrap=True, justify="left" if head == "kind" else "right")
    for e in matrix.judges:
        table.add_column(e, no_wrap=True)
    for row in summary_rows(matrix, comparison):
        kind = [kinds[row["case"]]] if shown_kind else []
        if not row["run"] or row["reference_error"]:
            first, cell = (("[yellow]not run[/]", "[yellow]? missing[/]") if not row["run"] else
                           ("[red]✗ reference[/]", "[red]✗ no reference[/]"))
            table.add_row(row["case"], *kind, first, *[""] * (len(heads) - len(kind) - 1),
                          *[cell] * len(matrix.judges))
            continue
        stroke = ([f"{row['stroke']:.6f}" if kinds[row["case"]] == SLIDER_CRANK else "[dim]–[/]"]
                  if strokes else [])
        table.add_row(row["case"], *kind, *stroke, str(row["dead_centre"]),
                      *[_cell(row["judges"][e]) for e in matrix.judges])
    return table


def _cell(verdict: dict) -> str:
    """One judge's cell of the summary table (:func:`~dualmech.validation.report.sections.engine_verdict`)."""
    if verdict["passed"] is None:
        return "[dim]–[/]"
    if verdict["passed"]:
        return f"[green]✓[/] {verdict['ratio']:.1e}"
    more = f" +{len(verdict['failed']) - 1}" if len(verdict["failed"]) > 1 else ""
    return f"[red]✗ {verdict['failed'][0]}{more}[/]"


def _length_unit(matrix: Matrix) -> str:
    """`` [m]`` (rich markup): the length unit of the matrix's slider-crank cases (the strokes) when they all
    state one, else ``""``."""
    from dualmech.models.units import unit_system

    lengths = {unit_system(c.raw.get("units", "consistent")).length
               for c in matrix.cases if c.is_slider_crank}
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


def verdict_lines(matrix: Matrix, comparison: Comparison, markdown: str) -> list[Any]:
    """The engines not applicable to a case (each with why), the verdict line with each judge's worst ratio,
    the first failures (the rest: see ``markdown``), the checks passed near a joint lock."""
    from rich.text import Text

    from dualmech.validation.matrix.cases import not_applicable
    from dualmech.validation.report.tables import not_applicable_lines, worst_checks

    failures = comparison.failures()
    n_ok = len(comparison.checks) - len(failures)
    colour = VERDICT_COLOURS[str(comparison.verdict)]
    missing = f"; {len(comparison.missing)} not run" if comparison.missing else ""
    worst = "; ".join(f"{e} {c.ratio:.2g} ({c.case} {c.quantity})"
                      for e, c in worst_checks(matrix, comparison).items())
    refused = not_applicable_lines(not_applicable(matrix))
    out: list[Any] = [f"[dim]– not applicable: {line}[/]" for line in refused]
    out += [f"[{colour}]{comparison.verdict}[/]: {n_ok} of {len(comparison.checks)} checks passed"
            f"{missing} (ratio = worst relative difference / tolerance; "
            "dead c. = dead-centre rows excluded, counted)" + (f"; worst ratio: {worst}" if worst else ""),
            *failure_lines(failures, markdown)]
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
