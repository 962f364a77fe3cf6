"""The report's sections as data: rows for the templates' tables, from a finished run and its comparison.

Every function here returns plain rows (dicts), a figure's plan or
:class:`~dualmech.models.design_summary.DesignSummary` objects; :mod:`~dualmech.validation.report.render`
puts them into the templates.  The numbers no stored table holds (balancing, the thesis's findings)
come from :mod:`dualmech.validation.report.derived`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from dualmech.core.status import Status, is_status
from dualmech.core.table import REACTION_COLUMNS, ColumnTable, ResultTable
from dualmech.models.design_summary import DesignSummary, design_summary
from dualmech.validation.compare import ENGINE, STATUS, STROKE, Comparison, Pair
from dualmech.validation.compare.pairs import GROUPS
from dualmech.validation.matrix import Matrix, ResolvedTolerance
from dualmech.validation.report.derived import Balancing
from dualmech.validation.report.figures import FigureSpec
from dualmech.validation.rundir import write_file


def engine_verdict(comparison: Comparison, case: str, engine: str) -> dict:
    """Verdict of one (case, judge): passed, worst ratio to tolerance, worst quantity, failures."""
    checks = comparison.for_engine(case, engine)
    if not checks:
        return {"passed": None, "ratio": float("nan"), "worst": "", "failed": [], "max_rel": float("nan")}
    worst = max(checks, key=lambda c: c.ratio if np.isfinite(c.ratio) else 1e300)
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
        rows.append(
            {
                "case": mc.id,
                "mode": mc.mode,
                "run": bool(comparison.dead_centres.get(mc.id) or comparison.errors.get(mc.id)),
                "reference_error": ref_error or ("; ".join(ref_failed) if ref_failed else None),
                "stroke": strokes.get(matrix.reference, float("nan")),
                "dead_centre": comparison.dead_centres.get(mc.id, {}).get(matrix.reference, 0),
                "judges": {e: engine_verdict(comparison, mc.id, e) for e in matrix.judges},
            }
        )
    return rows


def stroke_rows(matrix: Matrix, comparison: Comparison) -> list[dict]:
    """Per slider-crank case: the stroke per engine and each judge's difference from the reference."""
    rows = []
    for mc in (c for c in matrix.cases if c.is_slider_crank):  # another kind has no slider
        s = comparison.strokes.get(mc.id, {})
        ref = s.get(matrix.reference, float("nan"))
        rows.append(
            {
                "case": mc.id,
                "strokes": {e: s.get(e, float("nan")) for e in matrix.engines},
                "diffs": {e: s.get(e, float("nan")) - ref for e in matrix.judges},
            }
        )
    return rows


def pair_groups(pairs: tuple[Pair, ...]) -> list[str]:
    """The columns of the pair table: the column groups some pair was compared on, in
    :data:`~dualmech.validation.compare.pairs.GROUPS`'s order."""
    return [g for g in GROUPS if any(g in p.cells for p in pairs)]


def balancing_spec(balance: Balancing) -> FigureSpec | None:
    """The plan of the balancing section's polar figure (a
    :data:`~dualmech.validation.report.figures.FigureSpec`, drawn with the others): the drawn case's shaking
    force, original and balanced."""
    if balance.forces is None:
        return None
    return FigureSpec(
        "balancing-shaking-force",
        "balancing",
        "balancing",
        f"shaking force, {balance.drawn}: original and force-balanced design",
        "Tip of the shaking force's component normal to the crank axis over one revolution. "
        "Balanced: crank and rod mass centres at xi1 = -(1 + mu2)/mu1, xi2 = -1/mu2 "
        "(docs/conventions.md; errata S7).",
        ("balancing", (balance.forces, balance.name, balance.units)),
        static=True,
    )


def tolerance_rows(tolerances: dict[str, dict[str, ResolvedTolerance]]) -> list[dict]:
    """Distinct tolerances of a run (judge -> quantity or group -> tolerance: a matrix's
    :attr:`~dualmech.validation.matrix.Matrix.tolerances`), with the judges and quantities they apply to."""
    by_name: dict[tuple, dict] = {}
    for e, qs in tolerances.items():
        for q, t in qs.items():
            row = by_name.setdefault(
                (t.name, t.value, t.reason),
                {"name": t.name, "value": t.value, "reason": t.reason, "where": {}},
            )
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


def engine_versions(results: dict[str, dict[str, ColumnTable | str]]) -> dict[str, dict[str, str]]:
    """Per engine, every meta entry whose key mentions a version (as the engines report them)."""
    out: dict[str, dict[str, str]] = {}
    for per in results.values():
        for e, t in per.items():
            if isinstance(t, ColumnTable):
                for k, v in t.meta.items():
                    if "version" in k.lower():
                        out.setdefault(e, {})[k] = str(v)
    return out


def copy_errata(outdir: Path) -> str | None:
    """Copy the repository's ``docs/errata.md`` beside the report (so the folder can move).

    Returns its file name, or None for an installed package without the repository's docs.
    """
    errata = Path(__file__).resolve().parents[2] / "docs" / "errata.md"
    if not errata.is_file():  # an installed package without the repository's docs
        return None
    write_file(outdir, "errata.md", errata.read_bytes())
    return "errata.md"


def design_rows(matrix: Matrix, results: dict[str, dict[str, ResultTable | str]]) -> list[DesignSummary]:
    """The reference engine's :class:`DesignSummary` of every case it solved (every peak, NaN where none)."""
    tables = ((mc, results.get(mc.id, {}).get(matrix.reference)) for mc in matrix.cases)
    return [
        design_summary(t, mc.raw.get("units", "consistent")) for mc, t in tables if isinstance(t, ResultTable)
    ]


def dead_centre_rows(matrix: Matrix, results: dict[str, dict[str, ColumnTable | str]],
                     keys: dict[str, str] | None = None) -> list[dict]:
    """Per case with any flagged row: the input values (the crank angles, or the column ``keys[case id]``
    names) each engine flags ``dead_centre``."""
    rows = []
    for mc in matrix.cases:
        per = results.get(mc.id, {})
        key = (keys or {}).get(mc.id, "theta1_deg")
        flagged = {}
        for e in matrix.engines:
            t = per.get(e)
            if isinstance(t, ColumnTable):
                flagged[e] = [float(x) for x in t[key][is_status(t.status, Status.DEAD_CENTRE)]]
        if any(flagged.values()):
            rows.append(
                {
                    "case": mc.id,
                    "angles": {e: ", ".join(f"{a:g}" for a in v) or "none" for e, v in flagged.items()},
                }
            )
    return rows
