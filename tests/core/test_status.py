"""The status vocabulary's helpers: what each word promises, and the demotion of rows that break it."""

import numpy as np
from numpy.testing import assert_array_equal

from dualmech.core.status import POSE_COLUMNS, RATE_COLUMNS, Status, demote_non_finite, is_status, settle

WORDS = [Status.OK, Status.DEAD_CENTRE, Status.ASSEMBLY_LIMIT, Status.NO_ASSEMBLY, Status.OK]
REACTIONS = ("j3_fy",)


def _columns(rng: np.random.Generator) -> dict[str, np.ndarray]:
    return {name: rng.uniform(-1.0, 1.0, len(WORDS)) for name in (*POSE_COLUMNS, *RATE_COLUMNS, *REACTIONS)}


def test_demote_non_finite_reads_only_the_columns_each_word_gives():
    rng = np.random.default_rng(0)
    cols = _columns(rng)
    cols["j3_fy"][[0, 1, 2, 3]] = np.inf  # ok row 0 breaks its promise; rows 1-3 do not give reactions
    cols["S4_ddot"][4] = np.nan  # ok row 4 breaks it
    out = demote_non_finite(cols, np.array(WORDS, dtype=object), ("S4", "S4_ddot", "j3_fy"))
    assert_array_equal(out, ["not_finite", "dead_centre", "assembly_limit", "no_assembly", "not_finite"])


def test_settle_demotes_dead_centre_and_assembly_limit_rows_with_non_finite_pose_or_rates():
    rng = np.random.default_rng(1)
    cols = _columns(rng)
    cols["S4_dot"][1] = np.inf  # dead_centre gives rates
    cols["S4"][2] = np.nan  # assembly_limit gives the pose
    cols["S4_dot"][2] = np.inf  # ... but not rates: no demotion for this one
    status = settle(cols, np.array(WORDS, dtype=object), REACTIONS)
    assert_array_equal(status, ["ok", "not_finite", "not_finite", "no_assembly", "ok"])


def test_settle_blanks_what_a_word_does_not_give():
    rng = np.random.default_rng(2)
    cols = _columns(rng)
    status = settle(cols, np.array(WORDS, dtype=object), REACTIONS)
    given = {"j3_fy": [0, 4], "S4_dot": [0, 1, 4], "transmission": [0, 1, 4], "S4": [0, 1, 2, 4],
             "closure_condition": [0, 1, 2, 4]}
    for name, rows in given.items():
        assert np.isfinite(cols[name][rows]).all(), name
        others = np.setdiff1d(np.arange(len(WORDS)), rows)
        assert np.isnan(cols[name][others]).all(), name
    assert list(status) == [str(w) for w in WORDS]


def test_is_status_marks_the_rows_of_the_allowed_words_whatever_the_array():
    """Object arrays of words or of Status members, string arrays, lists, one row, no row: the same mask
    (it was np.isin on the words as strings; now one comparison per word)."""
    words = ["ok", "dead_centre", "no_assembly", "assembly_limit", "ok"]
    expected = [False, True, True, False, False]
    for form in (np.array(words, dtype=object), np.array([Status(w) for w in words], dtype=object),
                 np.array(words), words):
        assert_array_equal(is_status(form, Status.DEAD_CENTRE, "no_assembly"), expected)
    assert_array_equal(is_status(np.array(["ok"], dtype=object), Status.OK), [True])
    assert is_status(np.array([], dtype=object), Status.OK).shape == (0,)
    assert not is_status(np.array(words, dtype=object)).any()  # no word allowed
    assert not is_status(np.array([None, float("nan")], dtype=object), Status.OK).any()
