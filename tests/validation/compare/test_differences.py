"""The comparison's status masks, memoized per table while it runs (validation/compare/differences.py)."""

from __future__ import annotations

import json

import numpy as np

from dualmech.core.status import Status
from dualmech.validation.compare import compare_run

# ----------------------------------------------------------------------------- status masks, memoized


def _checks_text(comparison) -> str:
    return json.dumps([c.to_dict() for c in comparison.checks], default=str)


def test_memoized_status_masks_give_the_same_comparison(matrix, results, monkeypatch):
    """Why: compare_run asked each table which rows it gives once per quantity (0.7 s of a 1 s comparison);
    within a comparison each table's masks are computed once, and the checks are those computed afresh."""
    from dualmech.validation.compare import differences

    results["torque_a4=10_S1=3.5"]["pinocchio"].status[[2, 5]] = Status.NOT_CONVERGED.value  # masks vary
    memoized = compare_run(matrix, results)
    assert differences._MEMO is None  # gone with the comparison: tables changed later are asked again

    monkeypatch.setattr(differences, "status_memo", _no_memo)
    monkeypatch.setattr("dualmech.validation.compare.run.status_memo", _no_memo)
    afresh = compare_run(matrix, results)
    assert not afresh.passed
    assert _checks_text(memoized) == _checks_text(afresh)


def _no_memo():
    import contextlib

    return contextlib.nullcontext()


def test_a_memo_keyed_on_the_words_alone_is_seen(matrix, results, monkeypatch):
    """The fault the memo must not have: one mask per set of words, whatever table asks (the first
    table's answer given to every other)."""
    from dualmech.validation.compare import differences

    results["torque_a4=10_S1=3.5"]["pinocchio"].status[[2, 5]] = Status.NOT_CONVERGED.value
    good = compare_run(matrix, results)
    real = differences.is_status
    first: dict = {}

    def by_words_only(words, *allowed):
        return first.setdefault(frozenset(allowed), real(words, *allowed)).copy()

    monkeypatch.setattr(differences, "is_status", by_words_only)
    bad = compare_run(matrix, results)
    assert _checks_text(bad) != _checks_text(good)


def test_status_mask_outside_a_memo_reads_the_words_each_time():
    from dualmech.validation.compare.differences import status_mask, status_memo

    words = np.array(["ok", "dead_centre", "ok"], dtype=object)
    with status_memo():
        np.testing.assert_array_equal(status_mask(words, ["ok"]), [True, False, True])
        words[0] = "no_assembly"  # inside: the memo's answer (the tables must not change meanwhile)
        np.testing.assert_array_equal(status_mask(words, ["ok"]), [True, False, True])
        other = np.array(["dead_centre", "ok", "ok"], dtype=object)
        np.testing.assert_array_equal(status_mask(other, ["ok"]), [False, True, True])  # per array
    np.testing.assert_array_equal(status_mask(words, ["ok"]), [False, False, True])
