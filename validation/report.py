"""The report of a validation run: a self-contained HTML page and a Markdown summary.

Sections return data (:func:`summary_rows`, :func:`stroke_rows`, :func:`findings`,
...) and figures (PNG bytes); :func:`write_report` renders them with the Jinja2
templates in ``validation/templates/`` (HTML with autoescaping, Markdown with every
value escaped by :func:`markdown_escape`), embeds the figures in the HTML as
base64 PNG and writes them beside the Markdown under ``figures/``.  The page loads
nothing from the network.

Figures (matplotlib, Agg):

* per sweep and load mode, the thesis's figs. 5-38 regenerated from the in-house
  engine, each judge overlaid as markers: slider displacement ``S4``, every joint
  force and moment component (world axes, ``docs/conventions.md``), the slider
  load and the drive torque, against the crank angle, the base (ideal) case in each.
  Dead-centre positions are marked with dotted vertical lines; values beyond the
  axis range (the ``1/t`` spikes beside a dead centre) are drawn as triangles on
  the axis edge -- never silently removed;
* per judge, the relative difference ``r_i`` (:mod:`dualmech.validation.compare`)
  against the crank angle on a log scale, worst over kinematics and over reactions;
* per judge, a heat map of the worst relative difference per case and quantity.
"""

from __future__ import annotations

import base64
import contextlib
import io
import math
import os
import re
import shutil
import tempfile
import time
import warnings
from dataclasses import dataclass, replace
from importlib import import_module
from pathlib import Path
from typing import Any, Callable

import numpy as np

from dualmech.core.table import NUMERIC_COLUMNS, REACTION_COLUMNS, ResultTable
from dualmech.models.design_summary import (
    JOINTS, NEAR_DEAD_CENTRE_TRANSMISSION, DesignSummary, design_summary,
)
from dualmech.models.units import DIMENSIONS, axis_label, column_unit
from dualmech.validation import runner
from dualmech.validation.runner import ProgressCallback
from dualmech.validation.compare import ENGINE, STATUS, STROKE, Check, Comparison, compare_run, relative_differences
from dualmech.validation.executors import process_pool
from dualmech.validation.matrix import Matrix
from dualmech.validation.provenance import key_versions
from dualmech.validation.rundir import locked, record_files, remove_stale

#: Figures of each sweep and load mode: (key, title, columns, panel grid (rows, cols)).
SWEEP_FIGURES: tuple[tuple[str, str, tuple[str, ...], tuple[int, int]], ...] = (
    ("S4", "slider displacement S4", ("S4",), (1, 1)),
    ("joint1", "joint 1 (ground on crank): force and moment about O", ("j1_fx", "j1_fy", "j1_fz", "j1_mx", "j1_my", "j1_mz"), (2, 3)),
    ("joint2", "joint 2 (crank on rod): force", ("j2_fx", "j2_fy", "j2_fz"), (1, 3)),
    ("joint3", "joint 3 (rod on slider): force", ("j3_fx", "j3_fy", "j3_fz"), (1, 3)),
    ("joint4", "joint 4 (ground on slider): force and moment about P3", ("j4_fx", "j4_fy", "j4_fz", "j4_mx", "j4_my", "j4_mz"), (2, 3)),
    ("loads", "slider load and drive torque", ("slider_load", "drive_torque"), (1, 2)),
)
#: Rows with |transmission| below this set no axis range in torque mode (their reactions
#: are the 1/t spikes beside a dead centre); they are still drawn, at the edge if beyond it.
AXIS_RANGE_TRANSMISSION = 0.1
#: Floor of the log-scale difference plots (exact agreement is drawn here).
LOG_FLOOR = 1e-17
#: A panel is drawn as a line of text when its spread is below this fraction of its size (a constant),
#: or its size below this fraction of the case's largest value of the same dimension (round-off of zero).
FLAT_RELATIVE = 1e-9
JUDGE_MARKERS = ("o", "x", "+", "s", "^", "v", "d")
FINDINGS_FUNCTION = "dualmech.models.findings:thesis_findings"
UNITS = {"length": "in", "force": "lbf", "moment": "lbf·in"}  # label text only; see the case's units


@dataclass(frozen=True)
class Figure:
    """One rendered figure."""

    key: str  # file stem under figures/
    section: str  # "sweep", "difference" or "heatmap"
    group: str  # the sweep's name, or the judge's
    title: str
    caption: str
    png: bytes

    @property
    def data_uri(self) -> str:
        return "data:image/png;base64," + base64.b64encode(self.png).decode("ascii")


@dataclass(frozen=True)
class ReportFiles:
    """Where :func:`write_report` put its output."""

    html: Path
    markdown: Path
    summary: Path
    figures: tuple[Path, ...]
    seconds: float
    verdict: str  # PASS, FAIL or INCOMPLETE (validation/compare.py Verdict)


# ----------------------------------------------------------------------------- sections (data)

def engine_verdict(comparison: Comparison, case: str, engine: str) -> dict:
    """Verdict of one (case, judge): passed, worst ratio to tolerance, worst quantity, failures."""
    checks = comparison.for_engine(case, engine)
    if not checks:
        return {"passed": None, "ratio": float("nan"), "worst": "", "failed": [], "max_rel": float("nan")}
    worst = max(checks, key=lambda c: (c.ratio if np.isfinite(c.ratio) else 1e300))
    numeric = [c for c in checks if c.quantity not in (STATUS, ENGINE) and np.isfinite(c.max_rel)]
    return {
        "passed": all(c.passed for c in checks),
        "ratio": worst.ratio,
        "worst": worst.quantity,
        "failed": [c.quantity for c in checks if not c.passed],
        "max_rel": max((c.max_rel for c in numeric), default=float("nan")),
    }


def summary_rows(matrix: Matrix, comparison: Comparison) -> list[dict]:
    """One row per case: mode, in-house stroke, dead-centre rows, and a verdict per judge."""
    rows = []
    for mc in matrix.cases:
        strokes = comparison.strokes.get(mc.id, {})
        ref_error = comparison.errors.get(mc.id, {}).get(matrix.reference)
        ref_failed = [c.detail for c in comparison.for_engine(mc.id, matrix.reference) if not c.passed]
        rows.append({
            "case": mc.id,
            "mode": mc.mode,
            "run": bool(comparison.strokes.get(mc.id) or comparison.errors.get(mc.id)),
            "reference_error": ref_error or ("; ".join(ref_failed) if ref_failed else None),
            "stroke": strokes.get(matrix.reference, float("nan")),
            "dead_centre": comparison.dead_centres.get(mc.id, {}).get(matrix.reference, 0),
            "judges": {e: engine_verdict(comparison, mc.id, e) for e in matrix.judges},
        })
    return rows


def stroke_rows(matrix: Matrix, comparison: Comparison) -> list[dict]:
    """Per case: the stroke per engine and each judge's difference from the reference."""
    rows = []
    for mc in matrix.cases:
        s = comparison.strokes.get(mc.id, {})
        ref = s.get(matrix.reference, float("nan"))
        rows.append({"case": mc.id, "strokes": {e: s.get(e, float("nan")) for e in matrix.engines},
                     "diffs": {e: s.get(e, float("nan")) - ref for e in matrix.judges}})
    return rows


def findings() -> list[dict]:
    """The thesis's printed findings with verdicts, from the model package (a failure fails the report)."""
    module, func = FINDINGS_FUNCTION.split(":")
    rows = getattr(import_module(module), func)()
    return [{"finding": str(r.get("finding", "")), "verdict": str(r.get("verdict", "")),
             "evidence": str(r.get("evidence", ""))} for r in rows]


def balancing(matrix: Matrix) -> tuple[Figure | None, list[dict]]:
    """Shaking force before and after force balancing (Sinatra–Angeles): a polar figure and a table.

    The figure is for the first of these cases that assembles (``None`` if none does);
    the table gives, for the base case and the last case of each sweep (the spatial
    offsets), the peak shaking force and shaking moment over the cycle for the
    original and the balanced design (NaN for a case that assembles nowhere).
    """
    from dualmech.models.balancing import balanced_case, shaking, shaking_force_polar

    base = next((c for c in matrix.cases if c.is_base), matrix.cases[0])
    picks = [base] + [next(c for c in matrix.cases if c.id == s.case_ids[base.mode][-1])
                      for s in matrix.sweeps if s.case_ids.get(base.mode)]
    picks = list({mc.id: mc for mc in picks}.values())  # the base case may also end a sweep
    rows = []
    for mc in picks:
        case = mc.case()
        before, after = shaking(case), shaking(balanced_case(case))
        peak = {name: _peak_norm(getattr(s, attr))
                for name, s, attr in (("force_before", before, "force"), ("force_after", after, "force"),
                                      ("moment_before", before, "moment"), ("moment_after", after, "moment"))}
        ratio = peak["force_after"] / peak["force_before"] if peak["force_before"] > 0 else None  # at rest: none
        rows.append({"case": mc.id, **peak, "ratio": ratio})
    drawn = next((mc for mc, row in zip(picks, rows) if np.isfinite(row["force_before"])), None)
    if drawn is None:
        return None, rows
    with tempfile.TemporaryDirectory() as tmp:
        case = drawn.case()
        png = Path(shaking_force_polar(case, balanced_case(case), Path(tmp) / "shaking.png")).read_bytes()
    figure = Figure("balancing-shaking-force", "balancing", "balancing",
                    f"shaking force, {drawn.id}: original and force-balanced design",
                    "Tip of the shaking force's component normal to the crank axis over one revolution. "
                    "Balanced: crank and rod mass centres at xi1 = -(1 + mu2)/mu1, xi2 = -1/mu2 "
                    "(docs/conventions.md; errata S7).", png)
    return figure, rows


def _peak_norm(vectors: np.ndarray) -> float:
    """Largest Euclidean norm over the rows of ``vectors`` (shape ``(n, 3)``) that are finite; NaN if none."""
    norms = np.linalg.norm(vectors, axis=1)
    norms = norms[np.isfinite(norms)]
    return float(norms.max()) if norms.size else float("nan")


def tolerance_rows(matrix: Matrix) -> list[dict]:
    """Distinct tolerances of the matrix, with the judges and quantities they apply to."""
    by_name: dict[tuple, dict] = {}
    for e, qs in matrix.tolerances.items():
        for q, t in qs.items():
            row = by_name.setdefault((t.name, t.value, t.reason), {"name": t.name, "value": t.value,
                                                                     "reason": t.reason, "where": {}})
            row["where"].setdefault(e, []).append(q)
    out = []
    for row in by_name.values():
        where = "; ".join(f"{e}: {_compact_quantities(qs)}" for e, qs in row["where"].items())
        out.append({"name": row["name"], "value": row["value"], "reason": row["reason"], "where": where})
    return out


def _compact_quantities(qs: list[str]) -> str:
    kin = [q for q in qs if q not in REACTION_COLUMNS and q != STROKE]
    rea = [q for q in qs if q in REACTION_COLUMNS]
    parts = []
    if rea and len(rea) == len(REACTION_COLUMNS):
        parts.append("all reactions")
    elif rea:
        parts.append(", ".join(rea))
    if kin:
        parts.append(", ".join(kin))
    if STROKE in qs:
        parts.append("stroke")
    return ", ".join(parts)


def engine_versions(results: dict[str, dict[str, ResultTable | str]]) -> dict[str, dict[str, str]]:
    """Per engine, every meta entry whose key mentions a version (as the engines report them)."""
    out: dict[str, dict[str, str]] = {}
    for per in results.values():
        for e, t in per.items():
            if isinstance(t, ResultTable):
                for k, v in t.meta.items():
                    if "version" in k.lower():
                        out.setdefault(e, {})[k] = str(v)
    return out


def copy_errata(outdir: Path) -> str | None:
    """Copy the repository's ``docs/errata.md`` beside the report (so the folder can move); its name, or None."""
    errata = Path(__file__).resolve().parent.parent / "docs" / "errata.md"
    if not errata.is_file():  # an installed package without the repository's docs
        return None
    shutil.copyfile(errata, Path(outdir) / "errata.md")
    record_files(outdir, ["errata.md"])
    return "errata.md"


def design_rows(matrix: Matrix, results: dict[str, dict[str, ResultTable | str]]) -> list[DesignSummary]:
    """The reference engine's :class:`DesignSummary` of every case it solved (every peak, NaN where none)."""
    tables = ((mc, results.get(mc.id, {}).get(matrix.reference)) for mc in matrix.cases)
    return [design_summary(t, mc.raw.get("units", "consistent")) for mc, t in tables if isinstance(t, ResultTable)]


def dead_centre_rows(matrix: Matrix, results: dict[str, dict[str, ResultTable | str]]) -> list[dict]:
    """Per case with any flagged row: the crank angles each engine flags ``dead_centre``."""
    rows = []
    for mc in matrix.cases:
        per = results.get(mc.id, {})
        flagged = {}
        for e in matrix.engines:
            t = per.get(e)
            if isinstance(t, ResultTable):
                st = np.asarray(t.status, dtype=str)
                flagged[e] = [float(x) for x in t["theta1_deg"][st == "dead_centre"]]
        if any(flagged.values()):
            rows.append({"case": mc.id, "angles": {e: ", ".join(f"{a:g}" for a in v) or "none"
                                                   for e, v in flagged.items()}})
    return rows


# ----------------------------------------------------------------------------- figures

def _fig_to_png(fig: Any) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=80, bbox_inches="tight", pad_inches=0.1)  # nothing cut off
    import matplotlib.pyplot as plt

    plt.close(fig)
    return buf.getvalue()


def _axis_range(tables: list[ResultTable], column: str, torque: bool) -> tuple[float, float] | None:
    vals = []
    for t in tables:
        v = t[column]
        rows = np.isfinite(v)
        if torque and column in REACTION_COLUMNS:
            rows &= np.abs(t["transmission"]) >= AXIS_RANGE_TRANSMISSION
        vals.append(v[rows])
    v = np.concatenate(vals) if vals else np.array([])
    if not v.size:
        return None
    lo, hi = float(v.min()), float(v.max())
    pad = 0.08 * (hi - lo) if hi > lo else max(1e-9, 0.05 * abs(hi)) or 1.0
    return lo - pad, hi + pad


def _flat_note(tables: list[ResultTable], column: str, units: str) -> str | None:
    """A line that replaces a panel whose curve would show nothing: a constant, or round-off of zero.

    Constant: the spread of the values is below :data:`FLAT_RELATIVE` of their size.
    Round-off: every value is below :data:`FLAT_RELATIVE` of the largest value of any
    column of the same dimension in these tables (e.g. a planar case's out-of-plane moments).
    """
    dimension = DIMENSIONS[column]
    values = np.concatenate([t[column][np.isfinite(t[column])] for t in tables]) if tables else np.array([])
    if not values.size:
        return None
    peer = [np.abs(t[c][np.isfinite(t[c])]).max(initial=0.0) for t in tables for c in NUMERIC_COLUMNS
            if DIMENSIONS.get(c) == dimension and c != "residual"]
    size, scale = float(np.abs(values).max()), max(peer, default=0.0)
    unit = column_unit(column, units)
    if size <= FLAT_RELATIVE * scale:
        return f"zero to round-off:\n|{column}| <= {size:.1e} {unit}\n(< {FLAT_RELATIVE:g} of the case's largest)"
    if float(values.max() - values.min()) <= FLAT_RELATIVE * size:
        return f"constant:\n{column} = {float(np.median(values)):.9g} {unit}"
    return None


def _draw_clipped(ax: Any, x: np.ndarray, y: np.ndarray, lim: tuple[float, float], color: Any) -> None:
    lo, hi = lim
    above, below = np.isfinite(y) & (y > hi), np.isfinite(y) & (y < lo)
    if above.any():
        ax.plot(x[above], np.full(above.sum(), hi), "^", color=color, ms=5, clip_on=False, zorder=5)
    if below.any():
        ax.plot(x[below], np.full(below.sum(), lo), "v", color=color, ms=5, clip_on=False, zorder=5)


def sweep_figure(
    title: str,
    columns: tuple[str, ...],
    grid: tuple[int, int],
    cases: list[tuple[str, dict[str, ResultTable]]],
    reference: str,
    judges: tuple[str, ...],
    torque: bool,
    units: str = "consistent",
) -> bytes:
    """One figure of a sweep: ``columns`` against the crank angle, the reference as lines, judges as markers.

    Every axis says its quantity and unit (``units``: the cases' unit label,
    :mod:`dualmech.models.units`); tick labels never use an offset; a column that is
    constant or round-off of zero is stated in a line of text instead of drawn.

    Parameters
    ----------
    cases : list of (legend label, {engine: table})
        The sweep's cases, base case first.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    nrows, ncols = grid
    n_labels = len(cases) * (1 + len(judges))
    legend_in = 0.16 * math.ceil(n_labels / 4) + 0.15
    fig, axes = plt.subplots(nrows, ncols, figsize=(4.2 * ncols + 0.8, 2.9 * nrows + 0.9 + legend_in), squeeze=False)
    colors = ["black"] + [plt.get_cmap("tab10")(i) for i in range(10)]
    for ax, col in zip(axes.flat, columns):
        tabs = [t for _, per in cases for t in per.values()]
        _frame(ax, col, units)
        note = _flat_note(tabs, col, units)
        if note is not None:
            ax.text(0.5, 0.5, note, transform=ax.transAxes, ha="center", va="center", fontsize=8, wrap=True)
            ax.set_yticks([])
            continue
        lim = _axis_range(tabs, col, torque)
        for i, (label, per) in enumerate(cases):
            color = colors[i % len(colors)]
            ref = per.get(reference)
            if ref is not None:
                x = ref["theta1_deg"]
                ax.plot(x, ref[col], "-", color=color, lw=1.3, label=f"{label} ({reference})")
                if lim is not None:
                    _draw_clipped(ax, x, ref[col], lim, color)
                for a in x[np.asarray(ref.status, dtype=str) == "dead_centre"]:
                    ax.axvline(a, color=color, ls=":", lw=1.0)
            for j, e in enumerate(judges):
                t = per.get(e)
                if t is None:
                    continue
                x = t["theta1_deg"]
                step = max(1, len(x) // 36)
                sel = slice(j % step, None, step)
                ax.plot(x[sel], t[col][sel], JUDGE_MARKERS[j % len(JUDGE_MARKERS)], color=color, ms=4,
                        mfc="none", label=f"{label} ({e})" if i == 0 else None)
                if lim is not None:
                    _draw_clipped(ax, x[sel], t[col][sel], lim, color)
        if lim is not None:
            ax.set_ylim(*lim)
    for ax in list(axes.flat)[len(columns):]:
        ax.axis("off")
    handles, labels = axes.flat[0].get_legend_handles_labels()
    fig.suptitle(title, fontsize=11)
    height = fig.get_figheight()
    legend_in = 0.16 * math.ceil(len(labels) / 4) + 0.15
    fig.legend(handles, labels, loc="lower center", ncol=min(4, max(1, len(labels))), fontsize=7, frameon=False)
    # fixed margins (inches -> figure fraction): tight_layout would cost a full extra draw
    fig.subplots_adjust(left=0.7 / fig.get_figwidth(), right=0.98, top=1 - 0.55 / height,
                        bottom=(legend_in + 0.45) / height, hspace=0.55, wspace=0.22)
    return _fig_to_png(fig)


def _frame(ax: Any, column: str, units: str) -> None:
    """Title, axis labels with units, plain tick labels (no offset or scientific multiplier) of one panel."""
    ax.set_title(column, fontsize=10)
    ax.set_xlim(0, 360)
    ax.set_xticks(range(0, 361, 90))
    ax.grid(True, alpha=0.3)
    ax.set_xlabel("crank angle theta1 [deg]", fontsize=8)
    ax.set_ylabel(axis_label(column, units), fontsize=8)
    ax.tick_params(labelsize=8)
    ax.ticklabel_format(axis="y", useOffset=False, style="sci", scilimits=(-3, 4))


def difference_figure(
    engine: str,
    rows: dict[str, list[tuple[str, np.ndarray, np.ndarray, np.ndarray]]],
    tolerances: tuple[float, float],
) -> bytes:
    """Log-scale relative difference of one judge against the crank angle.

    Parameters
    ----------
    rows : dict
        Load mode -> list of (case id, theta1_deg, worst kinematic r_i, worst reaction r_i), each (n,).
    tolerances : (float, float)
        Kinematic and reaction tolerance (drawn as dashed lines; the strictest if they vary).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    modes = list(rows)
    fig, axes = plt.subplots(len(modes), 2, figsize=(12, 3.2 * len(modes) + 0.6), squeeze=False, sharey=True)
    cmap = plt.get_cmap("tab20")
    for m, mode in enumerate(modes):
        for k, (what, tol) in enumerate((("kinematics", tolerances[0]), ("reactions", tolerances[1]))):
            ax = axes[m, k]
            for i, (cid, x, kin, rea) in enumerate(rows[mode]):
                y = kin if k == 0 else rea
                y = np.where(np.isfinite(y), np.maximum(y, LOG_FLOOR), np.where(np.isinf(y), 1e3, np.nan))
                ax.plot(x, y, "-", lw=0.9, color=cmap(i % 20), label=cid)
            ax.axhline(tol, color="red", ls="--", lw=1.0, label="tolerance")
            ax.set_yscale("log")
            ax.set_xlim(0, 360)
            ax.set_xticks(range(0, 361, 90))
            ax.set_title(f"{mode} mode: {what} (worst column per row)", fontsize=10)
            ax.set_xlabel("crank angle theta1 [deg]", fontsize=8)
            ax.grid(True, which="major", alpha=0.3)
            ax.tick_params(labelsize=8)
            ax.legend(fontsize=6, ncol=2, loc="upper right")
    axes[0, 0].set_ylabel("relative difference r")
    fig.suptitle(f"{engine} against the reference: relative difference per crank position", fontsize=11)
    fig.subplots_adjust(left=0.07, right=0.98, top=1 - 0.6 / fig.get_figheight(), bottom=0.55 / fig.get_figheight(),
                        hspace=0.45, wspace=0.08)
    return _fig_to_png(fig)


def heatmap_figure(engine: str, cases: list[str], quantities: list[str], values: np.ndarray,
                   failed: np.ndarray) -> bytes:
    """Heat map of log10(worst relative difference), cases x quantities; failures boxed in red.

    ``values`` and ``failed`` have shape ``(len(cases), len(quantities))``; NaN = not compared.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(0.36 * len(quantities) + 4.0, 0.3 * len(cases) + 2.2))
    with np.errstate(divide="ignore", invalid="ignore"):
        logv = np.log10(np.maximum(values, LOG_FLOOR))
    im = ax.imshow(np.ma.masked_invalid(logv), cmap="viridis", aspect="auto", vmin=-17, vmax=0)
    for i, j in zip(*np.nonzero(failed)):
        ax.add_patch(plt.Rectangle((j - 0.5, i - 0.5), 1, 1, fill=False, ec="red", lw=2))
        ax.text(j, i, "✗", ha="center", va="center", color="red", fontsize=8)
    ax.set_xticks(range(len(quantities)), quantities, rotation=70, fontsize=7)
    ax.set_yticks(range(len(cases)), cases, fontsize=7)
    fig.colorbar(im, ax=ax, label="log10 max relative difference")
    ax.set_title(f"{engine}: worst relative difference per case and quantity", fontsize=10)
    w, h = fig.get_figwidth(), fig.get_figheight()
    fig.subplots_adjust(left=1.9 / w, right=1 - 0.2 / w, top=1 - 0.4 / h, bottom=1.1 / h)
    return _fig_to_png(fig)


def _figure_specs(matrix: Matrix, results: dict, comparison: Comparison) -> list[tuple]:
    """(key, section, group, title, caption, (function name, args)) of every figure."""
    specs = []
    units = matrix.cases[0].raw.get("units", "consistent") if matrix.cases else "consistent"
    for sw in matrix.sweeps:
        for mode, ids in sw.case_ids.items():
            cases = []
            for cid in ids:
                per = {e: t for e, t in results.get(cid, {}).items() if isinstance(t, ResultTable)}
                label = matrix.case_by_id(cid).labels.get(sw.name, cid)
                cases.append((label, per))
            if not any(cases_per for _, cases_per in cases):
                continue
            for key, what, cols, grid in SWEEP_FIGURES:
                title = f"{what}: {sw.name} sweep, {mode} mode"
                caption = (f"{sw.label}; {mode} mode. Lines: {matrix.reference}; markers: "
                           f"{', '.join(matrix.judges)}. Dotted verticals: dead centres; triangles: values beyond the axis.")
                specs.append((_file_key(f"{sw.name}-{mode}-{key}"), "sweep", sw.name, title, caption,
                              ("sweep", (title, cols, grid, cases, matrix.reference, matrix.judges, mode == "torque",
                                         units))))
    kin_q = tuple(q for q in matrix.quantities if q not in REACTION_COLUMNS)
    rea_q = tuple(q for q in matrix.quantities if q in REACTION_COLUMNS)
    for e in matrix.judges:
        rows: dict[str, list] = {m: [] for m in matrix.modes}
        for mc in matrix.cases:
            per = results.get(mc.id, {})
            ref, judge = per.get(matrix.reference), per.get(e)
            if not isinstance(ref, ResultTable) or not isinstance(judge, ResultTable) or len(ref) != len(judge):
                continue
            rel = relative_differences(ref, judge, mc.mode, matrix.quantities)
            with np.errstate(all="ignore"), warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN rows: nothing compared there
                kin = np.nanmax(np.stack([rel[q] for q in kin_q]), axis=0) if kin_q else np.full(len(ref), np.nan)
                rea = np.nanmax(np.stack([rel[q] for q in rea_q]), axis=0) if rea_q else np.full(len(ref), np.nan)
            rows[mc.mode].append((mc.id, ref["theta1_deg"], kin, rea))
        rows = {m: r for m, r in rows.items() if r}
        if rows:
            tols = matrix.tolerances[e]
            kt = min((tols[q].value for q in kin_q), default=float("nan"))
            rt = min((tols[q].value for q in rea_q), default=float("nan"))
            specs.append((_file_key(f"difference-{e}"), "difference", e, f"{e}: relative difference against {matrix.reference}",
                          "Worst relative difference r over the compared columns at each crank position (log scale); "
                          "dashed: the tolerance. Gaps: rows not compared (dead centres, unassembled).",
                          ("difference", (e, rows, (kt, rt)))))
    for e in matrix.judges:
        ids = [mc.id for mc in matrix.cases if comparison.for_engine(mc.id, e)]
        if not ids:
            continue
        qs = list(matrix.quantities) + [STROKE]
        vals = np.full((len(ids), len(qs)), np.nan)
        failed = np.zeros((len(ids), len(qs)), dtype=bool)
        for i, cid in enumerate(ids):
            for c in comparison.for_engine(cid, e):
                if c.quantity in qs:
                    j = qs.index(c.quantity)
                    vals[i, j] = c.max_rel
                    failed[i, j] = not c.passed
                elif not c.passed:  # status or engine failure: the whole row
                    failed[i, :] = True
        specs.append((_file_key(f"heatmap-{e}"), "heatmap", e, f"{e}: agreement per case and quantity",
                      "log10 of the worst relative difference; red boxes: out of tolerance (or the engine failed).",
                      ("heatmap", (e, ids, qs, vals, failed))))
    return specs


def _file_key(text: str) -> str:
    """A figure file stem that needs no escaping in URLs or Markdown."""
    return re.sub(r"[^A-Za-z0-9.-]", "-", text)


_FIGURE_FUNCTIONS = {"sweep": sweep_figure, "difference": difference_figure, "heatmap": heatmap_figure}


def _render(job: tuple[str, tuple]) -> bytes:
    name, args = job
    return _FIGURE_FUNCTIONS[name](*args)


def render_figures(matrix: Matrix, results: dict, comparison: Comparison, jobs: int = 1,
                   progress: ProgressCallback | None = None) -> list[Figure]:
    """Every figure of the report, rendered in ``jobs`` processes; ``progress(done, total, key)`` after each."""
    specs = _figure_specs(matrix, results, comparison)
    jobs_list = [spec[5] for spec in specs]
    pngs: list[bytes] = []
    with contextlib.ExitStack() as stack:
        if jobs > 1 and len(specs) > 1:
            pool = stack.enter_context(process_pool(jobs))
            rendered = pool.map(_render, jobs_list, chunksize=max(1, len(specs) // (4 * jobs)))
        else:
            rendered = map(_render, jobs_list)
        for spec, png in zip(specs, rendered):
            pngs.append(png)
            if progress is not None:
                progress(len(pngs), len(specs), spec[0])
    return [Figure(*spec[:5], png) for spec, png in zip(specs, pngs)]


# ----------------------------------------------------------------------------- rendering

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
    if x is None:
        return "–"
    if isinstance(x, float) and math.isnan(x):
        return "–"
    if isinstance(x, float) and math.isinf(x):
        return "∞"
    return format(x, spec)


def _environment(loader_dir: Path, markdown: bool):
    from jinja2 import Environment, FileSystemLoader, StrictUndefined, select_autoescape

    if markdown:
        env = Environment(loader=FileSystemLoader(str(loader_dir)), autoescape=False, undefined=StrictUndefined,
                          finalize=markdown_escape, trim_blocks=True, lstrip_blocks=True, keep_trailing_newline=True)
    else:
        env = Environment(loader=FileSystemLoader(str(loader_dir)), undefined=StrictUndefined,
                          autoescape=select_autoescape(["html", "j2"], default_for_string=True, default=True),
                          trim_blocks=True, lstrip_blocks=True)
    env.filters["fmt"] = _fmt
    return env


def comparison_summary(matrix: Matrix, comparison: Comparison, run: dict) -> dict:
    """The JSON summary of a run (``summary.json``): every check, strokes, verdicts."""
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
        "cases": [{"id": mc.id, "mode": mc.mode, "values": mc.values, "sweeps": list(mc.sweeps)} for mc in matrix.cases],
        "strokes": comparison.strokes,
        "dead_centres": comparison.dead_centres,
        "errors": comparison.errors,
        "checks": [c.to_dict() for c in comparison.checks],
    }


def write_report(
    rundir: str | Path,
    outdir: str | Path | None = None,
    *,
    jobs: int = 1,
    comparison: Comparison | None = None,
    progress: ProgressCallback | None = None,
) -> ReportFiles:
    """Render the report of the run in ``rundir`` into ``outdir`` (default: ``rundir``).

    Writes ``report.html`` (self-contained), ``report.md``, ``summary.json`` and
    ``figures/*.png``, and lists them in the folder's manifest
    (:mod:`~dualmech.validation.rundir`: only a dualmech folder, one writer at a time,
    and only figures it wrote before are removed when they are no longer drawn).
    """
    start = time.perf_counter()
    rundir = Path(rundir)
    matrix, run = runner.load_run(rundir)
    results = runner.load_results(rundir, matrix)
    if comparison is None:
        comparison = compare_run(matrix, results)
    with locked(outdir if outdir is not None else rundir) as outdir:
        figures = _section("figures", render_figures, matrix, results, comparison, jobs=jobs, progress=progress)
        balance_figure, balance_rows = _section("balancing", balancing, matrix)
        figures = [*figures, *([balance_figure] if balance_figure is not None else [])]
        find = _section("findings", findings) if matrix.of_thesis else None  # about the thesis's mechanism only
        paths = _write_figures(outdir, figures)
        context = _context(matrix, run, results, comparison, figures)
        context.update(findings=find, balancing=balance_rows, errata=copy_errata(outdir) if find else None,
                       report_seconds=time.perf_counter() - start)
        templates = Path(__file__).parent / "templates"
        files = ReportFiles(outdir / "report.html", outdir / "report.md", outdir / "summary.json", tuple(paths),
                            0.0, str(comparison.verdict))
        runner_write_text(files.html, _environment(templates, markdown=False).get_template("report.html.j2")
                          .render(**context))
        runner_write_text(files.markdown, _environment(templates, markdown=True).get_template("report.md.j2")
                          .render(**context))
        runner.write_json_atomic(files.summary, comparison_summary(matrix, comparison, run), pretty=True)
        record_files(outdir, [files.html, files.markdown, files.summary])
    return replace(files, seconds=time.perf_counter() - start)


def _write_figures(outdir: Path, figures: list[Figure]) -> list[Path]:
    """Write the figures' PNGs; remove figures this folder's earlier reports wrote that are no longer drawn."""
    figdir = outdir / "figures"
    figdir.mkdir(parents=True, exist_ok=True)
    paths = [figdir / f"{f.key}.png" for f in figures]
    for f, p in zip(figures, paths):
        p.write_bytes(f.png)
    record_files(outdir, paths)
    remove_stale(outdir, paths, "figures")
    return paths


def _context(matrix: Matrix, run: dict, results: dict, comparison: Comparison, figures: list[Figure]) -> dict:
    """The template variables that summarise the run (everything but the model-package sections)."""
    failures: list[Check] = comparison.failures()
    return {
        "matrix": matrix,
        "run": run,
        "passed": comparison.passed,
        "verdict": str(comparison.verdict),
        "n_missing": len(comparison.missing),
        "n_checks": len(comparison.checks),
        "failures": failures[:200],
        "n_failures": len(failures),
        "summary": summary_rows(matrix, comparison),
        "strokes": stroke_rows(matrix, comparison),
        "tolerances": tolerance_rows(matrix),
        "dead_centres": dead_centre_rows(matrix, results),
        "engine_versions": engine_versions(results),
        "design": design_rows(matrix, results),
        "design_columns": [name for _, forces, moments in JOINTS for name in
                           (f"{forces[0][:2]} |f|", *([f"{moments[0][:2]} |m|"] if moments else []))]
                          + ["|drive_torque|", "|slider_load|"],
        "near_dead_centre": NEAR_DEAD_CENTRE_TRANSMISSION,
        "figures": figures,
        "sections": [(s.name, s.label) for s in matrix.sweeps],
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
        raise ReportError(f"report section {name!r} failed: {type(err).__name__}: "
                          f"{lines[0][:200] if lines else ''}") from err


def runner_write_text(path: Path, text: str) -> None:
    """Write text atomically."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, path)
