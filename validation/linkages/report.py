"""The report of a linkage run: ``summary.json``, ``report.md``, ``report.html`` (self-contained),
``figures/<case>.png`` and every engine's table (``tables/<case>/<engine>.csv``) in the run folder.

Per judge the slider crank report's heat map of its ratio to tolerance per case and column
(:func:`judge_heatmaps`); per case one figure: the output angle against the input angle from every engine
(the reference as a line, each judge as markers), and below it each judge's worst ratio of relative
difference to tolerance per row (log scale; at most 1 passes).  The templates are
``validation/templates/linkages.*.j2``; the folder rules (a dualmech folder only, one writer at a time, a
manifest of what was written) are those of :mod:`dualmech.validation.rundir`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from dualmech.models.linkages import table_spec
from dualmech.validation.compare import ENGINE, STATUS
from dualmech.validation.linkages.matrix import LinkageEntry
from dualmech.validation.linkages.run import LinkageRun, write_tables
from dualmech.validation.provenance import KEY_LIBRARIES, versions
from dualmech.validation.report.canvas import drawing, fig_to_png
from dualmech.validation.report.plots import (
    HEATMAP_CAPTION,
    JUDGE_MARKERS,
    LOG_FLOOR,
    Figure,
    heatmap_arrays,
    heatmap_figure,
)
from dualmech.validation.report.render import environment
from dualmech.validation.rundir import locked, record_files, write_file, write_json

#: The report's Jinja2 templates (beside the slider crank's).
TEMPLATES = Path(__file__).resolve().parent.parent / "templates"
#: Format tag of a linkage run's ``summary.json`` (a dualmech folder marker, not a slider-crank baseline).
SUMMARY_FORMAT = "dualmech-summary/linkages-1"


@dataclass(frozen=True)
class LinkageReport:
    """What :func:`write_linkage_report` wrote."""

    summary: Path
    markdown: Path
    html: Path
    figures: tuple[Path, ...]
    tables: tuple[Path, ...]
    seconds: float
    verdict: str


def engine_rows(run: LinkageRun) -> list[dict]:
    """One row per case and engine of the matrix: its verdict, checks, worst ratio and where, seconds.
    ``at_deg`` is the input value at the worst row: the case's key
    (:attr:`~dualmech.models.linkages.table.TableSpec.key`), named by ``input`` in ``input_unit`` (``deg``,
    or ``""`` for a loop table driven by a slide, in its length unit)."""
    rows = []
    for entry in run.matrix.cases:
        solved = run.tables[entry.id]
        name, unit = table_spec(entry.kind, entry.case).key_label
        for engine in run.matrix.engines:
            checks = run.comparison.for_engine(entry.id, engine)
            worst = max(checks, key=lambda c: (not c.passed, c.ratio), default=None)
            table = solved.get(engine)
            rows.append({
                "case": entry.id, "kind": entry.kind, "engine": engine, "applies": engine in solved,
                "reference": engine == run.matrix.reference, "rows": None if table is None or isinstance(
                    table, str) else len(table),
                "passed": all(c.passed for c in checks) if checks else None, "n_checks": len(checks),
                "n_failed": sum(not c.passed for c in checks),
                "ratio": None if worst is None else worst.ratio,
                "quantity": None if worst is None else worst.quantity,
                "at_deg": None if worst is None else worst.worst_theta_deg, "input": name, "input_unit": unit,
                "seconds": run.seconds[entry.id].get(engine)})
    return rows


def linkage_summary(run: LinkageRun, seconds: float) -> dict:
    """The JSON summary of a linkage run (``summary.json``): verdict, worst ratio per judge, every check."""
    comparison = run.comparison
    return {
        "format": SUMMARY_FORMAT,
        "matrix": run.matrix.name,
        "description": run.matrix.description,
        "reference": run.matrix.reference,
        "engines": list(run.matrix.engines),
        "verdict": str(run.verdict),
        "passed": comparison.passed,
        "n_checks": len(comparison.checks),
        "n_failed": len(comparison.failures()),
        "seconds": seconds,
        "versions": versions(KEY_LIBRARIES),
        "cases": [{"id": e.id, "kind": e.kind, "source": e.source, "engines": list(run.matrix.engines_of(e))}
                  for e in run.matrix.cases],
        "worst": {judge: {"case": c.case, "quantity": c.quantity, "ratio": c.ratio, "max_rel": c.max_rel,
                          "tolerance": c.tolerance.name, "passed": c.passed}
                  for judge, c in run.worst().items()},
        "engine_rows": engine_rows(run),
        "errors": comparison.errors,
        "checks": [c.to_dict() for c in comparison.checks],
    }


def case_figure(run: LinkageRun, entry: LinkageEntry) -> Figure:
    """The output (:attr:`~dualmech.models.linkages.table.TableSpec.shown`: the output angle, or a loop
    table's last free coordinate) from every engine against the input, and each judge's worst ratio to
    tolerance per row."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    spec, case_id = table_spec(entry.kind, entry.case), entry.id
    column, key = spec.shown, spec.key
    name, unit = spec.key_label
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(7.0, 5.6), sharex=True)
    colors = [plt.get_cmap("tab10")(i) for i in range(10)]
    judges = [e for e in run.tables[case_id] if e != run.matrix.reference]
    reference = run.tables[case_id].get(run.matrix.reference)
    if reference is not None and not isinstance(reference, str):
        top.plot(reference[key], reference[column], "-", color="black", lw=1.3,
                 label=f"{run.matrix.reference} (reference)")
    for j, engine in enumerate(judges):
        table, style = run.tables[case_id][engine], dict(color=colors[j % 10], ms=4, ls="none", mfc="none")
        if not isinstance(table, str):
            top.plot(table[key], table[column], JUDGE_MARKERS[j % len(JUDGE_MARKERS)], label=engine,
                     **style)
        if engine in run.ratios[case_id]:
            theta, kin, reac = run.ratios[case_id][engine]
            worst = np.fmax(kin, reac)
            bottom.semilogy(theta, np.clip(worst, LOG_FLOOR, None), JUDGE_MARKERS[j % len(JUDGE_MARKERS)],
                            label=engine, **style)
    bottom.axhline(1.0, color="#c62828", ls="--", lw=1.0, label="tolerance")
    radians = spec.period(column) is not None and not column.endswith("_deg")
    top.set_ylabel(f"{column} (rad)" if radians else column, fontsize=8)
    top.set_title(f"{case_id}: {column} from every engine", fontsize=9)
    bottom.set_ylabel("worst |judge - ref| / (scale x tol)", fontsize=8)
    bottom.set_xlabel(f"{name} ({unit})" if unit else name, fontsize=8)
    for ax in (top, bottom):
        ax.tick_params(labelsize=7)
        ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    caption = (f"{column} against the input {name}, and per row "
               "each judge's worst ratio of relative difference to its tolerance (<= 1 passes)")
    png = fig_to_png(fig)
    return Figure(f"linkage-{case_id}", "linkage", case_id, f"{case_id}: {column}", caption, png)


def judge_heatmaps(run: LinkageRun) -> list[Figure]:
    """Per judge, the heat map of the slider crank's report (:func:`~dualmech.validation.report.plots.
    heatmap_figure`): its ratio to tolerance per case and compared column (the columns in the order the
    cases' checks name them: every kind's, a matrix of several kinds has their union), a failed check
    marked, a failed status or engine its case's whole row."""
    figures = []
    for e in run.matrix.judges:
        ids = [entry.id for entry in run.matrix.cases if run.comparison.for_engine(entry.id, e)]
        if not ids:
            continue
        qs = list(dict.fromkeys(c.quantity for cid in ids for c in run.comparison.for_engine(cid, e)
                                if c.quantity not in (STATUS, ENGINE)))
        arrays = heatmap_arrays(run.comparison, e, ids, qs)
        with drawing():
            png = heatmap_figure(e, ids, qs, *arrays)
        figures.append(Figure(f"heatmap-{e}", "heatmap", e, f"{e}: agreement per case and quantity",
                              HEATMAP_CAPTION, png))
    return figures


def write_linkage_report(run: LinkageRun, outdir: Path, seconds: float) -> LinkageReport:
    """Write the run folder's tables, figures, ``summary.json``, ``report.md`` and ``report.html``."""
    start = time.perf_counter()
    with locked(outdir) as outdir:
        tables = write_tables(run, outdir)
        figures = [*judge_heatmaps(run), *(case_figure(run, e) for e in run.matrix.cases)]
        paths = [write_file(outdir, f"figures/{f.key}.png", f.png, record=False) for f in figures]
        summary = linkage_summary(run, seconds)
        context = {"s": summary, "figures": figures, "failures": run.comparison.failures()[:200],
                   "checks": run.comparison.checks, "report_seconds": time.perf_counter() - start,
                   "generated": time.strftime("%Y-%m-%d %H:%M:%S %Z")}
        files = LinkageReport(outdir / "summary.json", outdir / "report.md", outdir / "report.html",
                              tuple(paths), tuple(tables), 0.0, str(run.verdict))
        write_json(outdir, files.summary.name, summary, pretty=True, record=False)
        for template, target, markdown in (("linkages.md.j2", files.markdown, True),
                                           ("linkages.html.j2", files.html, False)):
            write_file(outdir, target.name, environment(TEMPLATES, markdown).get_template(template).render(
                **context), record=False)
        record_files(outdir, [files.summary, files.markdown, files.html, *paths, *tables])
    return replace(files, seconds=time.perf_counter() - start)


def console_table(run: LinkageRun, title: str) -> Any:
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


def verdict_lines(run: LinkageRun, markdown: str) -> list[Any]:
    """The verdict line with each judge's worst ratio, and the first failures (the rest: see ``markdown``)."""
    from dualmech.validation.report.console import VERDICT_COLOURS, failure_lines

    failures = run.comparison.failures()
    n = len(run.comparison.checks)
    worst = "; ".join(f"{e} {c.ratio:.2g} ({c.case} {c.quantity})" for e, c in run.worst().items())
    out: list[Any] = [f"[{VERDICT_COLOURS[str(run.verdict)]}]{run.verdict}[/]: {n - len(failures)} of {n} "
                      f"checks passed; worst ratio (relative difference / tolerance): {worst}",
                      *failure_lines(failures, markdown)]
    return out
