"""Per-design outputs of a tolerance study (models/tolerance/outputs.py): the batched reduction, which keeps
squared magnitudes and folds blocks of designs and positions, against the outputs' definition written out
position by position (``docs/conventions.md``, "Tolerance analysis")."""

import numpy as np
import pytest
from numpy.testing import assert_array_equal

import dualmech.models.tolerance.outputs as outputs
from dualmech.core.status import ASSEMBLED, STATUSES
from dualmech.models.tolerance.outputs import FORCES, MOMENTS, SOLVED_LOAD, DesignReduction, needed_columns

D, P = 23, 40  # designs, positions


def _block(mode, seed=3):
    """Random columns ``(D, P)`` with NaN, inf and huge values, and random status codes (some designs all ok,
    one never assembling)."""
    rng = np.random.default_rng(seed)
    columns = {c: rng.normal(0.0, 10.0 ** rng.integers(-3, 4), (D, P)) for c in needed_columns(mode)}
    for c in columns.values():
        c[rng.random((D, P)) < 0.03] = np.nan
        c[rng.random((D, P)) < 0.01] = np.inf
        c[rng.random((D, P)) < 0.01] = 1e200  # squares overflow: a magnitude of inf is never a peak
    codes = rng.choice(len(STATUSES), size=(D, P), p=[0.7, 0.05, 0.05, 0.05, 0.05, 0.05, 0.03, 0.02])
    codes[:3] = STATUSES.index("ok")
    codes[3] = STATUSES.index("no_assembly")
    return columns, codes.astype(np.int8)


def _defined(columns, codes, mode):
    """The outputs as defined, one design and one position at a time (no squares kept, no blocks)."""
    ok = codes == STATUSES.index("ok")
    assembled = np.isin(codes, [STATUSES.index(s) for s in ASSEMBLED])
    out = {}
    s4 = columns["S4"]
    keep = assembled & np.isfinite(s4)
    out["stroke"] = np.array([s4[i, keep[i]].max() - s4[i, keep[i]].min() if keep[i].any() else np.nan
                              for i in range(D)])
    with np.errstate(over="ignore"):
        peaks = {name: np.sqrt(sum(columns[f"{prefix}{a}"] ** 2 for a in "xyz"))
                 for name, prefix in FORCES + MOMENTS}
    name, column = SOLVED_LOAD[mode]
    peaks[name] = np.abs(columns[column])
    for name, values in peaks.items():
        use = ok & np.isfinite(values)
        out[name] = np.array([values[i, use[i]].max() if use[i].any() else np.nan for i in range(D)])
    out["assembled_fraction"] = assembled.sum(axis=1) / P
    out["dead_centres"] = (codes == STATUSES.index("dead_centre")).sum(axis=1)
    failed = [STATUSES.index(s) for s in ("branch_jump", "not_converged", "not_finite")]
    out["failed_positions"] = np.isin(codes, failed).sum(axis=1)
    out["branch_jumps"] = (codes == STATUSES.index("branch_jump")).sum(axis=1)
    return out


def _reduced(columns, codes, mode):
    """The reduction fed in uneven blocks of designs and positions."""
    r = DesignReduction(D, mode)
    for d0, d1 in ((0, 5), (5, 16), (16, D)):
        for q0, q1 in ((0, 7), (7, 30), (30, P)):
            r.add(d0, {c: v[d0:d1, q0:q1] for c, v in columns.items()}, codes[d0:d1, q0:q1])
    return r.result()


def _differences(mode):
    columns, codes = _block(mode)
    with np.errstate(over="ignore"):
        got = _reduced(columns, codes, mode)
    want = _defined(columns, codes, mode)
    return [name for name in want if not np.array_equal(got[name], want[name], equal_nan=True)]


@pytest.mark.parametrize("mode", ["torque", "force"])
def test_reduction_is_the_definition_bit_for_bit(mode):
    assert _differences(mode) == []
    columns, codes = _block(mode)
    with np.errstate(over="ignore"):
        got = _reduced(columns, codes, mode)
    assert np.isfinite(got["peak_j1_force"][:3]).all() and np.isnan(got["stroke"][3])
    assert_array_equal(got["status"][:4], ["ok", "ok", "ok", "no_assembly"])


def test_reduction_check_sees_a_fault(monkeypatch):
    """Deliberate fault: the block extremes ignore the position statuses (every row taken as ok)."""
    real = outputs.block_extremes
    monkeypatch.setattr(outputs, "block_extremes",
                        lambda columns, codes, mode: real(columns, np.zeros_like(codes), mode))
    assert "peak_j1_force" in _differences("torque")
