"""Per row: which rows an engine gives a quantity on, and the relative differences ``r_i`` of a judge.

``r_i = |J_i - R_i| / (s_g c_i)`` (package docstring of :mod:`~dualmech.validation.compare`).
"""

from __future__ import annotations

import contextlib
import warnings
from typing import Iterable, Iterator

import numpy as np

from dualmech.core.status import ASSEMBLED, RATES_GIVEN, Status, is_status
from dualmech.core.table import REACTION_COLUMNS, ResultTable
from dualmech.validation.compare.results import (
    POSE_COLUMNS,
    RATE_COLUMNS,
    UNIT_GROUP,
    VERDICTS,
    RowDifferences,
)
from dualmech.validation.matrix.data import ResolvedTolerance


def condition_factor(reference: ResultTable, mode: str, quantity: str) -> np.ndarray:
    """``c_i`` of the module docstring, shape ``(n,)``: ``1/|t|`` for reactions in torque mode, else 1."""
    n = len(reference)
    if mode != "torque" or quantity not in REACTION_COLUMNS:
        return np.ones(n)
    t = np.abs(reference["transmission"])
    with np.errstate(divide="ignore"):
        return np.where(t > 0, 1.0 / np.where(t > 0, t, 1.0), np.inf)


def given_under(quantity: str) -> frozenset[str]:
    """The status words under which an engine gives ``quantity``."""
    if quantity in POSE_COLUMNS:
        return ASSEMBLED
    if quantity in RATE_COLUMNS:
        return RATES_GIVEN
    return frozenset({Status.OK})


#: Status masks already computed, while :func:`status_memo` is active: (id of the words, allowed) ->
#: (the words, their mask).  The words are kept, so their id is not reused while the memo lives.
_MEMO: dict[tuple[int, frozenset[str]], tuple[np.ndarray, np.ndarray]] | None = None


@contextlib.contextmanager
def status_memo() -> Iterator[None]:
    """Within the block, :func:`status_mask` computes each mask once per status array and set of words.

    For a comparison, whose tables do not change while it runs (a run's tables are compared
    quantity by quantity, and each quantity asks again which rows each table gives).
    """
    global _MEMO
    outer = _MEMO
    _MEMO = {} if outer is None else outer
    try:
        yield
    finally:
        _MEMO = outer


def status_mask(words: np.ndarray, allowed: Iterable[str]) -> np.ndarray:
    """:func:`~dualmech.core.status.is_status` of ``words`` (shape ``(n,)``), memoized inside
    :func:`status_memo`; a new array every call."""
    allowed = frozenset(str(a) for a in allowed)
    if _MEMO is None:
        return is_status(words, *allowed)
    key = (id(words), allowed)
    hit = _MEMO.get(key)
    if hit is None or hit[0] is not words:
        hit = _MEMO[key] = (words, is_status(words, *allowed))
    return hit[1].copy()


def rows_given(table: ResultTable, quantity: str) -> np.ndarray:
    """Rows, shape ``(n,)`` bool, where ``table``'s status says ``quantity`` is given."""
    return status_mask(table.status, given_under(quantity))


def engine_failures(table: ResultTable, quantities: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray]:
    """Rows where the engine failed, shape ``(n,)`` each: by its own word, and by a non-finite given value.

    Returns ``(failed_status, non_finite)``.
    """
    failed = ~status_mask(table.status, VERDICTS)
    non_finite = np.zeros(len(table), dtype=bool)
    for q in (*POSE_COLUMNS, *quantities):
        non_finite |= rows_given(table, q) & ~np.isfinite(table[q])
    return failed, non_finite & ~failed


def compared_rows(reference: ResultTable, judge: ResultTable, quantity: str) -> np.ndarray:
    return rows_given(reference, quantity) & rows_given(judge, quantity)


def unit_scales(
    reference: ResultTable, judge: ResultTable, mode: str, quantities: tuple[str, ...]
) -> dict[str, float]:
    """``s_g`` per unit group: the largest ``|R|/c`` over the compared rows of the group's quantities.

    A group whose reference values are all zero (or absent) gets scale 1, i.e. the
    comparison becomes absolute in the column's unit.
    """
    scales: dict[str, float] = {}
    for q in quantities:
        rows = compared_rows(reference, judge, q)
        vals = np.abs(reference[q][rows]) / condition_factor(reference, mode, q)[rows]
        vals = vals[np.isfinite(vals)]
        g = UNIT_GROUP[q]
        scales[g] = max(scales.get(g, 0.0), float(vals.max()) if vals.size else 0.0)
    return {g: (s if s > 0 else 1.0) for g, s in scales.items()}


def relative_differences(
    reference: ResultTable, judge: ResultTable, mode: str, quantities: tuple[str, ...]
) -> dict[str, np.ndarray]:
    """``r_i`` per quantity, each shape ``(n,)``; NaN on rows not compared, ``inf`` where a value is not
    finite."""
    scales = unit_scales(reference, judge, mode, quantities)
    out = {}
    for q in quantities:
        rows = compared_rows(reference, judge, q)
        with np.errstate(invalid="ignore", over="ignore"):
            rel = np.abs(judge[q] - reference[q]) / (
                scales[UNIT_GROUP[q]] * condition_factor(reference, mode, q)
            )
        rel = np.where(np.isfinite(rel), rel, np.inf)
        out[q] = np.where(rows, rel, np.nan)
    return out


def row_differences(rel: dict[str, np.ndarray], theta: np.ndarray) -> RowDifferences:
    """Per row, the worst of the kinematic and of the reaction ``r_i`` in ``rel``
    (:func:`relative_differences`); NaN where no column of the kind was compared."""
    kinematic = tuple(q for q in rel if q not in REACTION_COLUMNS)
    reactions = tuple(q for q in rel if q in REACTION_COLUMNS)
    return theta, _row_worst(rel, kinematic, len(theta)), _row_worst(rel, reactions, len(theta))


def _row_worst(rel: dict[str, np.ndarray], quantities: tuple[str, ...], n: int) -> np.ndarray:
    """Per row, the largest of ``rel[q]`` over ``quantities`` (shape ``(n,)``); NaN where none compared."""
    if not quantities:
        return np.full(n, np.nan)
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN rows: nothing compared there
        return np.nanmax(np.stack([rel[q] for q in quantities]), axis=0)


def stroke(table: ResultTable) -> float:
    """``max S4 - min S4`` over the assembled rows (the case's sampled angles); NaN if none."""
    s4 = table["S4"][is_status(table.status, *ASSEMBLED)]
    s4 = s4[np.isfinite(s4)]
    return float(s4.max() - s4.min()) if s4.size else float("nan")


def worst_row(rel: np.ndarray, finite: np.ndarray, key: np.ndarray) -> tuple[float, float]:
    """The largest ``rel`` over the rows ``finite`` and the ``key`` value (the input) at its row; NaN, NaN
    where no row is."""
    if not finite.any():
        return float("nan"), float("nan")
    rows = np.flatnonzero(finite)
    worst = rows[np.argmax(rel[finite])]
    return float(rel[worst]), float(key[worst])


def column_notes(compared: bool, one_sided: str | None, max_rel: float, tol: ResolvedTolerance,
                 worst_at: str) -> list[str]:
    """What a column check says of itself: no row ``compared``; the rows where only one engine gives a value
    (``one_sided``: that phrase, ``None`` if none); its worst ``max_rel`` beyond ``tol``, ``worst_at`` (the
    input value there)."""
    notes = [] if compared else ["no row compared: no position where both engines give it"]
    notes += [one_sided] if one_sided else []
    if np.isfinite(max_rel) and max_rel > tol.value:
        notes.append(f"max rel {max_rel:.3g} > {tol.value:.3g} ({tol.name}) {worst_at}")
    return notes
