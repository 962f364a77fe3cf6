"""The package layout: imports go downwards only (core < models < validation < cli), docs/architecture.md.

Every ``import`` statement of ``core/``, ``models/`` and ``validation/`` is read with :mod:`ast`,
those inside functions included (a lazy import is still a dependency).  ``cli/``, the top floor,
may import every other one.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: The packages from the lowest floor up; a module may import only its own floor and those below.
FLOORS = ("core", "models", "validation", "cli")
#: The one upward import, by design: the public API's lazy alias dualmech.models.solve ->
#: validation.api.solve (the judges' drivers and their registry live in validation/), imported at first
#: access only.  Any other upward import fails the test.
ALLOWED_UPWARD: dict[str, frozenset[str]] = {
    "models/__init__.py": frozenset({"dualmech.validation"}),
}


def imported_modules(source: str) -> list[tuple[int, str]]:
    """``(line, dotted module)`` of every absolute import in ``source``, nested ones included."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found.append((node.lineno, node.module))
    return found


def upward_imports(floor: str, path: Path, source: str) -> list[str]:
    """The imports of ``source`` (a module of package ``floor``) that reach a higher floor, as messages."""
    higher = FLOORS[FLOORS.index(floor) + 1:]
    rel = path.relative_to(ROOT).as_posix()
    bad = []
    for line, module in imported_modules(source):
        parts = module.split(".")
        if parts[0] != "dualmech" or len(parts) < 2 or parts[1] not in higher:
            continue
        if f"dualmech.{parts[1]}" in ALLOWED_UPWARD.get(rel, frozenset()):
            continue
        bad.append(f"{rel}:{line} imports {module} (a {floor} module may not import {parts[1]})")
    return bad


@pytest.mark.parametrize("floor", FLOORS[:-1])
def test_no_module_imports_a_higher_package(floor: str) -> None:
    bad = []
    for path in sorted((ROOT / floor).rglob("*.py")):
        bad += upward_imports(floor, path, path.read_text())
    assert not bad, "\n".join(bad)


def test_the_check_sees_nested_and_from_imports() -> None:
    """The parser itself: a lazy ``from`` import inside a function is found, a downward one is not."""
    source = ("import numpy\nfrom dualmech.core.dual import Dual\n\n"
              "def f():\n    from dualmech.validation.tolerances import SIM_STROKE\n    return SIM_STROKE\n")
    bad = upward_imports("models", ROOT / "models" / "x.py", source)
    assert bad == ["models/x.py:5 imports dualmech.validation.tolerances (a models module may not import "
                   "validation)"]
    assert upward_imports("core", ROOT / "core" / "x.py", "import dualmech.models.case\n") == [
        "core/x.py:1 imports dualmech.models.case (a core module may not import models)"]


def test_the_command_line_is_the_top_floor() -> None:
    """A validation module reaching up into the command line is caught, as one reaching into models is not."""
    source = "from dualmech.cli.errors import one_line_errors\nfrom dualmech.models.case import load_case\n"
    assert upward_imports("validation", ROOT / "validation" / "x.py", source) == [
        "validation/x.py:1 imports dualmech.cli.errors (a validation module may not import cli)"]
