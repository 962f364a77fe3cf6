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

from dualmech.core.table import ColumnTable, ResultTable
from dualmech.validation import tolerances as tol
from dualmech.validation.compare import UNIT_GROUP, Comparison, condition_factor, stroke, tables, unit_scales
from dualmech.validation.durable import NotAFileError, read_regular, write_json_atomic
from dualmech.validation.matrix import Matrix
from dualmech.validation.rundir import NUMBER, MapOf, Nullable, RunDirError, conform

BASELINE_FORMAT = "dualmech-baseline/1"

_NUMBER_OR_NULL = Nullable(NUMBER)
#: A baseline file (:func:`baseline_summary`); its checks are what :func:`compare_baseline` reads.
BASELINE_SCHEMA = {
    "format": str, "matrix": str, "reference": str, "engines": [str],
    "cases": MapOf({
        "reference": Nullable({"stroke": _NUMBER_OR_NULL, "peaks": MapOf(NUMBER),
                               "scales": MapOf(NUMBER), "length": NUMBER}),
        "checks": MapOf(MapOf({"max_rel": _NUMBER_OR_NULL, "passed": bool})),
    }),
}


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
    matrix: Matrix, comparison: Comparison, results: dict[str, dict[str, ColumnTable | str]]
) -> dict:
    """The baseline of a run of any kinds (JSON-ready): :func:`run_summary` with the reference's values of
    each case: a slider crank's stroke and scales (:func:`reference_values`), another kind's peaks and scales
    by its table spec (:func:`~dualmech.validation.compare.tables.reference_values`)."""
    references: dict[str, dict | None] = {}
    for mc in matrix.cases:
        ref = results.get(mc.id, {}).get(matrix.reference)
        if not isinstance(ref, ColumnTable):
            references[mc.id] = None
        elif mc.is_slider_crank:
            references[mc.id] = reference_values(ref, mc.mode, matrix.quantities)
        else:
            references[mc.id] = tables.reference_values(ref, tables.case_spec(mc))
    return run_summary(matrix.name, matrix.reference, matrix.engines, references, comparison)


def run_summary(name: str, reference: str, engines: tuple[str, ...], references: dict[str, dict | None],
                comparison: Comparison) -> dict:
    """The baseline of a run of any kind (JSON-ready): per case its reference values (``references``: case
    id -> ``stroke``, ``peaks``, ``scales``, ``length``, or ``None`` where the reference gave no table) and,
    per engine and quantity, the worst relative difference and whether it passed."""
    checks: dict[str, dict] = {cid: {} for cid in references}
    for c in comparison.checks:
        if c.case in checks:
            checks[c.case].setdefault(c.engine, {})[c.quantity] = {"max_rel": _num(c.max_rel),
                                                                   "passed": bool(c.passed)}
    return {
        "format": BASELINE_FORMAT,
        "matrix": name,
        "reference": reference,
        "engines": list(engines),
        "tolerances": {
            t: {"value": getattr(tol, t).value, "reason": getattr(tol, t).reason}
            for t in ("BASELINE_AGREEMENT_FACTOR", "BASELINE_AGREEMENT_FLOOR", "BASELINE_VALUE_RTOL")
        },
        "cases": {cid: {"reference": ref, "checks": checks[cid]} for cid, ref in references.items()},
    }


def write_baseline(path: str | Path, summary: dict) -> None:
    """Write a baseline file (atomically)."""
    write_json_atomic(Path(path), summary, pretty=True)


def read_baseline(path: str | Path, matrix: str | None = None) -> dict:
    """Read a baseline file, checked against :data:`BASELINE_SCHEMA` (and, given ``matrix``, made for the
    matrix of that name); a one-line ValueError naming the file and the field if it is not one.

    Called before a run starts, so that a broken baseline costs no run.
    """
    try:
        data = json.loads(read_regular(path))
    except FileNotFoundError:
        raise ValueError(f"baseline: cannot read {path} (no such file)") from None
    except NotAFileError as err:
        raise ValueError(f"baseline: {err}") from None
    except OSError as err:
        raise ValueError(f"baseline: cannot read {path} ({err.strerror})") from None
    except ValueError as err:
        raise ValueError(f"baseline: {path} is not valid JSON ({str(err).splitlines()[0][:120]})") from None
    if not isinstance(data, dict) or data.get("format") != BASELINE_FORMAT:
        raise ValueError(f"baseline: {path} is not a {BASELINE_FORMAT} file (write one with "
                         "--write-baseline)")
    try:
        conform(data, BASELINE_SCHEMA, path)
    except RunDirError as err:
        raise ValueError(f"baseline: {err}") from None
    if matrix is not None and data["matrix"] != matrix:
        raise ValueError(f"baseline: {path} is for matrix {data['matrix']!r}, not {matrix!r} (this run's); "
                         "give that matrix's baseline, or write one with --write-baseline")
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
    if baseline["matrix"] != current["matrix"]:
        return [Regression("*", "*", "matrix", f"the baseline is for another matrix ({baseline['matrix']!r}, "
                                              f"this run {current['matrix']!r}); nothing compared")]
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
