"""Checks that ``dualmech selftest`` found missing: each kills a fault of ``validation/mutants.toml``.

Every test here was seen failing on the fault it names (the selftest applies it
to a scratch copy and runs this module as part of the gate); on the current
source it passes.  The engines are the stand-ins of ``matrix_fakes``.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from dualmech.core.status import Status
from dualmech.core.table import REACTION_COLUMNS
from dualmech.validation.compare import compare_case, compare_run
from dualmech.validation.compare.baseline import baseline_summary, compare_baseline
from dualmech.validation.matrix import GROUPS, load_matrix

from .test_compare import _edited

#: A tolerance no measured difference of the default matrix comes within this fraction of is a blind spot:
#: the worst measured ratio (difference / tolerance) per judge and group is 7e-5 .. 8e-2
#: (reports/baseline.json).
BLIND_TOLERANCE_RATIO = 1e-6
#: A rigid judge missing a dead centre this far from one (|transmission|) is wrong, whatever the band.
MISSED_DEAD_CENTRE_T = 1e-3


def test_baseline_flags_an_in_house_value_that_moved(matrix, results):
    """Kills baseline-value-rtol-constant: an in-house stroke 1e-6 (relative) off its baseline regresses."""
    summary = baseline_summary(matrix, compare_run(matrix, results), results)
    baseline = json.loads(json.dumps(summary))
    cid = matrix.cases[0].id
    baseline["cases"][cid]["reference"]["stroke"] *= 1.0 + 1e-6
    regressions = compare_baseline(summary, baseline)
    assert [(r.case, r.quantity) for r in regressions] == [(cid, "stroke")], regressions


def test_baseline_flags_a_check_that_now_fails(matrix, results):
    """Kills baseline-new-failure-ignored: a check that passed in the baseline and fails now is named so."""
    baseline = baseline_summary(matrix, compare_run(matrix, results), results)
    cid = matrix.cases[1].id
    judge = results[cid]["pinocchio"]
    results[cid]["pinocchio"] = _edited(judge, 5, j2_fx=judge["j2_fx"][5] * (1.0 + 1e-3))
    now = compare_run(matrix, results)
    regressions = compare_baseline(baseline_summary(matrix, now, results), baseline)
    assert any(r.case == cid and r.engine == "pinocchio" and r.quantity == "j2_fx"
               and "passed in the baseline, fails now" in r.message for r in regressions), regressions


@pytest.mark.parametrize("value", [np.nan, np.inf])
def test_a_non_finite_value_fails_its_own_quantity(matrix, results, value):
    """Kills cmp-nan-one-engine: the column holding the NaN fails, not only the row's status check."""
    cid = matrix.cases[1].id
    results[cid]["pinocchio"] = _edited(results[cid]["pinocchio"], 5, j2_fx=value)
    checks = {c.quantity: c for c in compare_run(matrix, results).for_engine(cid, "pinocchio")}
    assert not checks["j2_fx"].passed and "non-finite" in checks["j2_fx"].detail
    assert all(c.passed for q, c in checks.items() if q not in ("j2_fx", "status"))


def test_a_rigid_judge_missing_a_dead_centre_fails(matrix, results):
    """Kills tol-dead-centre-band-wide: reference dead_centre, judge ok at |t| = 1e-3 is a status mismatch."""
    mc = next(c for c in matrix.cases if c.mode == "torque")
    ref, judge = results[mc.id]["dualmech"], results[mc.id]["pinocchio"]
    row = 4
    nan = {c: np.nan for c in REACTION_COLUMNS}
    ref = _edited(ref, row, Status.DEAD_CENTRE, transmission=MISSED_DEAD_CENTRE_T, **nan)
    judge = _edited(judge, row, transmission=MISSED_DEAD_CENTRE_T)
    checks = compare_case(mc.id, mc.mode, ref, judge, matrix.quantities, matrix.tolerances["pinocchio"])
    status = next(c for c in checks if c.quantity == "status")
    assert not status.passed and "reference dead_centre, judge ok" in status.detail, status.detail


def test_no_tolerance_is_a_blind_spot():
    """Kills tol-pinocchio-reactions-loose: each (judge, group) tolerance is used by a measured difference.

    The committed baseline holds the worst relative difference of every check of the
    default matrix; divided by the tolerance the default matrix applies, the largest
    per judge and group must exceed BLIND_TOLERANCE_RATIO.
    """
    root = Path(__file__).resolve().parents[3]
    baseline = json.loads((root / "reports" / "baseline.json").read_text())
    default = load_matrix(None)
    worst: dict[tuple[str, str], float] = {}
    for case in baseline["cases"].values():
        for engine, checks in case["checks"].items():
            for q, v in checks.items():
                group = next((g for g in ("kinematics", "reactions", "stroke") if q in GROUPS[g]), None)
                if engine not in default.judges or group is None or v.get("max_rel") is None:
                    continue
                key = (engine, group)
                worst[key] = max(worst.get(key, 0.0), v["max_rel"] / default.tolerances[engine][q].value)
    assert {e for e, _ in worst} == set(default.judges)
    blind = {k: v for k, v in worst.items() if v < BLIND_TOLERANCE_RATIO}
    assert not blind, f"no measured difference comes near these (ratio < {BLIND_TOLERANCE_RATIO:g}): {blind}"
