"""The one status vocabulary of the suite: what an engine says about one crank position.

Every engine (in-house, Pinocchio, MuJoCo rigid, MuJoCo simulation), the
comparison, the report and JUnit use these words and nothing else; each is
defined in ``docs/conventions.md`` ("Status words").  :class:`Status` is a
:class:`enum.StrEnum`, so a member compares equal to its word (``Status.OK ==
"ok"``) and stored tables stay plain JSON/CSV text.

==================  ==========  ==========  =================================================
word                kinematics  reactions   meaning
==================  ==========  ==========  =================================================
``ok``              finite      finite      the position assembles and everything is given
``dead_centre``     finite      NaN         torque mode, ``|transmission|`` below the band:
                                            the given torque cannot be balanced
``assembly_limit``  S1, S4, c   NaN         the rod is (nearly) normal to the slider line:
                                            the closure is singular, rates are unbounded (a
                                            loop table: its closure condition below the band)
``branch_jump``     NaN         NaN         the solver converged on the other assembly branch
``not_converged``   NaN         NaN         the solver stopped without meeting its tolerance
``no_assembly``     NaN         NaN         proven: the rod cannot reach the slider line
``not_finite``      NaN         NaN         the arithmetic overflowed (input far out of range)
``joint_lock``      S1, S4, c   NaN         a universal joint at the slider, the rod (nearly)
                                            along the slider axis: its spin rate is unbounded
==================  ==========  ==========  =================================================
"""

from __future__ import annotations

from enum import StrEnum

import numpy as np

from dualmech.core.thresholds import JOINT_LOCK_CONDITION


class Status(StrEnum):
    """Status of one crank position (module docstring)."""

    OK = "ok"
    DEAD_CENTRE = "dead_centre"
    ASSEMBLY_LIMIT = "assembly_limit"
    BRANCH_JUMP = "branch_jump"
    NOT_CONVERGED = "not_converged"
    NO_ASSEMBLY = "no_assembly"
    NOT_FINITE = "not_finite"
    JOINT_LOCK = "joint_lock"


#: Every status word (an engine's integer code for a word is its position here).
STATUSES: tuple[str, ...] = tuple(s.value for s in Status)
#: Positions where the loop is assembled and the pose (S1, S4) is given.
ASSEMBLED: frozenset[str] = frozenset({Status.OK, Status.DEAD_CENTRE, Status.ASSEMBLY_LIMIT,
                                       Status.JOINT_LOCK})
#: Positions where the rates (S4_dot, S4_ddot, transmission) are given as well.
RATES_GIVEN: frozenset[str] = frozenset({Status.OK, Status.DEAD_CENTRE})


def is_status(words: np.ndarray, *allowed: str) -> np.ndarray:
    """Boolean mask, shape ``(n,)``: which of ``words`` (shape ``(n,)``) is one of ``allowed``.

    One elementwise comparison per allowed word, not ``np.isin`` on the words converted to a string array:
    2-6 times faster from one row (the judges classify each row as they close it: 7.5 -> 4 us) to 10^6
    (96 -> 15 ms).
    """
    words = np.asarray(words)
    mask = np.zeros(words.shape, dtype=bool)
    for word in allowed:
        mask |= words == str(word)
    return mask


def demote_non_finite(columns: dict[str, np.ndarray], status: np.ndarray, names: tuple[str, ...],
                      given: dict[str, tuple[str, ...]] | None = None) -> np.ndarray:
    """Status words with every row that claims a non-finite value set to ``not_finite``.

    An engine calls this last, so that no ``ok`` row can carry NaN or inf
    (e.g. ``crank_rpm = 1e308`` overflows the accelerations).  An ``ok`` row must
    be finite in every column of ``names``; a row of another status word ``w``
    must be finite in the columns ``given[w]`` (e.g. ``dead_centre`` in the
    kinematics, ``assembly_limit`` in S1 and S4: the module docstring's table).
    Returns a new object array, shape ``(n,)``; ``columns`` is not changed.
    """
    status = np.asarray(status, dtype=object).copy()
    bad = np.zeros(status.shape[0], dtype=bool)
    for word, required in {Status.OK.value: names, **(given or {})}.items():
        rows = is_status(status, word)
        for name in required:
            bad |= rows & ~np.isfinite(np.asarray(columns[name], dtype=float))
    status[bad] = Status.NOT_FINITE.value
    return status


#: Columns given wherever the pose is (:data:`ASSEMBLED`), besides ``theta1_deg`` and ``S1`` (always given).
POSE_COLUMNS: tuple[str, ...] = ("S4", "closure_condition")
#: Columns given only where the rates are (:data:`RATES_GIVEN`).
RATE_COLUMNS: tuple[str, ...] = ("S4_dot", "S4_ddot", "transmission")


def settle(columns: dict[str, np.ndarray], status: np.ndarray, reactions: tuple[str, ...],
           pose: tuple[str, ...] = POSE_COLUMNS, rates: tuple[str, ...] = RATE_COLUMNS) -> np.ndarray:
    """An engine's last step: final status words, and ``columns`` blanked (NaN) to match them, in place.

    Rows claiming a non-finite value they should give become ``not_finite``
    (:func:`demote_non_finite`: ``ok`` in every column, ``dead_centre`` in
    :data:`POSE_COLUMNS` and :data:`RATE_COLUMNS`, ``assembly_limit`` and ``joint_lock`` in
    :data:`POSE_COLUMNS`); then every column a row's word does not give is set to
    NaN (``reactions`` outside ``ok``, rates outside :data:`RATES_GIVEN`, the pose
    outside :data:`ASSEMBLED`).  Returns the status words, object array, shape ``(n,)``.
    Another mechanism's table names its own ``pose`` and ``rates`` columns (e.g. the RSSR's).
    """
    status = demote_non_finite(columns, status, pose + rates + tuple(reactions), {
        Status.DEAD_CENTRE.value: pose + rates, Status.JOINT_LOCK.value: pose,
        Status.ASSEMBLY_LIMIT.value: pose})
    for names, given in ((reactions, (Status.OK,)), (rates, RATES_GIVEN), (pose, ASSEMBLED)):
        off = ~is_status(status, *given)
        for name in names:
            columns[name][off] = np.nan
    return status


def joint_locked(condition: np.ndarray, universal: bool | np.ndarray) -> np.ndarray:
    """Rows, shape ``(n,)``, where a universal joint at the slider locks: ``universal`` and the
    closure condition ``|u·k4|`` (shape ``(n,)``, NaN where not given) at or above
    :data:`~dualmech.core.thresholds.JOINT_LOCK_CONDITION` (``docs/conventions.md``, "Status words")."""
    with np.errstate(invalid="ignore"):
        return np.asarray(universal, dtype=bool) & (np.asarray(condition, dtype=float)
                                                    >= JOINT_LOCK_CONDITION.value)


def flag_joint_lock(status: np.ndarray, condition: np.ndarray, universal: bool | np.ndarray) -> np.ndarray:
    """Status words with every ``ok`` or ``dead_centre`` row where :func:`joint_locked` set to
    ``joint_lock`` (its rates and reactions are then blanked by :func:`settle`); a new object array."""
    status = np.asarray(status, dtype=object).copy()
    status[joint_locked(condition, universal) & is_status(status, Status.OK, Status.DEAD_CENTRE)] = \
        Status.JOINT_LOCK.value
    return status
