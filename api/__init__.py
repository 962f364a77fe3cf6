"""dualmech: exact joint reactions of single spatial loops, judged by Pinocchio, MuJoCo and Exudyn.

The package face: every name a user needs, resolved at first use, so that ``import dualmech`` loads no
engine (no Pinocchio, MuJoCo, numba or matplotlib) and ``dualmech.solve`` with the in-house engine never
imports a judge.  ``docs/conventions.md`` defines the case format, units, frames, signs and every output
column; ``docs/api.md`` lists these names with their signatures.

Example (a sweep of the slider-axis offset, no files written)::

    import dualmech

    base = dualmech.load_case("thesis/ideal")               # or dualmech.Case(...), a case file
    for a4 in (0.0, 10.0, 20.0, 30.0):
        table = dualmech.solve(base.with_values({"geometry.slider_offset": a4}))
        df = table.to_pandas()                              # one row per crank position
        print(a4, df["S4"].max() - df["S4"].min())          # the slider stroke, inches

Names
-----
Case, case_from_dict, load_case, preset_names, CaseError
    A design: built in code, from a table, from a case file or a bundled preset; the error of a bad one.
solve
    One case on one engine (``"dualmech"``, ``"pinocchio"``, ``"mujoco"``, ``"mujoco-sim"``,
    ``"exudyn"``): a :class:`ResultTable`.
validate, ValidationRun
    A validation matrix (or one case on every engine): run, compared, ``.write_report()``.
simulate, Simulation
    Forward dynamics of any kind: the input's equation of motion integrated under given loads.
tolerance_study, ToleranceStudy
    Monte Carlo and exact sensitivities of a design under manufacturing tolerances, judged and reported.
ResultTable, Status, ENGINES
    The one result contract of every engine, the status word of a row, the engines' names.
"""

from __future__ import annotations

from importlib import import_module
from importlib.metadata import version
from typing import TYPE_CHECKING, Any

__version__: str = version("dualmech")

#: public name -> the module that defines it (imported at the name's first use)
_HOMES: dict[str, str] = {
    "Case": "dualmech.models.case",
    "CaseError": "dualmech.models.inputs",
    "case_from_dict": "dualmech.models.case",
    "load_case": "dualmech.models.case",
    "preset_names": "dualmech.models.case",
    "solve": "dualmech.verbs",
    "validate": "dualmech.verbs",
    "ValidationRun": "dualmech.verbs",
    "tolerance_study": "dualmech.verbs",
    "ToleranceStudy": "dualmech.verbs",
    "simulate": "dualmech.verbs",
    "Simulation": "dualmech.models.simulation",
    "ResultTable": "dualmech.core.table",
    "Status": "dualmech.core.status",
    "ENGINES": "dualmech.validation.engines",
}

__all__ = ["ENGINES", "Case", "CaseError", "ResultTable", "Simulation", "Status", "ToleranceStudy",
           "ValidationRun", "__version__", "case_from_dict", "load_case", "preset_names", "simulate", "solve",
           "tolerance_study", "validate"]

if TYPE_CHECKING:  # the same names, for type checkers and the documentation's static reader
    from dualmech.core.status import Status
    from dualmech.core.table import ResultTable
    from dualmech.models.case import Case, case_from_dict, load_case, preset_names
    from dualmech.models.inputs import CaseError
    from dualmech.models.simulation import Simulation
    from dualmech.validation.engines import ENGINES
    from dualmech.verbs import ToleranceStudy, ValidationRun, simulate, solve, tolerance_study, validate


def __getattr__(name: str) -> Any:
    """A public name, from its home module at first access (module docstring)."""
    if name not in _HOMES:
        raise AttributeError(f"module 'dualmech' has no attribute {name!r}")
    value = getattr(import_module(_HOMES[name]), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_HOMES})
