"""A deliberate fault in one engine, where the matrix runner calls it (in this process: ``jobs=1``)."""

from __future__ import annotations

from importlib import import_module
from typing import Any, Callable

import pytest

from dualmech.validation.engines import ENGINES


def fault_engine(monkeypatch: pytest.MonkeyPatch, engine: str, fault: Callable[[Any], Any],
                 kinds: tuple[str, ...] = ()) -> None:
    """Make the tables ``engine`` gives for cases of ``kinds`` (default every kind it solves) pass through
    ``fault`` (table -> table), by replacing its registered functions (:data:`ENGINES`)."""
    for kind, spec in ENGINES[engine].items():
        if kinds and kind not in kinds:
            continue
        module, name = spec.split(":")
        home = import_module(module)
        real = getattr(home, name)
        monkeypatch.setattr(home, name, lambda case, real=real: fault(real(case)))
