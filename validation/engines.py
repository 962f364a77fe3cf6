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
#: only: a test's fake of the same name runs in a worker), each on cases of at most so many crank positions:
#: a thread cannot be ended, so an interrupted run waits for the task it is running (at most ~0.2 s under
#: these bounds); a larger case runs in a worker, which can be ended.  Both are engines whose library costs
#: a process more to load than the thesis matrix's tasks cost to run, so it is loaded once, here, instead of
#: in every worker:
#:
#: * the in-house kernel: compiled, releases the GIL, ~2 ms a thesis case (10^5 positions: ~0.1 s); loading
#:   numba and the cached kernel costs a process ~0.85 s of CPU;
#: * Pinocchio: ~30 ms a thesis case (~85 us a position: 2000 positions ~0.2 s); importing it costs a process
#:   0.23 s of CPU.
IN_PROCESS_ENGINES: dict[str, tuple[str, int]] = {
    "dualmech": (ENGINES["dualmech"], 100_000),
    "pinocchio": (ENGINES["pinocchio"], 2_000),
}


def runs_here(engine: str, spec: str, raw: dict) -> bool:
    """Whether the task of ``engine`` under ``spec`` on the case table ``raw`` runs in the running process
    beside a pool (:data:`IN_PROCESS_ENGINES`; a table that does not parse runs in a worker, which stores
    its error)."""
    here, most = IN_PROCESS_ENGINES.get(engine, (None, 0))
    if here != spec:
        return False
    try:
        return case_from_dict(raw).motion.angles_deg.size <= most
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
