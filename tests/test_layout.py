"""The package layout: imports go downwards only (core < models < validation < api, cli; architecture.md);
the house's size limits (issue 16): no module over 400 lines, no function over 60; and the tests' folders
mirror the package folders they test.

Every ``import`` statement of ``core/``, ``models/`` and ``validation/`` is read with :mod:`ast`,
those inside functions included (a lazy import is still a dependency).  ``cli/``, the top floor,
may import every other one.  Every module of the four packages and of ``tests/`` is measured: its
lines, and each function's (``def`` line to last line, methods and nested functions included).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: The packages from the lowest floor up; a module may import only its own floor and those below.  ``api``
#: is the package face (``import dualmech``), beside the command line on the top floor.
FLOORS = ("core", "models", "validation", "api", "cli")
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
        # ``dualmech`` itself is the face, api/; ``dualmech.X`` is package X
        target = "api" if parts == ["dualmech"] else parts[1] if parts[0] == "dualmech" else None
        if target not in higher:
            continue
        bad.append(f"{rel}:{line} imports {module} (a {floor} module may not import {target})")
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


def test_the_package_face_is_above_validation() -> None:
    """``import dualmech`` (the face, api/) from a lower floor is caught like any upward import."""
    source = "import dualmech\nimport dualmech.core.dual\n"
    assert upward_imports("models", ROOT / "models" / "x.py", source) == [
        "models/x.py:1 imports dualmech (a models module may not import api)"]


def test_the_command_line_is_the_top_floor() -> None:
    """A validation module reaching up into the command line is caught, as one reaching into models is not."""
    source = "from dualmech.cli.errors import one_line_errors\nfrom dualmech.models.case import load_case\n"
    assert upward_imports("validation", ROOT / "validation" / "x.py", source) == [
        "validation/x.py:1 imports dualmech.cli.errors (a validation module may not import cli)"]


#: What a command would import to ask a case "is this a linkage?": the linkages' packages, and the names
#: that single out a kind.  The command line reads a case of any kind (models/catalogue/) and does the
#: rest by the kind table (models/kinds.py: KIND_HOMES) and the engine registry (issue 32).
KIND_QUESTIONS = ("dualmech.models.linkages", "SLIDER_CRANK", "LINKAGE_KINDS", "is_linkage",
                  "is_listed_source")


def kind_questions(path: Path, source: str) -> list[str]:
    """The imports of ``source`` (a module at ``path``) that single out a kind, as messages."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ImportFrom) and node.module:
            names = [node.module, *(f"{node.module}.{a.name}" for a in node.names)]
        elif isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        else:
            continue
        for name in names:
            if any(name == q or name.startswith(q + ".") or name.endswith("." + q) for q in KIND_QUESTIONS):
                found.append(f"{path.relative_to(ROOT)}:{node.lineno} imports {name}")
    return found


def test_no_command_asks_whether_a_case_is_a_linkage() -> None:
    """Seen failing before the fix: cli/solve.py and cli/simulate.py imported is_linkage, cli/validate.py
    is_linkage_source."""
    bad = [m for path in sorted((ROOT / "cli").rglob("*.py")) for m in kind_questions(path, path.read_text())]
    assert not bad
    lazy = "def f():\n    from dualmech.models.linkages import is_linkage\n"
    assert kind_questions(ROOT / "cli" / "x.py", lazy) == [
        "cli/x.py:2 imports dualmech.models.linkages",
        "cli/x.py:2 imports dualmech.models.linkages.is_linkage"]


# ----------------------------------------------------------------------------- no import cycles (issue 32)

def module_name(path: Path, root: Path = ROOT) -> str:
    """The dotted name of the package module at ``path`` (a package's ``__init__.py`` is the package)."""
    parts = list(path.relative_to(root).with_suffix("").parts)
    return ".".join(["dualmech", *(parts[:-1] if parts[-1] == "__init__" else parts)])


def import_graph(sources: dict[str, str]) -> dict[str, set[str]]:
    """Module -> the package modules it imports (``sources``: dotted name -> text), nested imports
    included; ``from a.b import c`` reaches ``a.b.c`` if that is a module, else ``a.b``.  Importing a module
    also runs its parent packages' ``__init__``, so it depends on them too, except on its own parents
    (which Python runs before it anyway) unless it imports a name from one of them."""
    def owner(name: str) -> str:
        while name and name not in sources:
            name = name.rpartition(".")[0]
        return name

    graph: dict[str, set[str]] = {m: set() for m in sources}
    for module, source in sources.items():
        for node in ast.walk(ast.parse(source)):
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [f"{node.module}.{alias.name}" for alias in node.names]
            else:
                continue
            for name in names:
                target = owner(name)
                parts = target.split(".")
                parents = {".".join(parts[:k]) for k in range(2, len(parts))}
                graph[module] |= {p for p in parents if p in sources and not module.startswith(p + ".")}
                if target and target != module:
                    graph[module].add(target)
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The import cycles of ``graph``: its strongly connected components of more than one module (Tarjan),
    each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while not component or component[-1] != v:
                component.append(stack.pop())
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_no_two_modules_import_each_other_through_any_path() -> None:
    """Seen failing before the fix: models.slider_crank <-> models.slider_crank_kernel (the kernel took the
    status messages from the module that calls it; they are models/angle_ranges.py now)."""
    paths = [p for floor in FLOORS for p in sorted((ROOT / floor).rglob("*.py"))]
    sources = {module_name(p): p.read_text() for p in paths}
    assert not cycles(import_graph(sources))


def folder_graph(graph: dict[str, set[str]], packages: set[str] | None = None) -> dict[str, set[str]]:
    """The folders' import graph of a modules' one: folder (a module's package) -> the folders its modules
    import.  ``packages``: the modules that are folders (``__init__.py``; default: those with a module
    under them)."""
    def folder(module: str) -> str:
        return module if module in packages else module.rpartition(".")[0]

    packages = packages if packages is not None else {m.rpartition(".")[0] for m in graph}
    out: dict[str, set[str]] = {folder(m): set() for m in graph}
    for module, targets in graph.items():
        out[folder(module)] |= {folder(t) for t in targets} - {folder(module)}
    return out


@pytest.mark.parametrize("floor", FLOORS)
def test_no_two_folders_import_each_other(floor: str) -> None:
    """A folder per concept, imports one way between them (issue 32).  Seen failing before the fix: models
    <-> models/linkages (the slider crank's case format took the linkage kinds from models/linkages, which
    reads the slider crank's inputs; the kinds are models/kinds.py now, which imports no kind); validation's
    loose modules <-> compare/, linkages/, matrix/, report/, rundir/ (the runner, the Python API, the
    baseline, the tolerance study were loose modules above the folders they import; they are run/, the
    package face's verbs.py, compare/, tolerance/ now, and validation/ keeps what every folder reads)."""
    paths = sorted((ROOT / floor).rglob("*.py"))
    packages = {module_name(p) for p in paths if p.name == "__init__.py"}  # a folder of one __init__ too
    assert not cycles(folder_graph(import_graph({module_name(p): p.read_text() for p in paths}), packages))


def test_the_cycle_check_sees_a_lazy_import_and_a_package_that_re_exports() -> None:
    a_b = {"dualmech.x.a": "def f():\n    from dualmech.x.b import g\n",
           "dualmech.x.b": "import dualmech.x.a\n"}
    assert cycles(import_graph({"dualmech.x": "", **a_b})) == [["dualmech.x.a", "dualmech.x.b"]]
    re_export = {"dualmech.x": "from dualmech.x.a import f\nH = 1\n",
                 "dualmech.x.a": "from dualmech.x import H\n"}
    assert cycles(import_graph(re_export)) == [["dualmech.x", "dualmech.x.a"]]
    through = {"dualmech.x": "from dualmech.x.a import f\n", "dualmech.x.a": "",
               "dualmech.y": "import dualmech.x\n", "dualmech.y.b": "from dualmech.x.a import f\n",
               "dualmech.x.c": "from dualmech.y.b import f\n"}
    assert cycles(import_graph(through)) == []  # x.c -> y.b -> y, x.a: no way back to x.c
    assert cycles(import_graph({"dualmech.x": "", "dualmech.x.a": "from dualmech.x.b import g\n",
                                "dualmech.x.b": ""})) == []


# ----------------------------------------------------------------------------- size limits (issue 16)

#: The house's limits (docs/conventions.md): lines per module, lines per function (``def`` to last line).
MAX_MODULE_LINES, MAX_FUNCTION_LINES = 400, 60
#: Where the limits hold: the packages and the tests; never the virtual environment or byte-code caches.
SIZED = FLOORS + ("tests",)
NOT_SIZED = frozenset({".venv", "__pycache__"})


def oversize(rel: str, source: str) -> list[str]:
    """A message per limit the module ``source`` (at ``rel``) breaks: its lines, then each function's."""
    bad = []
    lines = len(source.splitlines())
    if lines > MAX_MODULE_LINES:
        bad.append(f"{rel}: {lines} lines (a module has at most {MAX_MODULE_LINES})")
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            length = node.end_lineno - node.lineno + 1
            if length > MAX_FUNCTION_LINES:
                bad.append(f"{rel}:{node.lineno} {node.name}: {length} lines "
                           f"(a function has at most {MAX_FUNCTION_LINES})")
    return bad


def oversize_in(root: Path, package: str) -> list[str]:
    """:func:`oversize` of every ``.py`` file under ``root / package`` (``.venv`` and caches skipped)."""
    bad = []
    for path in sorted((root / package).rglob("*.py")):
        rel = path.relative_to(root)
        if NOT_SIZED.isdisjoint(rel.parts):
            bad += oversize(rel.as_posix(), path.read_text())
    return bad


@pytest.mark.parametrize("package", SIZED)
def test_no_module_or_function_is_oversize(package: str) -> None:
    bad = oversize_in(ROOT, package)
    assert not bad, "\n".join(bad)


def _module(lines: int, function_lines: int, prefix: str = "def") -> str:
    """Source of ``lines`` lines holding one function of ``function_lines`` lines (``prefix`` its keyword)."""
    body = [f"{prefix} f():"] + ["    x = 1"] * (function_lines - 2) + ["    return x"]
    return "\n".join(body + ["y = 2"] * (lines - function_lines)) + "\n"


def test_the_size_check_sees_an_oversize_module_and_function() -> None:
    """At the limits nothing is reported; one line over each is, as are methods and async functions."""
    assert oversize("core/x.py", _module(400, 60)) == []
    assert oversize("core/x.py", _module(401, 61)) == [
        "core/x.py: 401 lines (a module has at most 400)",
        "core/x.py:1 f: 61 lines (a function has at most 60)"]
    method = "class C:\n" + "\n".join("    " + line for line in _module(61, 61, "async def").splitlines())
    assert oversize("tests/t.py", method + "\n") == ["tests/t.py:2 f: 61 lines (a function has at most 60)"]


def test_the_size_walk_measures_every_module_but_the_environment(tmp_path: Path) -> None:
    """A deliberate fault in a package (nested folder too) fails the gate; the same file in .venv or a cache
    does not."""
    for where in ("core/big.py", "core/deep/big.py", "core/.venv/big.py", "core/__pycache__/big.py"):
        (tmp_path / where).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / where).write_text(_module(401, 10))
    (tmp_path / "core" / "small.py").write_text(_module(400, 60))
    assert oversize_in(tmp_path, "core") == ["core/big.py: 401 lines (a module has at most 400)",
                                             "core/deep/big.py: 401 lines (a module has at most 400)"]


# ----------------------------------------------------------------------------- the tests mirror the packages

#: The name of a folder of test data (files the tests beside it read): it holds no Python.
DATA = "data"


def is_package_folder(root: Path, rel: Path) -> bool:
    """Whether folder ``rel`` of the project at ``root`` is a package folder (its ``__init__.py``); the root
    itself is one too: its tests (``tests/*.py``) are those of the project as a whole."""
    return rel == Path(".") or (root / rel / "__init__.py").is_file()


def unmirrored(root: Path) -> list[str]:
    """A message per folder under ``root / "tests"`` out of the packages' layout.

    A folder holding Python is the test package of the package folder at the same path without ``tests/``
    (``tests/validation/compare/`` tests ``validation/compare/``): that folder must exist, and the test
    folder must have its ``__init__.py`` (the tests import each other as packages).  A folder holding other
    files only is test data: it is named :data:`DATA` and sits in such a test folder.  Byte-code caches are
    skipped, so a folder a move left with caches only is no folder.
    """
    tests = root / "tests"
    bad = []
    for folder in sorted(p for p in (tests, *tests.rglob("*")) if p.is_dir()):
        rel = folder.relative_to(tests)
        files = [p for p in folder.iterdir() if p.is_file()]
        hidden = any(part.startswith(".") for part in rel.parts)
        if not files or hidden or not NOT_SIZED.isdisjoint(rel.parts):
            continue
        where = folder.relative_to(root).as_posix()
        if any(p.suffix == ".py" for p in files):
            if not is_package_folder(root, rel):
                bad.append(f"{where}/ holds tests of {rel.as_posix()}/, which is no package folder")
            if not (folder / "__init__.py").is_file():
                bad.append(f"{where}/ holds tests but no __init__.py")
        elif folder.name != DATA or not is_package_folder(root, rel.parent):
            bad.append(f"{where}/ holds no test module and is no {DATA}/ folder of tests of a package folder")
    return bad


def test_the_tests_mirror_the_packages() -> None:
    """Each test module sits in the folder of ``tests/`` that mirrors the package folder it tests.  Seen
    failing with a test module in ``tests/validation/linkages/`` (``validation/linkages/`` was removed)."""
    bad = unmirrored(ROOT)
    assert not bad, "\n".join(bad)


def test_the_mirror_check_sees_tests_and_data_out_of_the_layout(tmp_path: Path) -> None:
    """Tests of a removed package or of a package's data folder, a test folder without ``__init__.py`` and
    stray data are reported; test data beside its tests, caches and a folder left with caches only are
    not."""
    for where in ("validation/__init__.py", "validation/compare/__init__.py", "tests/__init__.py",
                  "tests/test_top.py", "tests/validation/__init__.py", "tests/validation/compare/__init__.py",
                  "tests/validation/compare/test_tables.py", "tests/validation/data/rssp.toml",
                  "tests/validation/__pycache__/runs.pyc", "tests/validation/old/__pycache__/test_x.pyc",
                  "tests/validation/linkages/__init__.py", "tests/validation/linkages/test_gate.py",
                  "tests/validation/linkages/tables/rssp.toml", "tests/validation/compare/deep/test_y.py",
                  "tests/validation/compare/tables/rusr.toml", "tests/validation/linkages/data/rrcrc.toml",
                  "validation/templates/report.html", "tests/validation/templates/__init__.py",
                  "tests/validation/templates/test_page.py"):
        (tmp_path / where).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / where).write_text("")
    assert unmirrored(tmp_path) == [
        "tests/validation/compare/deep/ holds tests of validation/compare/deep/, which is no package folder",
        "tests/validation/compare/deep/ holds tests but no __init__.py",
        "tests/validation/compare/tables/ holds no test module and is no data/ folder of tests of a package "
        "folder",
        "tests/validation/linkages/ holds tests of validation/linkages/, which is no package folder",
        "tests/validation/linkages/data/ holds no test module and is no data/ folder of tests of a package "
        "folder",
        "tests/validation/linkages/tables/ holds no test module and is no data/ folder of tests of a package "
        "folder",
        "tests/validation/templates/ holds tests of validation/templates/, which is no package folder"]
