"""Scratch copies of the source tree for ``dualmech selftest``: one per fault, the checkout never touched."""

from __future__ import annotations

import shutil
from pathlib import Path

from dualmech.validation.selftest.catalogue import Mutant, SelftestError, stale_reason

#: Import packages and the folders that hold them: pyproject.toml's ``package-dir``, which a test compares
#: with this table (the ``dualmech`` package itself is ``api/``).
PACKAGES: dict[str, str] = {"dualmech": "api", "dualmech.core": "core", "dualmech.models": "models",
                            "dualmech.validation": "validation", "dualmech.cli": "cli"}
#: What a scratch copy holds (relative to the source root); absent optional entries are skipped.
COPIED: tuple[str, ...] = (*PACKAGES.values(), "tests", "docs", "reports", "pyproject.toml", "README.md")
#: Entries a source root must have to be one.
REQUIRED: tuple[str, ...] = (*PACKAGES.values(), "pyproject.toml")


def source_root() -> Path:
    """The checkout this ``dualmech`` was imported from (the folder above ``validation/``)."""
    return Path(__file__).resolve().parents[2]


def check_source(root: Path) -> Path:
    """``root`` resolved, or a :class:`SelftestError` if it is not a dualmech source tree."""
    root = Path(root).resolve()
    missing = [p for p in REQUIRED if not (root / p).exists()]
    if missing:
        raise SelftestError(f"source: {root} is not a dualmech source tree (no {missing[0]}); "
                            "selftest needs the checkout, not an installed wheel")
    return root


def make_scratch(root: Path, dest: Path, mutant: Mutant | None = None) -> Path:
    """Copy the source tree at ``root`` to ``dest`` (created) and apply ``mutant`` there.

    ``dest/.pkg/dualmech`` holds links to the files of the copy's ``api/`` and one link per
    subpackage (``dest/.pkg/dualmech/core`` to ``dest/core``, ...), so a process with ``dest/.pkg``
    first on ``sys.path`` (:data:`BOOT`) imports the copy.
    """
    dest = Path(dest)
    dest.mkdir(parents=True)
    # numba's disk cache (__pycache__/*.nbi, *.nbc) is kept: the kernel checks it against a digest of
    # its sources, so a fault in the kernel recompiles it and any other fault reuses the warm cache
    ignore = shutil.ignore_patterns("*.pyc", ".pytest_cache")
    for name in COPIED:
        src = Path(root) / name
        if src.is_dir():
            shutil.copytree(src, dest / name, ignore=ignore)
        elif src.is_file():
            shutil.copy2(src, dest / name)
    pkg = dest / ".pkg" / "dualmech"
    pkg.mkdir(parents=True)
    for entry in (dest / PACKAGES["dualmech"]).iterdir():
        if entry.name != "__pycache__":
            (pkg / entry.name).symlink_to(entry, target_is_directory=entry.is_dir())
    for name, folder in PACKAGES.items():
        if name != "dualmech":
            (pkg / name.removeprefix("dualmech.")).symlink_to(dest / folder, target_is_directory=True)
    if mutant is not None:
        why = stale_reason(mutant, dest)
        if why:
            raise SelftestError(f"mutant {mutant.id}: {why}")
        path = dest / mutant.file
        path.write_text(path.read_text(encoding="utf-8").replace(mutant.old, mutant.new, 1), encoding="utf-8")
    return dest
