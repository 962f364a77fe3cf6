"""The rigid MuJoCo judge's answer on a loop table as the linkages' result table: the ``mujoco`` engine of
``[mechanism] kind = "loop"`` in :mod:`dualmech.validation.engines`.  Its columns are already the
shared names (:mod:`dualmech.models.loop.columns`); the table adds the key and settles the values by the
judge's own status words.  The ``mujoco-sim`` engine of the same kind is MuJoCo's simulation of the table
(:mod:`~dualmech.validation.judges.mujoco_loop.simulation`: its own model, the ground cut by a soft weld).
"""

from __future__ import annotations

import numpy as np

from dualmech.models.loop.columns import loop_table
from dualmech.models.loop.description import LoopMechanism
from dualmech.models.tables import LinkageTable
from dualmech.validation.judges.mujoco_loop.engine import solve_loop
from dualmech.validation.judges.mujoco_loop.simulation import solve_loop_sim

#: The registry names of the rigid judge and of the simulation.
ENGINE, SIM_ENGINE = "mujoco", "mujoco-sim"


def solve_table(mechanism: LoopMechanism) -> LinkageTable:
    """Every drive position of ``mechanism`` judged by rigid MuJoCo
    (:func:`~dualmech.validation.judges.mujoco_loop.engine.solve_loop`), as a table; ``meta["iterations"]``:
    Newton's iterations per position."""
    mine = solve_loop(mechanism)
    columns = {**mine.columns, "residual": mine.residual, "dynamics_residual": mine.dynamics_residual}
    return loop_table(ENGINE, mechanism, columns, mine.status, {"iterations": np.asarray(mine.iterations)})


def solve_sim_table(mechanism: LoopMechanism) -> LinkageTable:
    """Every drive position of ``mechanism`` simulated by MuJoCo
    (:func:`~dualmech.validation.judges.mujoco_loop.simulation.solve_loop_sim`), as a table; ``meta``: the
    simulation's (time step, steps per degree, run-in, servo gains, largest drive lag, ``L_ref``).
    ``residual`` is the weld's gap; there is no ``dynamics_residual`` (NaN: no least squares)."""
    mine = solve_loop_sim(mechanism)
    columns = {**mine.columns, "residual": mine.residual, "dynamics_residual": mine.dynamics_residual}
    return loop_table(SIM_ENGINE, mechanism, columns, mine.status, dict(mine.meta),
                      not_given=("dynamics_residual",))
