"""The Pinocchio judge's answer on a loop table as the linkages' result table: the ``pinocchio`` engine of
``[mechanism] kind = "loop"`` in :mod:`dualmech.validation.engines`, with the shared column names of
:mod:`dualmech.models.loop.columns` (settled by the judge's own status words).
"""

from __future__ import annotations

import numpy as np

from dualmech.models.loop.columns import coordinate_names, effort_names, loop_table, wrench_columns
from dualmech.models.loop.description import LoopMechanism
from dualmech.models.tables import LinkageTable
from dualmech.validation.judges.pinocchio_loop.engine import PinocchioLoopTable, solve_loop

#: The registry name of this judge.
ENGINE = "pinocchio"


def judge_columns(mine: PinocchioLoopTable) -> dict[str, np.ndarray]:
    """The judge's answer by the shared column names, each ``(n,)`` (NaN where it gives none)."""
    n = mine.status.shape[0]
    missing = np.full(n, np.nan)  # no position closed: the judge's dicts are empty
    cols: dict[str, np.ndarray] = {}
    for name in coordinate_names(mine.mechanism):
        cols.update({name: mine.values.get(name, missing), f"{name}_dot": mine.rates.get(name, missing),
                     f"{name}_ddot": mine.accels.get(name, missing)})
    cols.update({f"effort_{e}": mine.efforts.get(e, missing) for e in effort_names(mine.mechanism)})
    cols.update(wrench_columns(mine.force, mine.moment), residual=mine.residual,
                dynamics_residual=mine.dynamics_residual)
    return cols


def solve_table(mechanism: LoopMechanism) -> LinkageTable:
    """Every drive position of ``mechanism`` judged by Pinocchio
    (:func:`~dualmech.validation.judges.pinocchio_loop.engine.solve_loop`), as a table;
    ``meta["iterations"]``: the closure's iterations per position."""
    mine = solve_loop(mechanism)
    return loop_table(ENGINE, mechanism, judge_columns(mine), mine.status,
                      {"iterations": np.asarray(mine.iterations)})
