"""A tolerance study's spot checks: sampled designs re-solved by the judges, compared like the matrix.

Each picked design is solved by the in-house engine (the reference) and by every judge
(:func:`dualmech.validation.engines.run_engine`, by the design's kind: a loop table's judges are generated
from its table), and compared column by column as ``dualmech validate`` compares them, under the
validation matrix's default tolerances for that judge (``validation/matrix/tolerances.py``,
``DEFAULT_TOLERANCES``; each named in ``validation/tolerances.py``): a slider crank by
:func:`dualmech.validation.compare.compare_case`, another kind by its TableSpec
(:func:`dualmech.validation.compare.tables.judge_checks`).  A design is picked among those that assemble at
least in part, by the study's seed (:func:`~dualmech.models.tolerance.sampling.judge_picks`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from dualmech.core.table import ColumnTable
from dualmech.models.case import Case
from dualmech.models.kinds import SLIDER_CRANK, kind_of
from dualmech.models.linkages import table_spec
from dualmech.models.tolerance.outputs import DesignStatus
from dualmech.models.tolerance.plan import in_house, plan_of
from dualmech.validation import engines
from dualmech.validation.compare import Check, compare_case
from dualmech.validation.compare.tables import judge_checks
from dualmech.validation.matrix import COMPARABLE, resolve_tolerances

if TYPE_CHECKING:
    from dualmech.validation.progress import ProgressCallback

#: The judges of a tolerance study: the exact rigid-body engines (the simulation's tolerances are
#: far looser than a design's spread, so it would not tell designs apart).
JUDGES: tuple[str, ...] = ("pinocchio", "mujoco")


@dataclass(frozen=True)
class SpotCheck:
    """One judge on one design: every failed check, the worst ratio, and the outputs both give."""

    design: str
    engine: str
    passed: bool
    n_checks: int
    worst_ratio: float
    worst_quantity: str
    failures: tuple[str, ...]
    outputs: dict[str, tuple[float, float]]  # output -> (dualmech, judge)

    def to_dict(self) -> dict:
        """JSON-ready form."""
        return {"design": self.design, "engine": self.engine, "passed": self.passed,
                "n_checks": self.n_checks,
                "worst_ratio": self.worst_ratio, "worst_quantity": self.worst_quantity,
                "failures": list(self.failures), "outputs": {k: list(v) for k, v in self.outputs.items()}}


def judge_tolerances(engine: str) -> dict:
    """The matrix's default tolerances of judge ``engine`` for every comparable column and the stroke."""
    return resolve_tolerances(None, (engine,), COMPARABLE)[engine]


def _slider_crank_checks(design: Case, reference: ColumnTable, engine: str,
                         judge: ColumnTable) -> list[Check]:
    tolerances = judge_tolerances(engine)
    return compare_case(design.name, design.loads.mode, reference, judge, COMPARABLE, tolerances)


def _table_checks(design: Any, reference: ColumnTable, engine: str, judge: ColumnTable) -> list[Check]:
    return judge_checks(design.name, reference, judge, table_spec(kind_of(design), design))[0]


def spot_check(design: Any, reference: ColumnTable, engine: str, judge: ColumnTable) -> SpotCheck:
    """Compare ``judge`` (engine ``engine``) with the in-house ``reference`` on one design (a checked record
    of any kind)."""
    compare = _slider_crank_checks if kind_of(design) == SLIDER_CRANK else _table_checks
    checks = compare(design, reference, engine, judge)
    worst = max(checks, key=lambda c: c.ratio if np.isfinite(c.ratio) else np.inf)
    failures = tuple(f"{c.quantity}: {c.detail or f'ratio {c.ratio:.3g}'}" for c in checks if not c.passed)
    plan = plan_of(design)
    ours, theirs = plan.table_outputs([reference], design), plan.table_outputs([judge], design)
    outputs = {n: (float(ours[n][0]), float(theirs[n][0])) for n in plan.outputs(design)}
    return SpotCheck(design.name, engine, not failures, len(checks), float(worst.ratio), worst.quantity,
                     failures, outputs)


def run_spot_checks(designs: list[Any], judges: tuple[str, ...] = JUDGES,
                    progress: ProgressCallback | None = None) -> list[SpotCheck]:
    """Every judge on every design (checked records of any kind; the reference solved once per design);
    ``progress(done, len(designs), name)`` after each design."""
    out = []
    for k, design in enumerate(designs):
        reference = in_house(design)(design)
        out += [spot_check(design, reference, e, engines.run_engine(e, design)) for e in judges]
        if progress is not None:
            progress(k + 1, len(designs), design.name)
    return out


def candidates(status: np.ndarray) -> np.ndarray:
    """Indices of designs that assemble at least in part (worth judging)."""
    return np.flatnonzero(np.asarray(status, dtype=str) != DesignStatus.NO_ASSEMBLY.value)
