"""The report's sections of the cases whose kind has a table spec (RSSR, RCCC, loop tables), beside the
slider crank's, in one report (:mod:`dualmech.validation.report.render`, the same templates), and every
engine's table of those cases (``tables/<case>/<engine>.csv``) in the run folder.

What differs from the slider crank's is data, never a template of its own: the summary's second column is the
case's kind; the peak joint loads are those of every joint of the case's
:class:`~dualmech.models.tables.TableSpec` (:func:`~dualmech.models.linkages.table_summary`), one
table per kind and set of joints; dead centres are listed by the spec's key (the input value); the tolerances
are per group (``kinematics``, ``reactions``); each case has the engine-overlay figure
(:mod:`~dualmech.validation.report.overlay`: its output from every engine, each judge's worst ratio per row)
where the slider crank has its sweeps.  The slider crank's stroke, balancing and per-position difference
sections have no meaning for these kinds: a report with no slider-crank case says so and leaves them out
(:data:`OMITTED`).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from dualmech.models.kinds import SLIDER_CRANK, case_from_data, kind_of
from dualmech.models.linkages import table_spec, table_summary
from dualmech.models.tables import TableSpec
from dualmech.validation.compare import ENGINE, STATUS, Check, Comparison
from dualmech.validation.matrix import Matrix, MatrixCase
from dualmech.validation.report.figures import FigureSpec, heatmap_spec
from dualmech.validation.rundir import write_file

#: The slider crank's sections a report of no slider-crank case leaves out, and why (the page lists them).
OMITTED = ("the stroke (no slider)", "dynamic balancing (the slider crank's force balancing)",
           "sweep figures and the relative difference per crank position (each case's figure shows every "
           "judge's worst ratio per row)")

#: How the gate of these kinds (:mod:`~dualmech.validation.compare.tables`) makes a relative difference.
GATE = {"differences": "per column, relative to the case's largest value of the column's unit group, with no "
                       "condition factor", "source": "validation/compare/tables.py", "beside": ""}


def table_specs(matrix: Matrix) -> dict[str, tuple[str, TableSpec]]:
    """Case id -> its kind and table spec, for every case of ``matrix`` that is not a slider crank."""
    out = {}
    for mc in matrix.cases:
        if not mc.is_slider_crank:
            case = case_from_data(mc.raw)
            out[mc.id] = (kind_of(case), table_spec(kind_of(case), case))
    return out


def input_label(specs: dict[str, tuple[str, TableSpec]], slider_cranks: bool) -> str:
    """The input the cases' rows are keyed on, for headers: ``theta1 [deg]``, ``s1`` (a slide, in the case's
    length unit), or ``input value`` when the cases differ."""
    labels = {spec.key_label for _, spec in specs.values()}
    labels |= {("theta1", "deg")} if slider_cranks else set()
    if len(labels) != 1:
        return "input value"
    ((name, unit),) = labels
    return f"{name} [{unit}]" if unit else name


def design_tables(matrix: Matrix, results: dict, specs: dict[str, tuple[str, TableSpec]]) -> list[dict]:
    """The peak-load tables (the templates' ``design``): the reference's
    :func:`~dualmech.models.linkages.table_summary` of every case of ``specs`` it solved, one table per kind
    and set of joints, titled by the kind and its cases; no stroke or near-dead-centre column."""
    groups: dict[tuple, dict] = {}
    for mc in matrix.cases:
        table = results.get(mc.id, {}).get(matrix.reference)
        if mc.id not in specs or table is None or isinstance(table, str):
            continue
        kind, spec = specs[mc.id]
        summary = replace(table_summary(table, spec, mc.raw.get("units", "consistent")), case=mc.id)
        names = tuple(p.name for p in summary.peaks)
        group = groups.setdefault((kind, names), {"kind": kind, "columns": list(names), "rows": [],
                                                  "stroke": False, "near": False})
        group["rows"].append(summary)
    for g in groups.values():
        g["title"] = f"{g.pop('kind')}: {', '.join(d.case for d in g['rows'])}"
    return list(groups.values())


def not_applicable_lines(refused: dict[str, dict[str, str]]) -> list[str]:
    """One line per case and engine that does not solve it (``refused``:
    :func:`~dualmech.validation.matrix.cases.not_applicable`; a "–" in the summary), saying why:
    ``"exudyn on rrcrc: the Exudyn judge drives the first joint only (...)"``."""
    return [f"{engine} on {case}: {why}" for case, engines in refused.items()
            for engine, why in engines.items()]


def worst_checks(matrix: Matrix, comparison: Comparison) -> dict[str, Check]:
    """Per judge, its check of the largest ratio to tolerance over every case (a failing one first)."""
    out: dict[str, Check] = {}
    for c in comparison.checks:
        if c.engine == matrix.reference:
            continue
        best = out.get(c.engine)
        if best is None or (not c.passed, c.ratio) > (not best.passed, best.ratio):
            out[c.engine] = c
    return out


def case_figure(matrix: Matrix, results: dict, comparison: Comparison, mc: MatrixCase, spec: TableSpec
                ) -> FigureSpec:
    """The plan of one case's engine-overlay figure (:mod:`~dualmech.validation.report.overlay`): its output
    (:attr:`~dualmech.models.tables.TableSpec.shown`: the output angle, or a loop table's last free
    coordinate) from every engine against the input, and each judge's worst ratio to tolerance per row (its
    worst ``r_i`` of :attr:`Comparison.row_differences` over its group's tolerance)."""
    column, key, reference = spec.shown, spec.key, matrix.reference
    name, unit = spec.key_label
    curves = []
    for engine in sorted(results[mc.id], key=lambda e: e != reference):  # the reference first
        table = results[mc.id][engine]
        x, y = (None, None) if isinstance(table, str) else (table[key], table[column])
        rows = comparison.row_differences.get(mc.id, {}).get(engine)
        tols = matrix.tolerances.get(engine, {})
        ratio = (None, None) if rows is None else (
            rows[0], np.fmax(rows[1] / tols["kinematics"].value, rows[2] / tols["reactions"].value))
        curves.append((engine, x, y, *ratio))
    radians = spec.period(column) is not None and not column.endswith("_deg")
    title = f"{mc.id}: {column} from every engine"
    caption = (f"{column} against the input {name}, and per row each judge's worst ratio of relative "
               "difference to its tolerance (<= 1 passes)")
    axes = (f"{name} ({unit})" if unit else name, f"{column} (rad)" if radians else column)
    job = (title, *axes, tuple(curves))
    return FigureSpec(f"linkage-{mc.id}", "case", mc.id, title, caption, ("case", job), static=True)


def figure_specs(matrix: Matrix, results: dict, comparison: Comparison,
                 specs: dict[str, tuple[str, TableSpec]]) -> list[FigureSpec]:
    """The figures of the cases of ``specs``: per judge a heat map (the columns in the order the cases'
    checks name them: every kind's, a matrix of several kinds has their union; ``heatmap-tables-<judge>``
    beside a slider crank's), then the engine-overlay figure of each case that some engine solved."""
    out = []
    suffix = "-tables" if len(specs) < len(matrix.cases) else ""
    for e in matrix.judges:
        ids = [mc.id for mc in matrix.cases if mc.id in specs and comparison.for_engine(mc.id, e)]
        qs = list(dict.fromkeys(c.quantity for cid in ids for c in comparison.for_engine(cid, e)
                                if c.quantity not in (STATUS, ENGINE)))
        if ids and qs:  # a judge with no column compared (every case's reference failed) has no map
            out.append(heatmap_spec(comparison, e, ids, qs, key=f"heatmap{suffix}-{e}"))
    return out + [case_figure(matrix, results, comparison, mc, specs[mc.id][1]) for mc in matrix.cases
                  if mc.id in specs and any(not isinstance(t, str) for t in results.get(mc.id, {}).values())]


def write_tables(outdir: Path, results: dict, specs: dict[str, tuple[str, TableSpec]]) -> list[Path]:
    """Every engine's table of every case of ``specs`` as ``tables/<case>/<engine>.csv`` (full precision)."""
    return [write_file(outdir, f"tables/{case_id}/{engine}.csv", table.to_csv(), record=False)
            for case_id, per in results.items() if case_id in specs for engine, table in per.items()
            if not isinstance(table, str)]


def summary_cases(matrix: Matrix, specs: dict[str, tuple[str, TableSpec]],
                  refused: dict[str, dict[str, str]]) -> list[dict]:
    """``summary.json``'s ``cases``: per case its id, kind, load mode (a slider crank's), swept values and
    sweeps, input key (the column its rows are keyed on), engines that solve it and those that do not with
    why (``refused``: :func:`~dualmech.validation.matrix.cases.not_applicable`)."""
    return [{"id": mc.id, "kind": specs[mc.id][0] if mc.id in specs else SLIDER_CRANK, "mode": mc.mode,
             "values": mc.values, "sweeps": list(mc.sweeps),
             "key": specs[mc.id][1].key if mc.id in specs else "theta1_deg",
             "engines": list(matrix.engines_of(mc)), "not_applicable": refused.get(mc.id, {})}
            for mc in matrix.cases]


def worst_summary(matrix: Matrix, comparison: Comparison, specs: dict[str, tuple[str, TableSpec]]
                  ) -> dict[str, dict[str, Any]]:
    """``summary.json``'s ``worst``: per judge its worst check (:func:`worst_checks`), the input value of its
    worst row as ``at``, with the input's name and unit."""
    def key(case: str) -> tuple[str, str]:
        return specs[case][1].key_label if case in specs else ("theta1", "deg")

    return {judge: {"case": c.case, "quantity": c.quantity, "ratio": c.ratio, "max_rel": c.max_rel,
                    "tolerance": c.tolerance.name, "passed": c.passed, "input": key(c.case)[0],
                    "input_unit": key(c.case)[1], "at": c.worst_theta_deg}
            for judge, c in worst_checks(matrix, comparison).items()}
