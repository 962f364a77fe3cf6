"""A slider-crank case: the reference's own check, then each judge's statuses, quantities and stroke.

:func:`compare_slider_crank` is the gate of a slider-crank case in a run
(:func:`~dualmech.validation.compare.run.compare_run`; rules in the package docstring of
:mod:`~dualmech.validation.compare`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dualmech.core.status import ASSEMBLED, Status, is_status
from dualmech.core.table import ResultTable
from dualmech.models.case import case_from_dict
from dualmech.validation.compare.conditioning import Conditioning, allowances, stroke_allowance, within
from dualmech.validation.compare.differences import (
    column_notes,
    compared_rows,
    engine_failures,
    relative_differences,
    row_differences,
    rows_given,
    stroke,
    unit_scales,
    worst_row,
)
from dualmech.validation.compare.joint_lock import (
    JOINT_LOCK_CAP,
    lock_factor,
    lock_rate,
    widened,
)
from dualmech.validation.compare.odd_one_out import name_odd_one_out
from dualmech.validation.compare.pairs import case_pairs, looser, slider_crank_group
from dualmech.validation.compare.results import (
    EXPECT_NO_ASSEMBLY,
    NEAR_JOINT_LOCK,
    STATUS,
    STROKE,
    STROKE_PROXY,
    UNIT_GROUP,
    Check,
    RowDifferences,
)
from dualmech.validation.matrix import Matrix, MatrixCase, ResolvedTolerance
from dualmech.validation.tolerances import (
    ASSEMBLY_LIMIT_CONDITION,
    DEAD_CENTRE_TRANSMISSION,
    JOINT_LOCK_CONDITION,
)


def fail(case: str, engine: str, quantity: str, tol: ResolvedTolerance, detail: str,
         incomplete: bool = False) -> Check:
    """A failing check with no number: ``detail`` says why (``incomplete``: the work was not done)."""
    nan = float("nan")
    return Check(case, engine, quantity, nan, nan, nan, tol, nan, 0, 0, 0, False, detail, incomplete)


def _angles(rows: np.ndarray, theta: np.ndarray, limit: int = 4) -> str:
    idx = np.flatnonzero(rows)
    shown = ", ".join(f"{theta[i]:g}" for i in idx[:limit])
    return shown + (f", ... ({idx.size} rows)" if idx.size > limit else "")


_EXACT = ResolvedTolerance("exact", 0.0, "statuses must agree row by row, except where a stated band "
                                         "explains it")


@dataclass(frozen=True)
class StatusRule:
    """Where two engines may say ``ok`` and ``flag`` at the same row.

    Both engines' ``|X[column]|`` must lie within ``band`` of ``at`` and at or above
    ``floor``, and the case's load mode must be one of ``modes``.  Each engine sets
    ``flag`` from its own value of ``column``, so values that agree to round-off can
    fall on either side of its threshold; below ``floor`` (under every engine's
    threshold) the flag is owed, whatever the band.
    """

    flag: str
    column: str
    at: float
    band: str  # the name of the band's tolerance in the matrix (per judge)
    floor: float = 0.0
    modes: tuple[str, ...] = ()  # load modes where the rule applies; () = every mode


#: The only status differences the gate accepts, each at its engine-set threshold.
STATUS_RULES: tuple[StatusRule, ...] = (
    StatusRule(
        Status.DEAD_CENTRE,
        "transmission",
        0.0,
        "dead_centre_band",
        floor=0.5 * DEAD_CENTRE_TRANSMISSION.value,
        modes=("torque",),
    ),
    StatusRule(
        Status.ASSEMBLY_LIMIT, "closure_condition", ASSEMBLY_LIMIT_CONDITION.value, "assembly_limit_band"
    ),
    # the same closure condition at its other end (c -> 1), resolved as well as at the assembly limit
    StatusRule(Status.JOINT_LOCK, "closure_condition", JOINT_LOCK_CONDITION.value, "assembly_limit_band"),
)


def _failure_notes(who: str, table: ResultTable, failed: np.ndarray, non_finite: np.ndarray) -> list[str]:
    theta = table["theta1_deg"]
    notes = []
    for word in sorted({str(w) for w in np.asarray(table.status, dtype=str)[failed]}):
        rows = failed & is_status(table.status, word)
        notes.append(f"{who} says {word} at theta1 = {_angles(rows, theta)} deg")
    if non_finite.any():
        notes.append(f"{who} gives a non-finite value in a row it calls given, at theta1 = "
                     f"{_angles(non_finite, theta)} deg")
    return notes


def reference_check(case_id: str, reference: ResultTable, quantities: tuple[str, ...],
                    expect: str | None) -> Check:
    """The reference engine's own ``status`` check: no engine failure, and assembled somewhere (or as
    expected)."""
    failed, non_finite = engine_failures(reference, quantities)
    bad = failed | non_finite
    notes = _failure_notes("the reference", reference, failed, non_finite)
    assembled = is_status(reference.status, *ASSEMBLED)
    if expect == EXPECT_NO_ASSEMBLY:
        wrong = ~is_status(reference.status, Status.NO_ASSEMBLY) & ~bad
        if wrong.any():
            notes.append(f"expected no_assembly everywhere, assembles at theta1 = "
                         f"{_angles(wrong, reference['theta1_deg'])} deg")
        bad = bad | wrong
    elif not assembled.any() and not bad.any():
        notes.append('the reference assembles at no crank position (declare expect = "no_assembly" '
                     "in the sweep if that is intended)")
        bad = np.ones(len(reference), dtype=bool)
    n_bad = int(bad.sum())
    return Check(case_id, reference.engine, STATUS, float(n_bad), float(n_bad), float("nan"), _EXACT, 1.0,
                 len(reference), 0, n_bad, n_bad == 0, "; ".join(notes))


def _in_band(values: np.ndarray, rule: StatusRule, band: ResolvedTolerance) -> np.ndarray:
    """Rows, shape ``(n,)``, whose ``|values|`` lie within ``band`` of ``rule.at`` and at or above
    ``rule.floor``."""
    size = np.abs(values)
    with np.errstate(invalid="ignore"):  # a value an engine does not give is never in the band
        return (np.abs(size - rule.at) <= band.value) & (size >= rule.floor)


def status_check(case_id: str, reference: ResultTable, judge: ResultTable, quantities: tuple[str, ...],
                 bands: dict[str, ResolvedTolerance], mode: str = "") -> Check:
    """The judge's ``status`` check: its own failures, and agreement with the reference row by row.

    Rows where the reference itself failed are left to :func:`reference_check`; a
    difference is explained only by a :data:`STATUS_RULES` band found in ``bands``.
    """
    theta = reference["theta1_deg"]
    ref_failed, ref_non_finite = engine_failures(reference, quantities)
    failed, non_finite = engine_failures(judge, quantities)
    usable = ~(ref_failed | ref_non_finite)
    failed, non_finite = failed & usable, non_finite & usable
    rs, js = np.asarray(reference.status, dtype=str), np.asarray(judge.status, dtype=str)
    differ = usable & ~failed & (rs != js)
    notes = _failure_notes("the judge", judge, failed, non_finite)
    explained = np.zeros_like(differ)
    for rule in STATUS_RULES:
        band = bands.get(rule.band)
        if band is None or (rule.modes and mode not in rule.modes):
            continue
        pair = (is_status(rs, Status.OK) & is_status(js, rule.flag)) | (
            is_status(rs, rule.flag) & is_status(js, Status.OK))
        near = pair & _in_band(reference[rule.column], rule, band) & _in_band(judge[rule.column], rule, band)
        if near.any():
            notes.append(f"{int(near.sum())} {rule.flag} flag(s) differ within {band.value:g} of "
                         f"|{rule.column}| = {rule.at:g} ({band.name})")
        explained |= near
    mismatch = differ & ~explained
    for r_word, j_word in sorted({(r, j) for r, j in zip(rs[mismatch], js[mismatch])}):
        rows = mismatch & (rs == r_word) & (js == j_word)
        notes.append(f"reference {r_word}, judge {j_word} at theta1 = {_angles(rows, theta)} deg")
    bad = failed | non_finite | mismatch
    n_bad = int(bad.sum())
    agreed_unassembled = usable & ~bad & (rs == js) & ~is_status(rs, *ASSEMBLED)
    return Check(case_id, judge.engine, STATUS, float(n_bad), float(n_bad), float("nan"), _EXACT, 1.0,
                 int(usable.sum()), int(agreed_unassembled.sum()), n_bad, n_bad == 0, "; ".join(notes))


def quantity_check(case_id: str, mode: str, reference: ResultTable, judge: ResultTable, quantity: str,
                   rel: np.ndarray, scale: float, tol: ResolvedTolerance,
                   widening: np.ndarray | None = None,
                   allowance: dict[str, np.ndarray] | None = None) -> Check:
    """One column's check (module docstring): every row both engines give, none non-finite, at least one.

    A row's tolerance is ``f_i tol + a_i``: near a universal joint's lock ``f_i`` is ``widening``
    (shape ``(n,)``, :func:`~dualmech.validation.compare.joint_lock.lock_factor`; the detail then says
    :data:`~dualmech.validation.compare.joint_lock.NEAR_JOINT_LOCK`), and ``a_i`` is the sum of the
    ``allowance`` laws (:func:`~dualmech.validation.compare.conditioning.allowances`, each ``(n,)``);
    where the laws were needed to pass a row, the detail names them
    (:func:`~dualmech.validation.compare.conditioning.within`).  ``max_rel`` is then the row's
    difference scaled to ``tol`` (``r_i tol / tol_i``).
    """
    theta = reference["theta1_deg"]
    rows = compared_rows(reference, judge, quantity)
    notes = []
    factor = np.ones(len(reference))
    if widening is not None and widened(quantity) and (rows & (widening > 1)).any():
        near = rows & (widening > 1)
        factor = widening
        notes.append(f"{NEAR_JOINT_LOCK}: tolerance x{widening[near].max():.3g} at most, at theta1 = "
                     f"{_angles(near, theta)} deg ({JOINT_LOCK_CAP})")
    if tol.value > 0:
        rel, needed, phrase = within(rel, rows, tol.value, factor, allowance or {})
        notes += [f"{phrase} at theta1 = {_angles(needed, theta)} deg"] if phrase else []
    infinite = rows & np.isinf(rel)
    finite = rows & np.isfinite(rel)
    max_rel, worst = worst_row(rel, finite, theta)
    diff = np.abs(judge[quantity] - reference[quantity])[finite]
    n_dead = int((rows_given(reference, STROKE_PROXY) & rows_given(judge, STROKE_PROXY) & ~rows).sum())
    one_sided = f"non-finite value at theta1 = {_angles(infinite, theta)} deg" if infinite.any() else None
    notes += column_notes(bool(rows.any()), one_sided, max_rel, tol, f"at theta1 = {worst:g} deg")
    if n_dead:
        notes.append(f"{n_dead} assembled rows without it (dead centres, assembly limits) excluded")
    passed = bool(rows.any()) and not infinite.any() and max_rel <= tol.value
    return Check(case_id, judge.engine, quantity, float(diff.max()) if diff.size else float("nan"), max_rel,
                 worst, tol, scale, int(finite.sum()), n_dead, int(infinite.sum()), passed, "; ".join(notes))


def stroke_check(case_id: str, mode: str, reference: ResultTable, judge: ResultTable,
                 tol: ResolvedTolerance, conditioning: Conditioning | None = None) -> Check:
    """The stroke of the judge against the reference's, relative to the case's length scale.

    With ``conditioning``, its tolerance is ``tol`` plus the stroke's allowances
    (:func:`~dualmech.validation.compare.conditioning.stroke_allowance`); ``max_rel`` is scaled to ``tol``.
    """
    ref_stroke, judge_stroke = stroke(reference), stroke(judge)
    length = unit_scales(reference, judge, mode, (STROKE_PROXY,))["length"]
    d = abs(judge_stroke - ref_stroke)
    rel, phrase = d / length, ""
    if tol.value > 0 and conditioning is not None:
        laws = stroke_allowance(reference, judge, length, conditioning)
        scaled, _, phrase = within(np.array([rel]), np.array([True]), tol.value, 1.0,
                                   {k: np.array([a]) for k, a in laws.items()})
        rel = float(scaled[0])
    ok = bool(np.isfinite(d) and rel <= tol.value)
    notes = ([phrase] if phrase else []) if ok else [f"stroke {judge_stroke:.12g} against {ref_stroke:.12g}"]
    return Check(case_id, judge.engine, STROKE, d, rel, float("nan"), tol, length, int(np.isfinite(d)), 0,
                 int(not np.isfinite(d)), ok, "; ".join(notes))


def compare_case(
    case_id: str,
    mode: str,
    reference: ResultTable,
    judge: ResultTable,
    quantities: tuple[str, ...],
    tolerances: dict[str, ResolvedTolerance],
    expect: str | None = None,
    rel: dict[str, np.ndarray] | None = None,
    lock: np.ndarray | None = None,
    conditioning: Conditioning | None = None,
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
        Quantity (and ``"stroke"``, and the :data:`STATUS_RULES` bands) -> tolerance.
    expect : str, optional
        ``"no_assembly"``: the case is declared to assemble nowhere; only statuses are checked.
    rel : dict, optional
        The judge's :func:`relative_differences`, when the caller has them already.
    lock : numpy.ndarray, optional
        ``kappa`` per row, shape ``(n,)`` (:func:`~dualmech.validation.compare.joint_lock.lock_rate`):
        with the judge's ``joint_lock_cap`` in ``tolerances``, its rate and reaction tolerances are
        widened near a universal joint's lock.
    conditioning : Conditioning, optional
        The case's :class:`~dualmech.validation.compare.conditioning.Conditioning`: each row's tolerance
        grows by the allowances its conditioning calls for (none without it).
    """
    engine = judge.engine
    theta = reference["theta1_deg"]
    if len(judge) != len(reference) or not np.allclose(judge["theta1_deg"], theta, rtol=0, atol=1e-9):
        detail = f"rows differ: {len(judge)} crank angles against the reference's {len(reference)}"
        return [fail(case_id, engine, STATUS, _EXACT, detail)]
    checks = [status_check(case_id, reference, judge, quantities, tolerances, mode)]
    if expect == EXPECT_NO_ASSEMBLY:
        return checks
    if rel is None:
        rel = relative_differences(reference, judge, mode, quantities)
    scales = unit_scales(reference, judge, mode, quantities)
    cap = tolerances.get(JOINT_LOCK_CAP)
    widening = None if lock is None or cap is None else lock_factor(lock, reference["closure_condition"],
                                                                    cap.value)
    for q in quantities:
        scale = scales[UNIT_GROUP[q]]
        extra = None if conditioning is None else allowances(q, mode, reference, judge, scale, conditioning)
        checks.append(quantity_check(case_id, mode, reference, judge, q, rel[q], scale, tolerances[q],
                                     widening, extra))
    checks.append(stroke_check(case_id, mode, reference, judge, tolerances[STROKE], conditioning))
    return checks


def compare_slider_crank(matrix: Matrix, mc: MatrixCase, tables: dict[str, ResultTable],
                         rows: dict[str, RowDifferences],
                         pairs: dict[tuple[str, str], list[tuple[str, Check]]]
                         ) -> list[Check]:
    """The checks of slider-crank case ``mc`` whose reference answered (``tables``: engine -> its table):
    the reference's own, then each judge's (:func:`compare_case`, the odd one out named); each judge's rows
    kept in ``rows`` (:func:`row_differences`, for the report), each pair of engines added to ``pairs``
    (:func:`~dualmech.validation.compare.pairs.case_pairs`)."""
    ref = tables[matrix.reference]
    own = reference_check(mc.id, ref, matrix.quantities, mc.expect)
    case = case_from_dict(mc.raw)
    lock, conditioning = lock_rate(case, ref), Conditioning.of(case, ref)
    judged: list[Check] = []
    for e in matrix.judges:
        if e in tables:
            rel = None
            if len(tables[e]) == len(ref):
                rel = relative_differences(ref, tables[e], mc.mode, matrix.quantities)
                rows[e] = row_differences(rel, ref["theta1_deg"])
            judged += compare_case(mc.id, mc.mode, ref, tables[e], matrix.quantities, matrix.tolerances[e],
                                   mc.expect, rel, lock, conditioning)
    same_rows = {e: t for e, t in tables.items() if e in matrix.judges and len(t) == len(ref)}
    gate = [own, *name_odd_one_out(judged, ref, same_rows, mc.mode, matrix.tolerances, conditioning)]
    case_pairs(list(tables), matrix.reference, gate, lambda a, b: [
        reference_check(mc.id, tables[a], matrix.quantities, mc.expect),
        *compare_case(mc.id, mc.mode, tables[a], tables[b], matrix.quantities, looser(
            matrix.tolerances[a], matrix.tolerances[b]), mc.expect, None, lock, conditioning)],
        slider_crank_group, pairs)
    return gate


def first_line(message: str, width: int = 200) -> str:
    """The line of an engine's error text that says what went wrong, at most ``width`` characters.

    Engines store ``"<ExceptionType>: <message>"`` first (:func:`dualmech.validation.run.runner.run_task`);
    a stored traceback is read from its end, where Python puts that line.
    """
    lines = [ln.strip() for ln in message.strip().splitlines() if ln.strip()]
    if not lines:
        return "failed"
    line = lines[-1] if lines[0].startswith("Traceback") else lines[0]
    return line if len(line) <= width else line[: width - 1] + "…"
