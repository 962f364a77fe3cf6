"""A tolerance study's spot checks: sampled designs re-solved by the judges, compared like the matrix.

Each picked design is solved by the in-house engine (the reference) and by every judge
(:func:`dualmech.validation.engines.run_engine`), and compared column by column with
:func:`dualmech.validation.compare.compare_case` under the validation matrix's default
tolerances for that judge (``validation/matrix/tolerances.py``, ``DEFAULT_TOLERANCES``; each named in
``validation/tolerances.py``).  A design is picked among those that assemble at least in part,
by the study's seed (:func:`~dualmech.models.tolerance.sampling.judge_picks`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from dualmech.core.table import ResultTable
from dualmech.models.case import Case
from dualmech.models.tolerance.outputs import DesignStatus, design_outputs, output_names
from dualmech.validation import engines
from dualmech.validation.compare import compare_case
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


def spot_check(design: Case, reference: ResultTable, engine: str, judge: ResultTable) -> SpotCheck:
    """Compare ``judge`` (engine ``engine``) with the in-house ``reference`` on one design."""
    mode = design.loads.mode
    checks = compare_case(design.name, mode, reference, judge, COMPARABLE, judge_tolerances(engine))
    worst = max(checks, key=lambda c: c.ratio)
    failures = tuple(f"{c.quantity}: {c.detail or f'ratio {c.ratio:.3g}'}" for c in checks if not c.passed)
    ours, theirs = design_outputs([reference], mode), design_outputs([judge], mode)
    outputs = {n: (float(ours[n][0]), float(theirs[n][0])) for n in output_names(mode)}
    return SpotCheck(design.name, engine, not failures, len(checks), float(worst.ratio), worst.quantity,
                     failures, outputs)


def run_spot_checks(designs: list[Case], judges: tuple[str, ...] = JUDGES,
                    progress: ProgressCallback | None = None) -> list[SpotCheck]:
    """Every judge on every design (the reference solved once per design); ``progress(done, len(designs),
    name)`` after each design."""
    from dualmech.models.slider_crank import solve_case

    out = []
    for k, design in enumerate(designs):
        reference = solve_case(design)
        out += [spot_check(design, reference, e, engines.run_engine(e, design)) for e in judges]
        if progress is not None:
            progress(k + 1, len(designs), design.name)
    return out


def candidates(status: np.ndarray) -> np.ndarray:
    """Indices of designs that assemble at least in part (worth judging)."""
    return np.flatnonzero(np.asarray(status, dtype=str) != DesignStatus.NO_ASSEMBLY.value)
