"""Registry of engines that turn a case into a :class:`~dualmech.core.table.ResultTable`.

Engines are imported lazily, so that ``dualmech solve`` with the in-house
engine never imports Pinocchio or MuJoCo.  Every entry is a function
``solve_case(case) -> ResultTable``.
"""

from __future__ import annotations

from importlib import import_module
from typing import Callable

from dualmech.core.table import ResultTable
from dualmech.models.case import Case

#: engine name -> "module:function"
ENGINES: dict[str, str] = {
    "dualmech": "dualmech.models.slider_crank:solve_case",
    "pinocchio": "dualmech.validation.pinocchio_engine:solve_case",
    "mujoco": "dualmech.validation.mujoco_engine:solve_case",
    "mujoco-sim": "dualmech.validation.mujoco_sim:solve_case",
}


def get_engine(name: str) -> Callable[[Case], ResultTable]:
    """The ``solve_case`` function of engine ``name``."""
    if name not in ENGINES:
        raise ValueError(f"engine: expected one of {', '.join(ENGINES)}, got {name!r}")
    module, func = ENGINES[name].split(":")
    return getattr(import_module(module), func)


def run_engine(name: str, case: Case) -> ResultTable:
    """Solve ``case`` with engine ``name``."""
    return get_engine(name)(case)
