"""The rigid MuJoCo judge's answer on a loop table as the linkages' result table: the ``mujoco`` engine of
``[mechanism] kind = "loop"`` in :mod:`dualmech.validation.linkages.engines`.  Its columns are already the
shared names (:mod:`dualmech.models.loop.columns`); the table adds the key and settles the values by the
judge's own status words.  No ``mujoco-sim`` here: the generated MJCF cuts the loop with a weld that would
lock the cut joint (``docs/conventions.md``, "Loop tables"), so it is not a model for MuJoCo's simulation.
"""

from __future__ import annotations

import numpy as np

from dualmech.models.linkages.table import LinkageTable
from dualmech.models.loop.columns import loop_table
from dualmech.models.loop.description import LoopMechanism
from dualmech.validation.judges.mujoco_loop.engine import solve_loop

#: The registry name of this judge.
ENGINE = "mujoco"


def solve_table(mechanism: LoopMechanism) -> LinkageTable:
    """Every drive position of ``mechanism`` judged by rigid MuJoCo
    (:func:`~dualmech.validation.judges.mujoco_loop.engine.solve_loop`), as a table; ``meta["iterations"]``:
    Newton's iterations per position."""
    mine = solve_loop(mechanism)
    columns = {**mine.columns, "residual": mine.residual, "dynamics_residual": mine.dynamics_residual}
    return loop_table(ENGINE, mechanism, columns, mine.status, {"iterations": np.asarray(mine.iterations)})
