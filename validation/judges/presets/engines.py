"""The registered engines of the RSSR and RCCC that are generated judges (``validation/engines.py``): each
case run through its joint table (:func:`~dualmech.validation.judges.presets.run.judge_case`) by the
Pinocchio, rigid MuJoCo or Exudyn judge of a loop table, or simulated by MuJoCo (:func:`simulate_case`).
"""

from __future__ import annotations

from dualmech.models.linkages.rccc_case import RcccCase
from dualmech.models.linkages.rssr_case import RssrCase
from dualmech.models.tables import LinkageTable
from dualmech.validation.judges.exudyn_loop.table import close_table
from dualmech.validation.judges.exudyn_loop.table import solve_table as exudyn_table
from dualmech.validation.judges.mujoco_loop.table import solve_sim_table
from dualmech.validation.judges.mujoco_loop.table import solve_table as mujoco_table
from dualmech.validation.judges.pinocchio_loop.table import solve_table as pinocchio_table
from dualmech.validation.judges.presets.run import crude_start, judge_case, kind_parts
from dualmech.validation.judges.presets.starts import with_start


def simulate_case(case: RssrCase | RcccCase) -> LinkageTable:
    """The ``mujoco-sim`` engine of an RSSR or RCCC case: the generated simulated judge
    (:func:`~dualmech.validation.judges.mujoco_loop.table.solve_sim_table`) on the case's table, every joint
    started at the first crude start from which the rigid generated MuJoCo judge answers the first row on
    the branch (:func:`~dualmech.validation.judges.presets.run.crude_start`; with none, the first crude
    start: the simulation's words then say where it is), as the mechanism's table (``dynamics_residual`` not
    given: the simulation has no least squares).  The simulation plans its runs from its own rigid closure,
    so one start serves every row (the engine runs only on cases whose every row assembles:
    :func:`~dualmech.validation.engines.solves`).  ``meta``: the simulation's (time step, steps per degree,
    run-in, servo gains, the largest drive lag, ``L_ref``).
    """
    table, _, columns_of, _, _, _ = kind_parts(case)
    mechanism = table(case)
    starts, _, _ = crude_start(case, mechanism, 0, mujoco_table)
    return columns_of(case, solve_sim_table(with_start(mechanism, starts)), ("dynamics_residual",))


def simulate_rssr(case: RssrCase) -> LinkageTable:
    """The ``mujoco-sim`` engine of an RSSR case (:func:`simulate_case`)."""
    return simulate_case(case)


def simulate_rccc(case: RcccCase) -> LinkageTable:
    """The ``mujoco-sim`` engine of an RCCC case (:func:`simulate_case`)."""
    return simulate_case(case)


def solve_pinocchio_rssr(case: RssrCase) -> LinkageTable:
    """The ``pinocchio`` engine of an RSSR case: :func:`~dualmech.validation.judges.presets.run.judge_case`
    with the generated Pinocchio judge
    (:func:`~dualmech.validation.judges.pinocchio_loop.table.solve_table`)."""
    return judge_case(case, "pinocchio", pinocchio_table)


def solve_pinocchio_rccc(case: RcccCase) -> LinkageTable:
    """The ``pinocchio`` engine of an RCCC case (as :func:`solve_pinocchio_rssr`)."""
    return judge_case(case, "pinocchio", pinocchio_table)


def solve_mujoco_rssr(case: RssrCase) -> LinkageTable:
    """The ``mujoco`` engine of an RSSR case: :func:`~dualmech.validation.judges.presets.run.judge_case`
    with the generated rigid MuJoCo judge
    (:func:`~dualmech.validation.judges.mujoco_loop.table.solve_table`)."""
    return judge_case(case, "mujoco", mujoco_table)


def solve_mujoco_rccc(case: RcccCase) -> LinkageTable:
    """The ``mujoco`` engine of an RCCC case (as :func:`solve_mujoco_rssr`)."""
    return judge_case(case, "mujoco", mujoco_table)


def solve_exudyn_rssr(case: RssrCase) -> LinkageTable:
    """The ``exudyn`` engine of an RSSR case: :func:`~dualmech.validation.judges.presets.run.judge_case`
    with the Exudyn judge (:func:`~dualmech.validation.judges.exudyn_loop.table.solve_table`), each crude
    start probed by its own closure alone
    (:func:`~dualmech.validation.judges.exudyn_loop.table.close_table`); ``dynamics_residual`` not given
    (NaN: the multipliers are the reactions, no least squares).  ``meta``: ``restarts``."""
    return judge_case(case, "exudyn", exudyn_table, close_table, ("dynamics_residual",))


def solve_exudyn_rccc(case: RcccCase) -> LinkageTable:
    """The ``exudyn`` engine of an RCCC case (as :func:`solve_exudyn_rssr`)."""
    return judge_case(case, "exudyn", exudyn_table, close_table, ("dynamics_residual",))
