"""The outcome of a comparison: one :class:`Check` per (case, engine, quantity), and the run's
:class:`Verdict`.

The rules that produce them are in :mod:`~dualmech.validation.compare` (package docstring).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from enum import StrEnum

import numpy as np

from dualmech.core.status import Status
from dualmech.core.table import FORCE_COLUMNS, MOMENT_COLUMNS
from dualmech.validation.matrix import ResolvedTolerance

#: Unit group of each comparable column: relative differences share one scale per group.
UNIT_GROUP: dict[str, str] = {
    "S1": "length", "S4": "length", "S4_dot": "velocity", "S4_ddot": "acceleration",
    "transmission": "ratio",
    **{c: "force" for c in FORCE_COLUMNS},
    **{c: "moment" for c in MOMENT_COLUMNS},
}
#: Columns given under each status word (``docs/conventions.md``, "Status words").
POSE_COLUMNS: tuple[str, ...] = ("S1", "S4")
RATE_COLUMNS: tuple[str, ...] = ("S4_dot", "S4_ddot", "transmission")
#: The column whose rows count as "assembled" (the stroke, and what a check reports as excluded).
STROKE_PROXY = "S4"
#: Status words that are verdicts about the mechanism (the others are engine failures).
VERDICTS: frozenset[str] = frozenset(
    {Status.OK, Status.DEAD_CENTRE, Status.ASSEMBLY_LIMIT, Status.JOINT_LOCK, Status.NO_ASSEMBLY}
)
#: Pseudo-quantities of :class:`Check` besides the table columns.
STROKE, STATUS, ENGINE = "stroke", "status", "engine"
#: The words every check whose tolerance was widened near a universal joint's lock carries in its detail
#: (:mod:`~dualmech.validation.compare.joint_lock`; the report and the summary look for them).
NEAR_JOINT_LOCK = "near joint lock"
#: The only declared expectation a matrix case may carry (``[[sweep]] expect = ...``).
EXPECT_NO_ASSEMBLY = "no_assembly"


class Verdict(StrEnum):
    """Outcome of a whole run."""

    PASS = "PASS"
    FAIL = "FAIL"
    INCOMPLETE = "INCOMPLETE"


@dataclass(frozen=True)
class Check:
    """One verdict: a judge's ``quantity`` on one case against the reference.

    Attributes
    ----------
    case, engine, quantity : str
        Matrix case id, engine, and a column name, ``"stroke"``, ``"status"``
        (status agreement; for the reference engine, its own failures) or
        ``"engine"`` (the engine ran).
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
        Rows compared; rows not compared but accounted for (dead centres, positions
        both engines agree do not assemble); rows that disagree or fail.
    passed : bool
    detail : str
        One line for reports (why it failed, what was excluded).
    incomplete : bool
        The check failed because work is missing (not run), not because of a result.
    odd_one_out : str
        Where three or more engines compare the quantity and this check failed: the engine that
        disagrees with the others (:mod:`~dualmech.validation.compare.odd_one_out`), else ``""``.
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
    incomplete: bool = False
    odd_one_out: str = ""

    @property
    def ratio(self) -> float:
        """``max_rel / tolerance`` (``inf`` for a failure without a number, 0 if nothing compared)."""
        if not self.passed and not np.isfinite(self.max_rel):
            return float("inf")
        if not np.isfinite(self.max_rel):
            return 0.0
        return self.max_rel / self.tolerance.value if self.tolerance.value > 0 else (
            0.0 if self.max_rel == 0 else float("inf"))

    @property
    def near_joint_lock(self) -> bool:
        """Whether the check's tolerance was widened near a universal joint's lock (its detail says so)."""
        return NEAR_JOINT_LOCK in self.detail

    def to_dict(self) -> dict:
        """JSON-ready form."""
        d = asdict(self)
        d["tolerance"] = asdict(self.tolerance)
        return d


@dataclass(frozen=True)
class Pair:
    """Two engines' agreement over a run's cases, per column group
    (:mod:`~dualmech.validation.compare.pairs`).

    Attributes
    ----------
    one, other : str
        The engines, ``one`` earlier in the matrix's order (in the reference's place).
    verdict : bool
        Whether ``one`` is the reference: the pair's checks are then the gate's (else informative).
    cells : dict
        Column group (:data:`~dualmech.validation.compare.pairs.GROUPS`) -> the pair's check of the
        largest ratio to tolerance over every case and column of the group (a failing check first).
    cases : int
        Cases both engines answered (one ``status`` check each).
    status_rows : int
        Rows, over those cases, whose statuses the status rules do not accept, or where an engine failed.
    """

    one: str
    other: str
    verdict: bool
    cells: dict[str, Check]
    cases: int
    status_rows: int

    def to_dict(self) -> dict:
        """JSON-ready form (``summary.json``)."""
        return {"one": self.one, "other": self.other, "verdict": self.verdict, "cases": self.cases,
                "status_rows": self.status_rows, "cells": {g: c.to_dict() for g, c in self.cells.items()}}


#: One judge on one case, row by row: theta1_deg, worst kinematic r_i, worst reaction r_i, each ``(n,)``.
RowDifferences = tuple[np.ndarray, np.ndarray, np.ndarray]


@dataclass(frozen=True)
class Comparison:
    """Every check of a run, and the strokes and dead-centre counts per case and engine."""

    checks: tuple[Check, ...]
    strokes: dict[str, dict[str, float]] = field(default_factory=dict)  # case -> engine -> stroke
    dead_centres: dict[str, dict[str, int]] = field(default_factory=dict)  # case -> engine -> rows
    errors: dict[str, dict[str, str]] = field(default_factory=dict)  # case -> engine -> message
    #: case -> judge -> (theta1_deg, worst kinematic r_i, worst reaction r_i) per row, each ``(n,)``: the
    #: gate's own relative differences, kept for the report's difference figures (NaN: nothing compared)
    row_differences: dict[str, dict[str, RowDifferences]] = field(default_factory=dict)
    #: every pair of engines that answered a case, measured as the gate measures a judge (the report's pair
    #: table, :mod:`~dualmech.validation.compare.pairs`)
    pairs: tuple[Pair, ...] = ()

    @property
    def verdict(self) -> Verdict:
        """``FAIL`` if any check failed on a result, else ``INCOMPLETE`` if work is missing, else ``PASS``."""
        failed = [c for c in self.checks if not c.passed]
        if any(not c.incomplete for c in failed):
            return Verdict.FAIL
        if failed or not self.checks:
            return Verdict.INCOMPLETE
        return Verdict.PASS

    @property
    def passed(self) -> bool:
        return self.verdict is Verdict.PASS

    @property
    def missing(self) -> list[Check]:
        """The checks that failed because work is missing."""
        return [c for c in self.checks if c.incomplete]

    def failures(self) -> list[Check]:
        """Failing checks, worst first within each case."""
        return [c for c in self.checks if not c.passed]

    def for_engine(self, case: str, engine: str) -> list[Check]:
        """The checks of one (case, engine)."""
        return [c for c in self.checks if c.case == case and c.engine == engine]
