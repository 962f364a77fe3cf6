"""Judge against reference: per case, engine and quantity, how far apart and whether that is fine.

For one case, the reference engine's table ``R`` (the in-house solver) and a
judge's table ``J`` are compared row by row (one row per crank position):

.. math::

    d_i = |J_i - R_i|, \\qquad
    r_i = \\frac{d_i}{s_g\\, c_i}, \\qquad
    \\text{pass} \\iff \\max_i r_i \\le \\text{tol}

* ``c_i`` is the condition factor of the row (``docs/conventions.md``, "Dead
  centres"): ``1/|t_i|`` for reactions in drive-torque mode, with ``t`` the
  reference's ``transmission`` column, else 1.  Near a dead centre the slider
  load grows like ``1/t`` and so does every honest difference; the tolerance
  grows with it instead of the row being dropped.
* ``s_g`` is the scale of the quantity's unit group (:data:`UNIT_GROUP`):
  the largest ``|R_i| / c_i`` over the case's comparable rows of every compared
  quantity of that group (a normwise relative difference: a zero component, such
  as a planar case's out-of-plane moments, is judged against the case's forces).
* Rows that either engine flags ``dead_centre`` carry no reactions (NaN): they are
  **excluded from the reaction comparisons but counted** (``n_excluded``) and
  reported; their kinematics are compared.  Rows where one engine assembles and
  the other does not (``branch_jump``, ``not_converged``, ``no_assembly``), or
  where exactly one value is NaN, are mismatches and fail the check.

The stroke (max S4 - min S4 over the sampled crank angles) is compared per
judge, relative to the length scale; a ``status`` check per (case, judge) fails
on any assembly mismatch, an ``engine`` check when an engine raised.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from dualmech.core.table import FORCE_COLUMNS, MOMENT_COLUMNS, REACTION_COLUMNS, ResultTable
from dualmech.validation.matrix import Matrix, ResolvedTolerance

#: Unit group of each comparable column: relative differences share one scale per group.
UNIT_GROUP: dict[str, str] = {
    "S1": "length", "S4": "length", "S4_dot": "velocity", "S4_ddot": "acceleration",
    "transmission": "ratio",
    **{c: "force" for c in FORCE_COLUMNS},
    **{c: "moment" for c in MOMENT_COLUMNS},
}
#: Status words under which the kinematics columns are given.
ASSEMBLED: frozenset[str] = frozenset({"ok", "dead_centre"})
#: Pseudo-quantities of :class:`Check` besides the table columns.
STROKE, STATUS, ENGINE = "stroke", "status", "engine"


@dataclass(frozen=True)
class Check:
    """One verdict: a judge's ``quantity`` on one case against the reference.

    Attributes
    ----------
    case, engine, quantity : str
        Matrix case id, judge engine, and a column name, ``"stroke"``, ``"status"``
        (assembly agreement) or ``"engine"`` (the engine ran).
    max_abs : float
        Largest ``|judge - reference|`` over the compared rows, in the column's unit.
    max_rel : float
        Largest ``r_i`` (module docstring); ``nan`` when nothing was compared.
    worst_theta_deg : float
        Crank angle of ``max_rel`` (``nan`` if none).
    tolerance : ResolvedTolerance
        The tolerance ``max_rel`` is held to.
    scale : float
        ``s_g`` used for ``max_rel``.
    n_compared, n_excluded, n_mismatch : int
        Rows compared; rows excluded but counted (dead centres, rows neither engine
        assembles); rows that disagree on assembly or on NaN.
    passed : bool
    detail : str
        One line for reports (why it failed, what was excluded).
    """

    case: str
    engine: str
    quantity: str
    max_abs: float
    max_rel: float
    worst_theta_deg: float
    tolerance: ResolvedTolerance
    scale: float
    n_compared: int
    n_excluded: int
    n_mismatch: int
    passed: bool
    detail: str = ""

    @property
    def ratio(self) -> float:
        """``max_rel / tolerance`` (``inf`` for a failure without a number, 0 if nothing compared)."""
        if not self.passed and not np.isfinite(self.max_rel):
            return float("inf")
        if not np.isfinite(self.max_rel):
            return 0.0
        return self.max_rel / self.tolerance.value if self.tolerance.value > 0 else (
            0.0 if self.max_rel == 0 else float("inf"))

    def to_dict(self) -> dict:
        """JSON-ready form."""
        d = asdict(self)
        d["tolerance"] = asdict(self.tolerance)
        return d


@dataclass(frozen=True)
class Comparison:
    """Every check of a run, and the strokes and dead-centre counts per case and engine."""

    checks: tuple[Check, ...]
    strokes: dict[str, dict[str, float]] = field(default_factory=dict)  # case -> engine -> stroke
    dead_centres: dict[str, dict[str, int]] = field(default_factory=dict)  # case -> engine -> rows
    errors: dict[str, dict[str, str]] = field(default_factory=dict)  # case -> engine -> message

    @property
    def passed(self) -> bool:
        return all(c.passed for c in self.checks) and not any(self.errors.values())

    def failures(self) -> list[Check]:
        """Failing checks, worst first within each case."""
        return [c for c in self.checks if not c.passed]

    def for_engine(self, case: str, engine: str) -> list[Check]:
        """The checks of one (case, judge)."""
        return [c for c in self.checks if c.case == case and c.engine == engine]


# ----------------------------------------------------------------------------- per row

def condition_factor(reference: ResultTable, mode: str, quantity: str) -> np.ndarray:
    """``c_i`` of the module docstring, shape ``(n,)``: ``1/|t|`` for reactions in torque mode, else 1."""
    n = len(reference)
    if mode != "torque" or quantity not in REACTION_COLUMNS:
        return np.ones(n)
    t = np.abs(reference["transmission"])
    with np.errstate(divide="ignore"):
        return np.where(t > 0, 1.0 / np.where(t > 0, t, 1.0), np.inf)


def _row_masks(reference: ResultTable, judge: ResultTable) -> dict[str, np.ndarray]:
    rs = np.asarray(reference.status, dtype=str)
    js = np.asarray(judge.status, dtype=str)
    r_asm = np.isin(rs, list(ASSEMBLED))
    j_asm = np.isin(js, list(ASSEMBLED))
    return {
        "kinematic": r_asm & j_asm,
        "reaction": (rs == "ok") & (js == "ok"),
        "dead_centre": r_asm & j_asm & ((rs == "dead_centre") | (js == "dead_centre")),
        "mismatch": r_asm != j_asm,
        "neither": ~r_asm & ~j_asm,
    }


def _rows_for(quantity: str, masks: dict[str, np.ndarray]) -> np.ndarray:
    return masks["reaction"] if quantity in REACTION_COLUMNS else masks["kinematic"]


def unit_scales(reference: ResultTable, judge: ResultTable, mode: str, quantities: tuple[str, ...]) -> dict[str, float]:
    """``s_g`` per unit group: the largest ``|R|/c`` over the comparable rows of the group's quantities.

    A group whose reference values are all zero (or absent) gets scale 1, i.e. the
    comparison becomes absolute in the column's unit.
    """
    masks = _row_masks(reference, judge)
    scales: dict[str, float] = {}
    for q in quantities:
        rows = _rows_for(q, masks)
        vals = np.abs(reference[q][rows]) / condition_factor(reference, mode, q)[rows]
        vals = vals[np.isfinite(vals)]
        g = UNIT_GROUP[q]
        scales[g] = max(scales.get(g, 0.0), float(vals.max()) if vals.size else 0.0)
    return {g: (s if s > 0 else 1.0) for g, s in scales.items()}


def relative_differences(
    reference: ResultTable, judge: ResultTable, mode: str, quantities: tuple[str, ...]
) -> dict[str, np.ndarray]:
    """``r_i`` per quantity, each shape ``(n,)``; NaN on rows not compared, ``inf`` on NaN mismatches."""
    masks = _row_masks(reference, judge)
    scales = unit_scales(reference, judge, mode, quantities)
    out = {}
    for q in quantities:
        rows = _rows_for(q, masks)
        r, j = reference[q], judge[q]
        with np.errstate(invalid="ignore"):
            rel = np.abs(j - r) / (scales[UNIT_GROUP[q]] * condition_factor(reference, mode, q))
        one_nan = np.isnan(r) != np.isnan(j)
        rel = np.where(one_nan, np.inf, rel)
        out[q] = np.where(rows, rel, np.nan)
    return out


def stroke(table: ResultTable) -> float:
    """``max S4 - min S4`` over the assembled rows (the case's sampled angles); NaN if none."""
    s4 = table["S4"][np.isin(np.asarray(table.status, dtype=str), list(ASSEMBLED))]
    s4 = s4[np.isfinite(s4)]
    return float(s4.max() - s4.min()) if s4.size else float("nan")


# ----------------------------------------------------------------------------- per case

def _fail(case: str, engine: str, quantity: str, tol: ResolvedTolerance, detail: str) -> Check:
    nan = float("nan")
    return Check(case, engine, quantity, nan, nan, nan, tol, nan, 0, 0, 0, False, detail)


def _angles(rows: np.ndarray, theta: np.ndarray, limit: int = 4) -> str:
    idx = np.flatnonzero(rows)
    shown = ", ".join(f"{theta[i]:g}" for i in idx[:limit])
    return shown + (f", ... ({idx.size} rows)" if idx.size > limit else "")


def compare_case(
    case_id: str,
    mode: str,
    reference: ResultTable,
    judge: ResultTable,
    quantities: tuple[str, ...],
    tolerances: dict[str, ResolvedTolerance],
) -> list[Check]:
    """Every check of one judge on one case (module docstring).

    Parameters
    ----------
    case_id, mode : str
        Matrix case id and load mode (``"torque"`` enables the ``1/|t|`` condition factor).
    reference, judge : ResultTable
        Same crank angles, one row per position.
    quantities : tuple of str
        Columns to compare.
    tolerances : dict
        Quantity (and ``"stroke"``) -> tolerance.
    """
    engine = judge.engine
    status_tol = ResolvedTolerance("exact", 0.0, "assembly must agree row by row")
    theta = reference["theta1_deg"]
    if len(judge) != len(reference) or not np.allclose(judge["theta1_deg"], theta, rtol=0, atol=1e-9):
        detail = f"rows differ: {len(judge)} crank angles against the reference's {len(reference)}"
        return [_fail(case_id, engine, STATUS, status_tol, detail)] + [
            _fail(case_id, engine, q, tolerances[q], detail) for q in (*quantities, STROKE)]
    masks = _row_masks(reference, judge)
    n_mis = int(masks["mismatch"].sum())
    checks = [Check(
        case_id, engine, STATUS, float(n_mis), float(n_mis), float("nan"), status_tol, 1.0,
        len(reference), int(masks["neither"].sum()), n_mis, n_mis == 0,
        f"assembly differs at theta1 = {_angles(masks['mismatch'], theta)} deg" if n_mis else "",
    )]
    rel = relative_differences(reference, judge, mode, quantities)
    scales = unit_scales(reference, judge, mode, quantities)
    n_dead = int(masks["dead_centre"].sum())
    for q in quantities:
        rows = _rows_for(q, masks)
        r = rel[q]
        nan_mis = rows & np.isinf(r) & (np.isnan(reference[q]) != np.isnan(judge[q]))
        good = rows & np.isfinite(r)
        diff = np.abs(judge[q] - reference[q])[good]
        max_rel = float(np.nanmax(r[rows & ~nan_mis])) if (rows & ~nan_mis & ~np.isnan(r)).any() else float("nan")
        worst = float(theta[np.nanargmax(np.where(rows & ~nan_mis, r, np.nan))]) if np.isfinite(max_rel) else float("nan")
        excluded = (n_dead if q in REACTION_COLUMNS else 0) + int(masks["neither"].sum()) + int(
            (rows & np.isnan(reference[q]) & np.isnan(judge[q])).sum())
        n_nan = int(nan_mis.sum())
        tol = tolerances[q]
        passed = n_nan == 0 and n_mis == 0 and (not np.isfinite(max_rel) or max_rel <= tol.value)
        notes = []
        if n_nan:
            notes.append(f"NaN in one engine only at theta1 = {_angles(nan_mis, theta)} deg")
        if np.isfinite(max_rel) and max_rel > tol.value:
            notes.append(f"max rel {max_rel:.3g} > {tol.value:.3g} ({tol.name}) at theta1 = {worst:g} deg")
        if q in REACTION_COLUMNS and n_dead:
            notes.append(f"{n_dead} dead-centre rows excluded")
        checks.append(Check(
            case_id, engine, q, float(diff.max()) if diff.size else float("nan"), max_rel, worst, tol,
            scales[UNIT_GROUP[q]], int(good.sum()), excluded, n_nan + n_mis, passed, "; ".join(notes),
        ))
    ref_stroke, judge_stroke = stroke(reference), stroke(judge)
    length = unit_scales(reference, judge, mode, ("S4",))["length"]
    d = abs(judge_stroke - ref_stroke)
    tol = tolerances[STROKE]
    ok = bool(np.isfinite(d) and d / length <= tol.value) or (np.isnan(ref_stroke) and np.isnan(judge_stroke))
    checks.append(Check(
        case_id, engine, STROKE, d, d / length, float("nan"), tol, length,
        1 if np.isfinite(d) else 0, 0, 0 if np.isfinite(d) or np.isnan(ref_stroke) == np.isnan(judge_stroke) else 1,
        ok, "" if ok else f"stroke {judge_stroke:.12g} against {ref_stroke:.12g}",
    ))
    return checks


def compare_run(matrix: Matrix, results: dict[str, dict[str, ResultTable | str]]) -> Comparison:
    """All checks of a run.

    Parameters
    ----------
    matrix : Matrix
    results : dict
        Case id -> engine -> its :class:`ResultTable`, or the error message (str) when the
        engine raised.  Cases missing from ``results`` are skipped (an unfinished run).
    """
    checks: list[Check] = []
    strokes: dict[str, dict[str, float]] = {}
    dead: dict[str, dict[str, int]] = {}
    errors: dict[str, dict[str, str]] = {}
    engine_tol = ResolvedTolerance("exact", 0.0, "the engine must run")
    for mc in matrix.cases:
        if mc.id not in results:
            continue
        per_engine = results[mc.id]
        errors[mc.id] = {e: v for e, v in per_engine.items() if isinstance(v, str)}
        tables = {e: per_engine[e] for e in matrix.engines if isinstance(per_engine.get(e), ResultTable)}
        strokes[mc.id] = {e: stroke(t) for e, t in tables.items()}
        dead[mc.id] = {e: int(np.sum(np.asarray(t.status, dtype=str) == "dead_centre")) for e, t in tables.items()}
        ref = tables.get(matrix.reference)
        for e in matrix.judges:
            if e not in per_engine:
                checks.append(_fail(mc.id, e, ENGINE, engine_tol, "not run"))
            elif e in errors[mc.id]:
                checks.append(_fail(mc.id, e, ENGINE, engine_tol, _last_line(errors[mc.id][e])))
            elif ref is None:
                why = errors[mc.id].get(matrix.reference, "not run")
                checks.append(_fail(mc.id, e, ENGINE, engine_tol,
                                    f"reference {matrix.reference} failed: {_last_line(why)}"))
            else:
                checks += compare_case(mc.id, mc.mode, ref, tables[e], matrix.quantities, matrix.tolerances[e])
    return Comparison(tuple(checks), strokes, dead, errors)


def _last_line(message: str) -> str:
    lines = [ln for ln in message.strip().splitlines() if ln.strip()]
    return lines[-1] if lines else "failed"
