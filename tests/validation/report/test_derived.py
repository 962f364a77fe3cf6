"""The report's in-house sections solved ahead (validation/report/derived.py): the thesis's findings solved
in a background thread while the run's workers solve are the findings solved after, and a failure there is the
report's, not lost in the thread."""

from __future__ import annotations

import pytest

from dualmech.validation.matrix import load_matrix
from dualmech.validation.report import derived


def test_findings_solved_ahead_are_the_findings():
    ahead = derived.findings_ahead(load_matrix("thesis-1991"))
    assert ahead is not None
    assert ahead() == derived.findings()


def test_no_findings_ahead_for_a_matrix_that_is_not_the_thesis():
    from dualmech.models.case import load_case

    assert derived.findings_ahead(load_matrix(load_case("thesis/ideal"))) is None  # one design


def test_a_failure_of_the_findings_reaches_the_caller(monkeypatch):
    def broken() -> list[dict]:
        raise RuntimeError("findings broke")

    monkeypatch.setattr(derived, "findings", broken)
    ahead = derived.findings_ahead(load_matrix("thesis-1991"))
    with pytest.raises(RuntimeError, match="findings broke"):
        ahead()
