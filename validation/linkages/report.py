"""The report of a linkage run (RSSR, RCCC, loop tables): the slider crank's report, by the same templates
and section code (:mod:`dualmech.validation.report.render`, :mod:`dualmech.validation.report.sections`), with
each kind's own sections, and every engine's table (``tables/<case>/<engine>.csv``) in the run folder.

What differs from the slider crank's is data, never a template of its own: the summary's second column is the
case's kind; the peak joint loads are those of every joint of the case's
:class:`~dualmech.models.linkages.table.TableSpec` (:func:`~dualmech.models.linkages.table_summary`),
one table per kind; dead centres are listed by the spec's key (the input value); the tolerances are the
linkage gate's (:func:`~dualmech.validation.linkages.gate.judge_tolerances`); each case has the engine-overlay
figure (:mod:`~dualmech.validation.report.overlay`: its output from every engine, each judge's worst ratio per
row) where the slider crank has its sweeps.  The slider crank's stroke, balancing and per-position difference
sections have no meaning here: the page says so and leaves them out (``omitted``).  The folder rules (a
dualmech folder only, one writer at a time, a manifest of what was written) are those of
:mod:`dualmech.validation.rundir`.
"""

from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from dualmech.models.linkages import table_spec, table_summary
from dualmech.validation.compare import ENGINE, STATUS
from dualmech.validation.durable import json_text
from dualmech.validation.linkages.gate import judge_tolerances
from dualmech.validation.linkages.matrix import LinkageEntry
from dualmech.validation.linkages.run import LinkageRun, as_run_matrix, write_tables
from dualmech.validation.matrix import Matrix
from dualmech.validation.progress import ProgressCallback
from dualmech.validation.report.figures import FigureSpec, PendingFigures, heatmap_spec
from dualmech.validation.report.render import (
    ReportFiles,
    comparison_summary,
    compiled_templates,
    publish,
    run_context,
)
from dualmech.validation.report.sections import tolerance_rows
from dualmech.validation.run.runner import load_run
from dualmech.validation.rundir import locked, record_files

#: The slider crank's sections a linkage report leaves out, and why (the page lists them).
OMITTED = ("the stroke (no slider)", "dynamic balancing (the slider crank's force balancing)",
           "sweep figures and the relative difference per crank position (each case's figure shows every "
           "judge's worst ratio per row)")

#: How the linkage gate (:mod:`~dualmech.validation.linkages.gate`) makes a relative difference, for the page.
GATE = {"differences": "per column, relative to the case's largest value of the column's unit group, with no "
                       "condition factor", "source": "validation/linkages/gate.py", "beside": ""}


def input_label(run: LinkageRun) -> str:
    """The input the cases' rows are keyed on, for headers: ``theta1 [deg]``, ``s1`` (a slide, in the case's
    length unit), or ``input value`` when the cases differ."""
    labels = {table_spec(e.kind, e.case).key_label for e in run.matrix.cases}
    if len(labels) != 1:
        return "input value"
    ((name, unit),) = labels
    return f"{name} [{unit}]" if unit else name


def design_tables(run: LinkageRun) -> list[dict]:
    """The peak-load tables (the templates' ``design``): the reference's
    :func:`~dualmech.models.linkages.table_summary` of every case it solved, one table per kind and
    set of joints, titled by the kind and its cases; no stroke or near-dead-centre column."""
    groups: dict[tuple, dict] = {}
    for entry in run.matrix.cases:
        table = run.tables[entry.id].get(run.matrix.reference)
        if table is None or isinstance(table, str):
            continue
        units = entry.data.get("units", "consistent")
        summary = replace(table_summary(table, table_spec(entry.kind, entry.case), units), case=entry.id)
        names = tuple(p.name for p in summary.peaks)
        group = groups.setdefault((entry.kind, names), {"kind": entry.kind, "columns": list(names),
                                                         "rows": [], "stroke": False, "near": False})
        group["rows"].append(summary)
    for g in groups.values():
        g["title"] = f"{g.pop('kind')}: {', '.join(d.case for d in g['rows'])}"
    return list(groups.values())


def linkage_context(run: LinkageRun, matrix: Matrix, stored: dict) -> dict:
    """The template variables of a linkage run (module docstring); ``matrix`` the runner's
    (:func:`~dualmech.validation.linkages.run.as_run_matrix`), ``stored`` its ``run.json``."""
    keys = {e.id: table_spec(e.kind, e.case).key for e in run.matrix.cases}
    context = run_context(matrix, stored, run.tables, run.comparison, keys)
    kinds = {e.id: e.kind for e in run.matrix.cases}
    for row in context["summary"]:
        row.update(mode=kinds[row["case"]], run=bool(run.tables.get(row["case"])))
    label = input_label(run)
    context.update(mode_label="kind", key_label=label, input_name=f"input ({label})", omitted=list(OMITTED),
                   not_applicable=not_applicable_lines(run),
                   gate=GATE,
                   design=design_tables(run),
                   tolerances=tolerance_rows({e: judge_tolerances(e) for e in run.matrix.judges}))
    return context


def linkage_summary(run: LinkageRun, matrix: Matrix, stored: dict) -> dict:
    """``summary.json`` of a linkage run: the slider crank's (:func:`~dualmech.validation.report.render.
    comparison_summary`: verdict, every check, errors, dead centres, the run), each case's kind, source, key
    and engines, and per judge its worst check (the input value of its worst row as ``at``)."""
    keys = {e.id: table_spec(e.kind, e.case).key_label for e in run.matrix.cases}
    refused = run.matrix.not_applicable()  # once: the simulation's applicability solves each case in-house
    cases = [{"id": e.id, "kind": e.kind, "source": e.source, "key": table_spec(e.kind, e.case).key,
              "engines": [n for n in run.matrix.engines if n not in refused.get(e.id, {})],
              "not_applicable": refused.get(e.id, {})} for e in run.matrix.cases]
    worst = {judge: {"case": c.case, "quantity": c.quantity, "ratio": c.ratio, "max_rel": c.max_rel,
                     "tolerance": c.tolerance.name, "passed": c.passed, "input": keys[c.case][0],
                     "input_unit": keys[c.case][1], "at": c.worst_theta_deg}
             for judge, c in run.worst().items()}
    return comparison_summary(matrix, run.comparison, stored) | {"cases": cases, "worst": worst}


def case_spec(run: LinkageRun, entry: LinkageEntry) -> FigureSpec:
    """The plan of one case's engine-overlay figure (:mod:`~dualmech.validation.report.overlay`): its output
    (:attr:`~dualmech.models.linkages.table.TableSpec.shown`: the output angle, or a loop table's last free
    coordinate) from every engine against the input, and each judge's worst ratio to tolerance per row."""
    spec, case_id, reference = table_spec(entry.kind, entry.case), entry.id, run.matrix.reference
    column, key = spec.shown, spec.key
    name, unit = spec.key_label
    curves = []
    for engine in sorted(run.tables[case_id], key=lambda e: e != reference):  # the reference first
        table = run.tables[case_id][engine]
        x, y = (None, None) if isinstance(table, str) else (table[key], table[column])
        rows = run.ratios[case_id].get(engine)
        ratio = (None, None) if rows is None else (rows[0], np.fmax(rows[1], rows[2]))
        curves.append((engine, x, y, *ratio))
    radians = spec.period(column) is not None and not column.endswith("_deg")
    title = f"{case_id}: {column} from every engine"
    caption = (f"{column} against the input {name}, and per row each judge's worst ratio of relative "
               "difference to its tolerance (<= 1 passes)")
    axes = (f"{name} ({unit})" if unit else name, f"{column} (rad)" if radians else column)
    job = (title, *axes, tuple(curves))
    return FigureSpec(f"linkage-{case_id}", "case", case_id, title, caption, ("case", job), static=True)


def figure_specs(run: LinkageRun) -> list[FigureSpec]:
    """Every figure of a linkage report: per judge the slider crank's heat map (the columns in the order the
    cases' checks name them: every kind's, a matrix of several kinds has their union), then the engine-overlay
    figure of each case that some engine solved."""
    specs = []
    for e in run.matrix.judges:
        ids = [entry.id for entry in run.matrix.cases if run.comparison.for_engine(entry.id, e)]
        qs = list(dict.fromkeys(c.quantity for cid in ids for c in run.comparison.for_engine(cid, e)
                                if c.quantity not in (STATUS, ENGINE)))
        if ids and qs:  # a judge with no column compared (every case's reference failed) has no map
            specs.append(heatmap_spec(run.comparison, e, ids, qs))
    return specs + [case_spec(run, entry) for entry in run.matrix.cases
                    if any(not isinstance(t, str) for t in run.tables[entry.id].values())]


def write_linkage_report(run: LinkageRun, rundir: Path, outdir: Path, *, jobs: int = 1,
                         progress: ProgressCallback | None = None) -> ReportFiles:
    """Write the report of the linkage run stored in ``rundir`` (its ``run.json``) into ``outdir``: every
    engine's table, the figures (drawn in ``jobs`` processes; ``progress(done, total, key)`` after each),
    ``summary.json``, ``report.md`` and ``report.html``
    (:func:`~dualmech.validation.report.render.publish`)."""
    start = time.perf_counter()
    matrix, stored = as_run_matrix(run.matrix), load_run(rundir)[1]
    with locked(outdir) as outdir:
        record_files(outdir, write_tables(run, outdir))
        pending = PendingFigures(jobs)
        try:
            pending.add(figure_specs(run))
            figures = pending.collect(progress)
        finally:
            pending.cancel()
        summary = json_text(linkage_summary(run, matrix, stored), pretty=True)
        files = publish(outdir, linkage_context(run, matrix, stored), summary, compiled_templates(), figures,
                        start, str(run.verdict))
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


def not_applicable_lines(run: LinkageRun) -> list[str]:
    """One line per case and engine of the matrix that does not solve it (a "–" in the summary), saying why:
    ``"exudyn on rrcrc: the Exudyn judge drives the first joint only (...)"``."""
    return [f"{engine} on {case}: {why}" for case, engines in run.matrix.not_applicable().items()
            for engine, why in engines.items()]


def verdict_lines(run: LinkageRun, markdown: str) -> list[Any]:
    """The verdict line with each judge's worst ratio, and the first failures (the rest: see ``markdown``)."""
    from dualmech.validation.report.console import VERDICT_COLOURS, failure_lines

    failures = run.comparison.failures()
    n = len(run.comparison.checks)
    worst = "; ".join(f"{e} {c.ratio:.2g} ({c.case} {c.quantity})" for e, c in run.worst().items())
    out: list[Any] = [f"[dim]– not applicable: {line}[/]" for line in not_applicable_lines(run)]
    out += [f"[{VERDICT_COLOURS[str(run.verdict)]}]{run.verdict}[/]: {n - len(failures)} of {n} "
            f"checks passed; worst ratio (relative difference / tolerance): {worst}",
            *failure_lines(failures, markdown)]
    return out
