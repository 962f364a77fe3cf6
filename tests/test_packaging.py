"""The wheel holds every package of the tree: pyproject.toml lists packages by hand (the top-level folders
are mapped onto ``dualmech.*``), so a new subpackage missing from the list would install nowhere but an
editable checkout."""

from __future__ import annotations

import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_every_package_of_the_tree_is_listed() -> None:
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    folders = {v: k for k, v in config["package-dir"].items()}
    found = {
        ".".join([folders[init.relative_to(ROOT).parts[0]], *init.relative_to(ROOT).parts[1:-1]])
        for folder in folders
        for init in (ROOT / folder).rglob("__init__.py")
    }
    assert found == set(config["packages"])


def test_every_bundled_linkage_case_is_package_data() -> None:
    """Each bundled linkage case (RSSR, RCCC, the loop tables of ``models/loop/cases/``) matches a
    package-data glob of its package, so ``dualmech cases`` lists it from a wheel too."""
    from dualmech.models.linkages import CASE_FOLDERS

    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    folders = {v: k for k, v in config["package-dir"].items()}
    missing = []
    for folder in CASE_FOLDERS:
        for path in sorted(folder.glob("*.toml")):
            rel = path.resolve().relative_to(ROOT)
            package = ".".join([folders[rel.parts[0]], *rel.parts[1:-2]])
            inside = Path(*rel.parts[-2:])  # cases/<stem>.toml
            if not any(inside.match(glob) for glob in config["package-data"].get(package, [])):
                missing.append(f"{rel} (package {package})")
    assert not missing, missing
