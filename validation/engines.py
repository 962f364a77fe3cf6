"""Registry of engines that turn a case into a :class:`~dualmech.core.table.ResultTable`.

Engines are imported lazily, so that ``dualmech solve`` with the in-house
engine never imports Pinocchio or MuJoCo.  Every entry is a function
``solve_case(case) -> ResultTable``.
"""

from __future__ import annotations

from importlib import import_module
from typing import Callable

from dualmech.core.table import ResultTable
from dualmech.models.case import Case, case_from_dict

#: engine name -> "module:function"
ENGINES: dict[str, str] = {
    "dualmech": "dualmech.models.slider_crank:solve_case",
    "pinocchio": "dualmech.validation.pinocchio_engine:solve_case",
    "mujoco": "dualmech.validation.mujoco_engine:solve_case",
    "mujoco-sim": "dualmech.validation.mujoco_sim:solve_case",
}


#: Engines run in a thread of the running process beside a pool's workers (under their registered function
#: only: a test's fake of the same name runs in a worker): the in-house kernel is compiled, releases the GIL
#: and takes ~2 ms a case, while loading it (numba) costs a worker ~0.6 s of CPU; so it is loaded once, in
#: the process that runs the matrix, and the workers run the judges ...
IN_PROCESS_ENGINES: dict[str, str] = {"dualmech": ENGINES["dualmech"]}
#: ... for cases of at most this many crank positions (~0.1 s of the kernel): a thread cannot be ended, so
#: an interrupted run waits for the one it is running; a larger case runs in a worker, which can be.
IN_PROCESS_MAX_POSITIONS = 100_000


def runs_here(engine: str, spec: str, raw: dict) -> bool:
    """Whether the task of ``engine`` under ``spec`` on the case table ``raw`` runs in the running process
    beside a pool (:data:`IN_PROCESS_ENGINES`, :data:`IN_PROCESS_MAX_POSITIONS`; a table that does not
    parse runs in a worker, which stores its error)."""
    if IN_PROCESS_ENGINES.get(engine) != spec:
        return False
    try:
        return case_from_dict(raw).motion.angles_deg.size <= IN_PROCESS_MAX_POSITIONS
    except ValueError:
        return False


def get_engine(name: str) -> Callable[[Case], ResultTable]:
    """The ``solve_case`` function of engine ``name``."""
    if name not in ENGINES:
        raise ValueError(f"engine: expected one of {', '.join(ENGINES)}, got {name!r}")
    module, func = ENGINES[name].split(":")
    return getattr(import_module(module), func)


def run_engine(name: str, case: Case) -> ResultTable:
    """Solve ``case`` with engine ``name``."""
    return get_engine(name)(case)
