"""The Exudyn judge's answer on a loop table as the linkages' result table: the ``exudyn`` engine of
``[mechanism] kind = "loop"``, with the shared column names of :mod:`dualmech.models.loop.columns` (settled
by the judge's own status words).
"""

from __future__ import annotations

import numpy as np

from dualmech.models.loop.columns import RESIDUALS, column_names, loop_spec, loop_table
from dualmech.models.loop.description import LoopMechanism
from dualmech.models.tables import LinkageTable
from dualmech.validation.judges.exudyn_loop.continuation import continuation
from dualmech.validation.judges.exudyn_loop.engine import ExudynLoopTable, solve_loop

#: The registry name of this judge.
ENGINE = "exudyn"


def judge_columns(mine: ExudynLoopTable) -> dict[str, np.ndarray]:
    """The judge's answer by the shared column names, each ``(n,)`` (NaN where it gives none);
    ``dynamics_residual`` NaN at every row (no least squares: the multipliers are the reactions)."""
    n = mine.status.shape[0]
    cols = {name: np.asarray(mine.columns.get(name, np.full(n, np.nan)), float)
            for name in column_names(mine.mechanism)}
    cols.update({RESIDUALS[0]: mine.residual, RESIDUALS[1]: np.full(n, np.nan)})
    return cols


def solve_table(mechanism: LoopMechanism) -> LinkageTable:
    """Every drive position of ``mechanism`` judged by Exudyn
    (:func:`~dualmech.validation.judges.exudyn_loop.engine.solve_loop`), as a table;
    ``meta["richardson"]``: each column's Richardson error estimate per row."""
    mine = solve_loop(mechanism)
    return loop_table(ENGINE, mechanism, judge_columns(mine), mine.status,
                      {"richardson": {k: np.asarray(v) for k, v in mine.errors.items()}},
                      not_given=(RESIDUALS[1],))


def close_table(mechanism: LoopMechanism) -> LinkageTable:
    """The judge's own closure alone at every drive position of ``mechanism``
    (:func:`~dualmech.validation.judges.exudyn_loop.continuation.continuation`), as a table: the coordinates,
    the closure's words and residual; no rates or reactions (not given: NaN at every row, claimed by no
    word).  What a crude start is probed with on one row, where a run has no rows to integrate through
    (:mod:`dualmech.validation.judges.presets.run`)."""
    poses, status, residual, _ = continuation(mechanism)
    n = status.shape[0]
    cols = {name: np.full(n, np.nan) for name in column_names(mechanism)}
    for i, pose in enumerate(poses):
        for name, value in ({} if pose is None else pose.named()).items():
            cols[name][i] = value
    cols.update({RESIDUALS[0]: residual, RESIDUALS[1]: np.full(n, np.nan)})
    spec = loop_spec(mechanism)
    return loop_table(ENGINE, mechanism, cols, status, {}, not_given=spec.rates + spec.reactions)
