"""Writing a report: the Jinja2 templates of ``validation/templates/`` filled with the sections.

:func:`write_report` renders a self-contained HTML page (autoescaped; every figure interactive, plotly.js
inlined once and each figure's data beside it; nothing loaded from the network, which the page's
Content-Security-Policy forbids) and a Markdown summary (every value escaped by :func:`markdown_escape`, the
static figures beside it under ``figures/``), and writes ``summary.json``.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Callable

from dualmech.models.design_summary import JOINTS, NEAR_DEAD_CENTRE_TRANSMISSION
from dualmech.models.tables import TableSpec
from dualmech.validation.compare import Check, Comparison, compare_run
from dualmech.validation.durable import json_text
from dualmech.validation.matrix import Matrix
from dualmech.validation.matrix.cases import not_applicable
from dualmech.validation.progress import ProgressCallback
from dualmech.validation.provenance import key_versions
from dualmech.validation.report import derived
from dualmech.validation.report.figures import PendingFigures, start_figures
from dualmech.validation.report.interactive import plotly_js
from dualmech.validation.report.plots import Figure
from dualmech.validation.report.sections import (
    balancing_spec,
    copy_errata,
    dead_centre_rows,
    design_rows,
    engine_versions,
    pair_groups,
    stroke_rows,
    summary_rows,
    tolerance_rows,
)
from dualmech.validation.report.tables import GATE as TABLES_GATE
from dualmech.validation.report.tables import (
    OMITTED,
    design_tables,
    input_label,
    not_applicable_lines,
    summary_cases,
    table_specs,
    worst_summary,
    write_tables,
)
from dualmech.validation.report.tables import figure_specs as table_figures
from dualmech.validation.run import runner
from dualmech.validation.rundir import locked, record_files, remove_stale, write_file

#: The report's Jinja2 templates.
TEMPLATES = Path(__file__).resolve().parent.parent / "templates"

#: How the slider crank's gate (:mod:`dualmech.validation.compare`) makes a relative difference, for the page.
GATE = {"differences": "normwise per unit group and, for reactions in drive-torque mode, weighted by the "
                       "transmission |t|", "source": "validation/compare/checks.py",
        "beside": "Rows beside them are compared with a tolerance scaled by 1/|t|."}


@dataclass(frozen=True)
class ReportFiles:
    """Where :func:`write_report` put its output."""

    html: Path
    markdown: Path
    summary: Path
    figures: tuple[Path, ...]
    seconds: float
    verdict: str  # PASS, FAIL or INCOMPLETE (validation/compare.py Verdict)


def markdown_escape(value: Any) -> str:
    """Text safe inside Markdown (and its tables): markup characters and HTML are escaped."""
    text = "" if value is None else str(value)
    text = text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
    text = text.replace("\r", " ").replace("\n", " ")
    out = []
    for ch in text:
        out.append("\\" + ch if ch in "\\`*_{}[]()#+!|~" else ch)
    return "".join(out)


def _fmt(x: Any, spec: str = ".3g") -> str:
    """The templates' ``fmt`` filter: ``format(x, spec)``, with a dash for None and NaN."""
    if x is None:
        return "–"
    if isinstance(x, float) and math.isnan(x):
        return "–"
    if isinstance(x, float) and math.isinf(x):
        return "∞"
    return format(x, spec)


def environment(loader_dir: Path, markdown: bool) -> Any:
    """A Jinja2 environment over the templates in ``loader_dir``: HTML autoescaped, or Markdown escaped.

    Both fail on an undefined variable and have the ``fmt`` filter (numbers to short text).
    """
    from jinja2 import Environment, FileSystemLoader, StrictUndefined, select_autoescape

    if markdown:
        env = Environment(
            loader=FileSystemLoader(str(loader_dir)),
            autoescape=False,
            undefined=StrictUndefined,
            finalize=markdown_escape,
            trim_blocks=True,
            lstrip_blocks=True,
            keep_trailing_newline=True,
        )
    else:
        env = Environment(
            loader=FileSystemLoader(str(loader_dir)),
            undefined=StrictUndefined,
            autoescape=select_autoescape(["html", "j2"], default_for_string=True, default=True),
            trim_blocks=True,
            lstrip_blocks=True,
        )
    env.filters["fmt"] = _fmt
    return env


def comparison_summary(matrix: Matrix, comparison: Comparison, run: dict,
                       specs: dict[str, tuple[str, TableSpec]] | None = None,
                       refused: dict[str, dict[str, str]] | None = None) -> dict:
    """The JSON summary of a run (``summary.json``): every check, strokes, verdicts, each case's kind, input
    and engines (:func:`~dualmech.validation.report.tables.summary_cases`), each judge's worst check.
    ``specs`` (:func:`~dualmech.validation.report.tables.table_specs`) and ``refused``
    (:func:`~dualmech.validation.matrix.cases.not_applicable`) are the matrix's, made here if not given."""
    specs = table_specs(matrix) if specs is None else specs
    refused = not_applicable(matrix) if refused is None else refused
    return {
        "format": "dualmech-summary/1",
        "matrix": matrix.name,
        "reference": matrix.reference,
        "engines": list(matrix.engines),
        "passed": comparison.passed,
        "verdict": str(comparison.verdict),
        "n_checks": len(comparison.checks),
        "n_failed": len(comparison.failures()),
        "n_missing": len(comparison.missing),
        "versions": key_versions(run),
        "run": {k: run.get(k) for k in ("started", "seconds", "jobs", "scheduler", "machine", "versions")},
        "cases": summary_cases(matrix, specs, refused),
        "worst": worst_summary(matrix, comparison, specs),
        "strokes": comparison.strokes,
        "dead_centres": comparison.dead_centres,
        "errors": comparison.errors,
        "checks": [c.to_dict() for c in comparison.checks],
        "pairs": [p.to_dict() for p in comparison.pairs],
    }


def write_report(
    rundir: str | Path,
    outdir: str | Path | None = None,
    *,
    jobs: int = 1,
    comparison: Comparison | Callable[[], Comparison] | None = None,
    results: dict | None = None,
    progress: ProgressCallback | None = None,
    findings: Callable[[], list[dict]] | None = None,
) -> ReportFiles:
    """Render the report of the run in ``rundir`` into ``outdir`` (default: ``rundir``).

    Writes ``report.html`` (self-contained, its figures interactive), ``report.md``, ``summary.json`` and
    ``figures/*.png`` (the figures the Markdown report shows), and lists them in the folder's manifest
    (:mod:`~dualmech.validation.rundir`: only a dualmech folder, one writer at a time,
    and only figures it wrote before are removed when they are no longer drawn).
    ``comparison`` and ``results`` (case id -> engine -> table or error text), if given, are the run's as
    :func:`~dualmech.verbs.run_and_compare` has them in memory; else they are read and made here.
    ``comparison`` may also be a function that makes it: it is called once the first figures are being
    drawn (:func:`~dualmech.validation.report.figures.start_figures`), so that ``jobs`` workers draw while
    this process compares.  ``findings``, if given, gives the thesis's findings (e.g. solved while the run
    ran: :func:`~dualmech.validation.report.derived.findings_ahead`); else they are solved here.
    """
    start = time.perf_counter()
    rundir = Path(rundir)
    matrix, run = runner.load_run(rundir)
    if results is None:
        results = runner.load_results(rundir, matrix)
    with locked(outdir if outdir is not None else rundir) as outdir:
        specs = table_specs(matrix)
        record_files(outdir, write_tables(outdir, results, specs))
        pending = _section("figures", start_figures, matrix, results, jobs=jobs)
        try:
            comparison = _compared(matrix, results, comparison)
            context, summary, templates = _while_drawn(matrix, run, results, comparison, pending,
                                                       findings or derived.findings, specs)
            figures = _section("figures", pending.collect, progress)
        finally:
            pending.cancel()  # after a failure: the figures not started yet (none left otherwise)
        context["errata"] = copy_errata(outdir) if context["findings"] else None
        files = publish(outdir, context, summary, templates, figures, start, str(comparison.verdict))
    return replace(files, seconds=time.perf_counter() - start)


def publish(outdir: Path, context: dict, summary: str, templates: tuple[Any, Any], figures: list[Figure],
            start: float, verdict: str) -> ReportFiles:
    """Write a report into ``outdir`` (held by :func:`~dualmech.validation.rundir.locked`): the figures'
    PNGs, ``report.html`` and ``report.md`` from the compiled ``templates`` (:func:`compiled_templates`)
    filled with ``context`` and the ``figures``, and the ``summary`` (``summary.json``'s text).  ``start``:
    the report's :func:`time.perf_counter` at its start."""
    paths = _write_figures(outdir, figures)
    context.update(figures=figures, plotly_js=plotly_js(), report_seconds=time.perf_counter() - start)
    files = ReportFiles(outdir / "report.html", outdir / "report.md", outdir / "summary.json",
                        tuple(paths), 0.0, verdict)
    for target, text in ((files.html, templates[0].render(**context)),
                         (files.markdown, templates[1].render(**context)), (files.summary, summary)):
        write_file(outdir, target.name, text)
    return files


def compiled_templates() -> tuple[Any, Any]:
    """The report's HTML and Markdown templates (``validation/templates/report.{html,md}.j2``), compiled."""
    return (environment(TEMPLATES, markdown=False).get_template("report.html.j2"),
            environment(TEMPLATES, markdown=True).get_template("report.md.j2"))


def _while_drawn(matrix: Matrix, run: dict, results: dict, comparison: Comparison, pending: PendingFigures,
                 findings: Callable[[], list[dict]], specs: dict[str, tuple[str, TableSpec]]
                 ) -> tuple[dict, str, tuple[Any, Any]]:
    """Start the figures that need the comparison (and the balancing section's), then make what needs no
    figure while the workers draw: the template variables but the figures (the findings solved here, with
    the compiled kernel that the run loaded in this process: engines.IN_PROCESS_ENGINES), the summary's
    JSON text and the compiled HTML and Markdown templates.  ``specs``: the table specs of the matrix's
    cases of other kinds (:func:`~dualmech.validation.report.tables.table_specs`)."""
    sliders = any(mc.is_slider_crank for mc in matrix.cases)
    balance = _section("balancing", derived.balancing, matrix) if sliders else None
    shaking = _section("balancing", balancing_spec, balance) if balance else None
    others = _section("figures", table_figures, matrix, results, comparison, specs)
    extra = (*([shaking] if shaking else []), *others)
    _section("figures", pending.add_judged, matrix, comparison, extra=extra)
    refused = not_applicable(matrix)  # once: the simulation's applicability solves a case in-house
    context = _context(matrix, run, results, comparison, specs, refused)
    context.update(findings=_section("findings", findings) if matrix.of_thesis else None,
                   balancing=balance.rows if balance else None)
    summary = json_text(comparison_summary(matrix, comparison, run, specs, refused), pretty=True)
    return context, summary, compiled_templates()


def _compared(matrix: Matrix, results: dict, comparison: Comparison | Callable[[], Comparison] | None
              ) -> Comparison:
    """The run's comparison: ``comparison``, made by it if it is a function, or made here."""
    if comparison is None:
        return compare_run(matrix, results)
    return comparison() if callable(comparison) else comparison


def _write_figures(outdir: Path, figures: list[Figure]) -> list[Path]:
    """Write the PNGs of the figures drawn as PNG; remove those this folder's earlier reports wrote that are
    no longer drawn (:mod:`~dualmech.validation.rundir`: inside the folder, never through a link)."""
    static = [f for f in figures if f.png is not None]
    names = [f"figures/{f.key}.png" for f in static]  # by their names in outdir, also when outdir is relative
    paths = [write_file(outdir, name, f.png, record=False) for name, f in zip(names, static)]
    record_files(outdir, names)
    remove_stale(outdir, names, "figures")
    return paths


def _context(matrix: Matrix, run: dict, results: dict, comparison: Comparison,
             specs: dict[str, tuple[str, TableSpec]], refused: dict[str, dict[str, str]]) -> dict:
    """The template variables that summarise a run (everything but the figures and the findings): the
    slider crank's sections where it has slider-crank cases, the other kinds' (``specs``,
    :mod:`~dualmech.validation.report.tables`) where it has those, each leaving out what the other has not."""
    sliders = [mc for mc in matrix.cases if mc.is_slider_crank]
    keys = {case: spec.key for case, (_, spec) in specs.items()}
    context = run_context(matrix, run, results, comparison, keys)
    label = input_label(specs, bool(sliders))
    kinds = {case: kind for case, (kind, _) in specs.items()}
    for row in context["summary"]:
        row["mode"] = kinds.get(row["case"], row["mode"])
    context.update(mode_label="mode" if not specs else "kind" if not sliders else "kind or mode",
                   key_label=label, input_name="crank angle" if not specs else f"input ({label})",
                   not_applicable=not_applicable_lines(refused), gate=_gate(bool(sliders), bool(specs)),
                   omitted=[] if sliders else list(OMITTED), design=design_tables(matrix, results, specs),
                   tolerances=tolerance_rows({e: matrix.tolerances[e] for e in matrix.judges}))
    if sliders:
        columns = [name for _, forces, moments in JOINTS
                   for name in (f"{forces[0][:2]} |f|", *([f"{moments[0][:2]} |m|"] if moments else []))]
        design = {"title": "slider crank" if specs else None, "columns": [*columns, "|drive_torque|",
                                                                          "|slider_load|"],
                  "rows": design_rows(matrix, results), "stroke": True, "near": True}
        context.update(strokes=stroke_rows(matrix, comparison), design=[design, *context["design"]],
                       sections=[(s.name, s.label) for s in matrix.sweeps], differences=True)
    return context


def _gate(sliders: bool, others: bool) -> dict[str, str]:
    """How the run's gates make a relative difference, for the page: the slider crank's, the other kinds', or
    both, each named."""
    if not (sliders and others):
        return GATE if sliders else TABLES_GATE
    return {"differences": f"for a slider crank {GATE['differences']}; for the other kinds "
                           f"{TABLES_GATE['differences']}", "source": "validation/compare/",
            "beside": f"{GATE['beside']} (a slider crank's)"}


def run_context(matrix: Matrix, run: dict, results: dict, comparison: Comparison,
                keys: dict[str, str] | None = None) -> dict:
    """The template variables of any kind's run: verdict, summary, failures, dead centres (at the input
    values of the columns ``keys`` names per case, the crank angle by default), every check, the run's
    ``run.json``; each kind's sections are added by :func:`_context`, those a run has not stay empty
    (``None``): the templates leave them out."""
    failures: list[Check] = comparison.failures()
    return {
        "matrix": matrix,
        "run": run,
        "passed": comparison.passed,
        "verdict": str(comparison.verdict),
        "n_missing": len(comparison.missing),
        "n_checks": len(comparison.checks),
        "checks": comparison.checks,
        "failures": failures[:200],
        "n_failures": len(failures),
        "near_lock": [c for c in comparison.checks if c.near_joint_lock],
        "pairs": comparison.pairs,
        "pair_groups": pair_groups(comparison.pairs),
        "summary": summary_rows(matrix, comparison),
        "mode_label": "mode",
        "input_name": "crank angle",
        "omitted": [],
        "not_applicable": [],  # "engine on case: why", of the engines that do not solve a case
        "dead_centres": dead_centre_rows(matrix, results, keys),
        "key_label": "theta1 [deg]",
        "engine_versions": engine_versions(results),
        "near_dead_centre": NEAR_DEAD_CENTRE_TRANSMISSION,
        "strokes": None, "balancing": None, "findings": None, "tolerances": [], "design": [], "sections": [],
        "differences": False,
        "n_done": len(results),
        "generated": time.strftime("%Y-%m-%d %H:%M:%S %Z"),
    }


class ReportError(RuntimeError):
    """A section of the report could not be built; the message is one line."""


def _section(name: str, build: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
    """``build(*args, **kwargs)``; any exception becomes a :class:`ReportError` naming the section."""
    try:
        return build(*args, **kwargs)
    except Exception as err:
        lines = str(err).strip().splitlines()
        raise ReportError(
            f"report section {name!r} failed: {type(err).__name__}: {lines[0][:200] if lines else ''}"
        ) from err
