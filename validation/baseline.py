"""The regression gate: a run's summary against a committed baseline.

A baseline (JSON) holds, per case: the in-house stroke and, per compared quantity,
the in-house scale ``max |R| / c`` (see :mod:`dualmech.validation.compare`); per
judge and quantity, the worst relative difference and whether it passed.  A new
run regresses when, beyond the tolerances of ``validation/tolerances.py``
(``BASELINE_*``, also written into the file so that it states them):

* a case, engine or quantity of the baseline is missing from the run;
* a check that passed now fails;
* a judge's worst relative difference grew by more than
  ``BASELINE_AGREEMENT_FACTOR`` and is above ``BASELINE_AGREEMENT_FLOOR``;
* an in-house stroke or scale moved by more than ``BASELINE_VALUE_RTOL``
  (relative to the case's length or unit-group scale).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dualmech.core.table import ResultTable
from dualmech.validation import tolerances as tol
from dualmech.validation.compare import UNIT_GROUP, Comparison, condition_factor, stroke, unit_scales
from dualmech.validation.durable import write_json_atomic
from dualmech.validation.matrix import Matrix

BASELINE_FORMAT = "dualmech-baseline/1"


@dataclass(frozen=True)
class Regression:
    """One way the run is worse than the baseline."""

    case: str
    engine: str
    quantity: str
    message: str

    def __str__(self) -> str:
        return f"{self.case} / {self.engine}: {self.quantity}: {self.message}"


def _num(x: float) -> float | None:
    return None if x is None or not math.isfinite(x) else float(x)


def reference_values(table: ResultTable, mode: str, quantities: tuple[str, ...]) -> dict:
    """The in-house stroke, and per quantity its scale ``max |R|/c`` and its group's scale."""
    group_scales = unit_scales(table, table, mode, quantities)
    ok = np.asarray(table.status, dtype=str) == "ok"
    peaks = {}
    for q in quantities:
        v = np.abs(table[q][ok]) / condition_factor(table, mode, q)[ok]
        v = v[np.isfinite(v)]
        peaks[q] = float(v.max()) if v.size else 0.0
    return {
        "stroke": _num(stroke(table)),
        "peaks": peaks,
        "scales": {q: group_scales[UNIT_GROUP[q]] for q in quantities},
        "length": group_scales.get("length", unit_scales(table, table, mode, ("S4",))["length"]),
    }


def baseline_summary(
    matrix: Matrix, comparison: Comparison, results: dict[str, dict[str, ResultTable | str]]
) -> dict:
    """The baseline of a run (JSON-ready)."""
    cases = {}
    for mc in matrix.cases:
        per = results.get(mc.id, {})
        ref = per.get(matrix.reference)
        entry: dict = {"reference": None, "checks": {}}
        if isinstance(ref, ResultTable):
            entry["reference"] = reference_values(ref, mc.mode, matrix.quantities)
        for c in comparison.checks:
            if c.case == mc.id:
                entry["checks"].setdefault(c.engine, {})[c.quantity] = {
                    "max_rel": _num(c.max_rel), "passed": bool(c.passed)}
        cases[mc.id] = entry
    return {
        "format": BASELINE_FORMAT,
        "matrix": matrix.name,
        "reference": matrix.reference,
        "engines": list(matrix.engines),
        "tolerances": {
            name: {"value": getattr(tol, name).value, "reason": getattr(tol, name).reason}
            for name in ("BASELINE_AGREEMENT_FACTOR", "BASELINE_AGREEMENT_FLOOR", "BASELINE_VALUE_RTOL")
        },
        "cases": cases,
    }


def write_baseline(path: str | Path, summary: dict) -> None:
    """Write a baseline file (atomically)."""
    write_json_atomic(Path(path), summary, pretty=True)


def read_baseline(path: str | Path) -> dict:
    """Read a baseline file; ValueError if it is not one."""
    try:
        with Path(path).open() as fh:
            data = json.load(fh)
    except OSError as err:
        raise ValueError(f"baseline: cannot read {path} ({err.strerror})") from None
    except ValueError as err:
        raise ValueError(f"baseline: {path} is not valid JSON ({err})") from None
    if not isinstance(data, dict) or data.get("format") != BASELINE_FORMAT:
        raise ValueError(f"baseline: {path} is not a {BASELINE_FORMAT} file (write one with "
                         "--write-baseline)")
    return data


def _moved(now: float | None, then: float | None, scale: float, rtol: float) -> bool:
    if then is None or now is None:
        return (then is None) != (now is None)
    return abs(now - then) > rtol * max(scale, abs(then))


def compare_baseline(current: dict, baseline: dict) -> list[Regression]:
    """Every regression of ``current`` (a :func:`baseline_summary`) against ``baseline``."""
    factor = tol.BASELINE_AGREEMENT_FACTOR.value
    floor = tol.BASELINE_AGREEMENT_FLOOR.value
    rtol = tol.BASELINE_VALUE_RTOL.value
    ref_name = baseline.get("reference", "dualmech")
    out: list[Regression] = []
    for cid, base in baseline["cases"].items():
        now = current["cases"].get(cid)
        if now is None:
            out.append(Regression(cid, "*", "case", "in the baseline but not in this run"))
            continue
        bref, nref = base.get("reference"), now.get("reference")
        if bref is not None:
            if nref is None:
                out.append(Regression(cid, ref_name, "engine", "the reference engine produced no table"))
            else:
                if _moved(nref["stroke"], bref["stroke"], bref.get("length", 0.0), rtol):
                    out.append(Regression(cid, ref_name, "stroke",
                                          f"in-house stroke {nref['stroke']!r} against baseline "
                                          f"{bref['stroke']!r}"))
                for q, then in bref["peaks"].items():
                    if q not in nref["peaks"]:
                        out.append(Regression(cid, ref_name, q, "quantity no longer compared"))
                    elif _moved(nref["peaks"][q], then, bref["scales"].get(q, 0.0), rtol):
                        out.append(Regression(cid, ref_name, q,
                                              f"in-house scale {nref['peaks'][q]:.12g} against baseline "
                                              f"{then:.12g}"))
        for engine, checks in base["checks"].items():
            now_checks = now["checks"].get(engine, {})
            for q, b in checks.items():
                n = now_checks.get(q)
                if n is None:
                    out.append(Regression(cid, engine, q, "checked in the baseline but not in this run"))
                    continue
                if b["passed"] and not n["passed"]:
                    out.append(Regression(cid, engine, q, "passed in the baseline, fails now"))
                elif n["max_rel"] is not None and n["max_rel"] > floor and (
                        b["max_rel"] is None or n["max_rel"] > factor * b["max_rel"]):
                    then = "none" if b["max_rel"] is None else f"{b['max_rel']:.3g}"
                    out.append(Regression(cid, engine, q,
                                          f"max rel {n['max_rel']:.3g} against baseline {then} (> "
                                          f"x{factor:g})"))
    return out
