"""The mechanism and its case format; with :func:`solve`, the start of dualmech's Python API.

Example (the README's "Python API")::

    import dualmech.models
    case = dualmech.models.load_case("thesis/a4-30-s1-3")   # a case TOML file or a preset name
    table = dualmech.models.solve(case, engine="pinocchio")  # a ResultTable, one row per crank position
    df = table.to_pandas()                                   # or .to_numpy(), .to_polars()

Public names: :class:`Case`, :func:`load_case`, :func:`preset_names` (:mod:`dualmech.models.case`) and
:func:`solve`.  ``solve`` lives in :mod:`dualmech.validation.api`, beside the engine registry, because
three of its four engines (Pinocchio, MuJoCo, MuJoCo simulation) are validation drivers and ``models/``
may not import ``validation/`` at module level (``tests/test_layout.py``); it is resolved here at first
access, so ``import dualmech.models`` stays cheap (no Pinocchio, MuJoCo or matplotlib).
"""

from __future__ import annotations

from typing import Any

from dualmech.models.case import Case, load_case, preset_names

__all__ = ["Case", "load_case", "preset_names", "solve"]


def __getattr__(name: str) -> Any:
    """``solve``, from :mod:`dualmech.validation.api` at first access (module docstring)."""
    if name == "solve":
        from dualmech.validation.api import solve

        return solve
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
