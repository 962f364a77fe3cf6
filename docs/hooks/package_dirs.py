"""mkdocs hooks: let mkdocstrings (griffe) read ``dualmech`` from its source folders, and show the
docstrings' Sphinx roles as plain code.

pyproject.toml maps the import names onto folders that do not bear them (``dualmech`` -> ``api/``,
``dualmech.core`` -> ``core/``, ...).  Python's import system follows that mapping (setuptools' editable
finder), but griffe reads source files by folder name, so it finds neither ``dualmech`` nor its
subpackages.  This hook builds, for the length of the build, a temporary tree of symbolic links in which
each package sits at the path its import name says (``dualmech/core`` -> ``core/``), from the mapping in
pyproject.toml (its one statement), and puts that tree first on the python handler's search ``paths``.

The docstrings are numpy style with Sphinx roles (``:func:`solve```, ``:class:`~dualmech.core.Case```,
``:math:`S_4```), which mkdocstrings does not resolve: the rendered page would show ``:func:solve``.
:func:`on_page_content` drops the role and a ``~``-shortened path's module part, leaving the code span.
"""

from __future__ import annotations

import re
import shutil
import tempfile
import tomllib
from pathlib import Path
from typing import Any

from mkdocs.plugins import event_priority

ROOT = Path(__file__).resolve().parents[2]
#: a Sphinx role before a code span, as Markdown renders it; ``~a.b.c`` shows as ``c`` in Sphinx
_ROLE = re.compile(r":(?:func|class|meth|attr|data|mod|obj|exc|math):<code>(?:~(?:[\w]+\.)*)?")


def link_tree(root: Path, into: Path) -> None:
    """Lay out in ``into`` every package of ``root/pyproject.toml``'s ``package-dir`` at its import path.

    A package with mapped subpackages becomes a folder of links to its own files; any other package is
    one link to its folder.
    """
    mapping: dict[str, str] = tomllib.loads((root / "pyproject.toml").read_text())["tool"]["setuptools"][
        "package-dir"]
    for package in sorted(mapping, key=lambda name: name.count(".")):  # parents before their children
        source, target = root / mapping[package], into.joinpath(*package.split("."))
        children = {name.split(".")[-1] for name in mapping if name.startswith(package + ".")}
        if not children:
            target.symlink_to(source, target_is_directory=True)
            continue
        target.mkdir()
        for entry in source.iterdir():
            if entry.name not in children and entry.name != "__pycache__":
                target.joinpath(entry.name).symlink_to(entry)


#: the trees built (``mkdocs serve`` reads the configuration again at each rebuild)
_TREES: list[Path] = []


@event_priority(100)  # before mkdocstrings' own on_config, which makes the handler and reads its paths
def on_config(config: Any) -> Any:
    """Build a tree and put it first on the python handler's ``paths``."""
    tree = Path(tempfile.mkdtemp(prefix="dualmech-docs-"))
    _TREES.append(tree)
    link_tree(ROOT, tree)
    python = config.plugins["mkdocstrings"].config.handlers.setdefault("python", {})
    python["paths"] = [str(tree), *python.get("paths", [])]
    return config


def on_shutdown() -> None:
    """Remove the trees."""
    for tree in _TREES:
        shutil.rmtree(tree, ignore_errors=True)


def on_page_content(html: str, **_: Any) -> str:
    """The page's HTML with every Sphinx role before a code span removed (module docstring), and the
    reStructuredText ``::`` that ends a paragraph before a literal block shown as one colon."""
    return _ROLE.sub("<code>", html).replace("::</p>", ":</p>")
