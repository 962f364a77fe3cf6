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
``assembly_limit``  S1, S4      NaN         the rod is (nearly) normal to the slider line:
                                            the closure is singular, rates are unbounded
``branch_jump``     NaN         NaN         the solver converged on the other assembly branch
``not_converged``   NaN         NaN         the solver stopped without meeting its tolerance
``no_assembly``     NaN         NaN         proven: the rod cannot reach the slider line
``not_finite``      NaN         NaN         the arithmetic overflowed (input far out of range)
==================  ==========  ==========  =================================================
"""

from __future__ import annotations

from enum import StrEnum

import numpy as np


class Status(StrEnum):
    """Status of one crank position (module docstring)."""

    OK = "ok"
    DEAD_CENTRE = "dead_centre"
    ASSEMBLY_LIMIT = "assembly_limit"
    BRANCH_JUMP = "branch_jump"
    NOT_CONVERGED = "not_converged"
    NO_ASSEMBLY = "no_assembly"
    NOT_FINITE = "not_finite"


#: Every status word, in order of precedence when several apply.
STATUSES: tuple[str, ...] = tuple(s.value for s in Status)
#: Positions where the loop is assembled and the pose (S1, S4) is given.
ASSEMBLED: frozenset[str] = frozenset({Status.OK, Status.DEAD_CENTRE, Status.ASSEMBLY_LIMIT})
#: Positions where the rates (S4_dot, S4_ddot, transmission) are given as well.
RATES_GIVEN: frozenset[str] = frozenset({Status.OK, Status.DEAD_CENTRE})


def is_status(words: np.ndarray, *allowed: str) -> np.ndarray:
    """Boolean mask, shape ``(n,)``: which of ``words`` (shape ``(n,)``) is one of ``allowed``."""
    return np.isin(np.asarray(words, dtype=str), [str(a) for a in allowed])


def demote_non_finite(columns: dict[str, np.ndarray], status: np.ndarray, names: tuple[str, ...]) -> np.ndarray:
    """Status words with every ``ok`` row that holds a non-finite value in ``names`` set to ``not_finite``.

    An engine calls this last, so that no ``ok`` row can carry NaN or inf
    (e.g. ``crank_rpm = 1e308`` overflows the accelerations).  Returns a new
    object array, shape ``(n,)``; ``columns`` is not changed.
    """
    status = np.asarray(status, dtype=object).copy()
    bad = np.zeros(status.shape[0], dtype=bool)
    for name in names:
        bad |= ~np.isfinite(np.asarray(columns[name], dtype=float))
    status[bad & is_status(status, Status.OK)] = Status.NOT_FINITE.value
    return status
