"""Which engine disagrees with the others, where three or more engines compare a quantity.

A judge's failing check says only that the judge and the reference disagree.  With another judge
(a *witness*) on the same case and quantity, the judges are compared with each other as each is with the
reference (the reference's scale ``s_g`` and condition factor, the looser of the two tolerances, the
same per-row laws), and the failing check names the odd one out:

* the **reference**, when a witness also fails and agrees with the judge (two engines agree with each
  other and both disagree with the reference);
* the **judge**, when a witness at least as precise (its tolerance no looser) passes, so agrees with the
  reference, and disagrees with the judge.

Otherwise (every pair disagrees, or no witness) nobody is named.  The name is the check's
``odd_one_out`` and leads its detail (``summary.json``, the report's failure table, the console).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from dualmech.core.table import ResultTable
from dualmech.validation.compare.conditioning import Conditioning, allowances, stroke_allowance
from dualmech.validation.compare.differences import compared_rows, condition_factor, stroke, unit_scales
from dualmech.validation.compare.results import STROKE, STROKE_PROXY, Check
from dualmech.validation.matrix import ResolvedTolerance


def judges_agree(one: ResultTable, other: ResultTable, reference: ResultTable, mode: str, check: Check,
                 tol: float, conditioning: Conditioning | None) -> bool:
    """Whether judges ``one`` and ``other`` agree on ``check.quantity`` within ``tol`` (plus the per-row
    laws), relative to the reference's scale ``check.scale`` and condition factor (module docstring)."""
    q = check.quantity
    if q == STROKE:
        d = abs(stroke(one) - stroke(other))
        length = unit_scales(reference, one, mode, (STROKE_PROXY,))["length"]
        extra = sum(stroke_allowance(one, other, length, conditioning).values()) if conditioning else 0.0
        return bool(np.isfinite(d) and d <= (tol + extra) * length)
    rows = compared_rows(one, other, q)
    if not rows.any():
        return False
    extra = sum(allowances(q, mode, one, other, check.scale, conditioning).values()) if conditioning else 0.0
    with np.errstate(invalid="ignore", divide="ignore"):
        rel = np.abs(one[q] - other[q]) / (check.scale * condition_factor(reference, mode, q))
        allowed = tol + extra
    return bool(np.all((rel <= allowed)[rows]))


def name_odd_one_out(checks: list[Check], reference: ResultTable, judges: dict[str, ResultTable], mode: str,
                     tolerances: dict[str, dict[str, ResolvedTolerance]],
                     conditioning: Conditioning | None = None) -> list[Check]:
    """``checks`` of one case, each failing quantity check annotated with the odd one out (module
    docstring); the others unchanged."""
    by_key = {(c.engine, c.quantity): c for c in checks}
    out = []
    for c in checks:
        if c.passed or c.engine not in judges or not np.isfinite(c.scale) or c.quantity not in \
                tolerances[c.engine] or (c.quantity != STROKE and c.quantity not in reference.columns):
            out.append(c)
            continue
        odd, why = _odd(c, by_key, reference, judges, mode, tolerances, conditioning)
        detail = f"{why}; {c.detail}" if c.detail else why
        out.append(replace(c, odd_one_out=odd, detail=detail) if odd else c)
    return out


def _odd(check: Check, by_key: dict[tuple[str, str], Check], reference: ResultTable,
         judges: dict[str, ResultTable], mode: str, tolerances: dict[str, dict[str, ResolvedTolerance]],
         conditioning: Conditioning | None) -> tuple[str, str]:
    """``(engine, phrase)`` naming the odd one out for a failing ``check``; ``("", "")`` if none."""
    engine, q = check.engine, check.quantity
    own = tolerances[engine][q].value
    alone = []
    for witness, table in judges.items():
        other = by_key.get((witness, q))
        if witness == engine or other is None or not np.isfinite(other.scale):
            continue
        tol = max(own, tolerances[witness][q].value)
        agree = judges_agree(judges[engine], table, reference, mode, check, tol, conditioning)
        if not other.passed and agree:
            return reference.engine, (f"odd one out: {reference.engine} ({engine} and {witness} agree with "
                                      f"each other, both disagree with {reference.engine})")
        if other.passed and not agree and tolerances[witness][q].value <= own:
            alone.append(witness)
    if alone:
        return engine, (f"odd one out: {engine} ({' and '.join(alone)} "
                        f"{'agrees' if len(alone) == 1 else 'agree'} with {reference.engine})")
    return "", ""
