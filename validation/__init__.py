"""Cross-validation: the judges' drivers, the matrix, comparison, baseline, JUnit and report.

Public names (resolved at first access, so importing this package imports no engine):

- :func:`validate` -- run and compare a matrix, a case file or a preset, as ``dualmech validate`` does;
  returns a :class:`ValidationRun` (``.verdict``, ``.comparison``, ``.results``, ``.write_report()``).
- :func:`solve` -- one case on one engine (also ``dualmech.models.solve``).
- :data:`ENGINES` -- the engine names and their drivers.

Example::

    import dualmech.validation
    run = dualmech.validation.validate("thesis/a4-30-s1-3", outdir="runs/a4-30")
    print(run.verdict)        # PASS, FAIL or INCOMPLETE
"""

from __future__ import annotations

from importlib import import_module
from typing import Any

__all__ = ["ENGINES", "ValidationRun", "solve", "validate", "validate_linkages"]

#: public name -> the module that defines it
_HOMES: dict[str, str] = {
    "ENGINES": "dualmech.validation.engines",
    "ValidationRun": "dualmech.validation.api",
    "solve": "dualmech.validation.api",
    "validate": "dualmech.validation.api",
    "validate_linkages": "dualmech.validation.api",
}


def __getattr__(name: str) -> Any:
    """The public names of :data:`__all__`, imported from their module at first access."""
    if name not in _HOMES:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(import_module(_HOMES[name]), name)
