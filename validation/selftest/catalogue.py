"""The fault catalogue of ``dualmech selftest`` (``validation/mutants.toml``): parsed, checked, applicable."""

from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass
from pathlib import Path

#: Fault classes of the catalogue (docs/validation.md, "The gate proves it can fail").
CLASSES: tuple[str, ...] = ("solver", "shared-input", "judge", "comparison")
#: Default catalogue, relative to the source root.
CATALOGUE = "validation/mutants.toml"
_ID = re.compile(r"[A-Za-z0-9][A-Za-z0-9-]*")


class SelftestError(ValueError):
    """A catalogue or source tree that cannot be used; the message is one line."""


@dataclass(frozen=True)
class Mutant:
    """One deliberate fault: ``old`` replaced by ``new`` in ``file`` (relative to the source root)."""

    id: str
    file: str
    old: str
    new: str
    fault_class: str
    description: str


@dataclass(frozen=True)
class Catalogue:
    """The faults and the gate they are run against (matrix file and test modules, source-relative)."""

    mutants: tuple[Mutant, ...]
    matrix: str
    tests: tuple[str, ...]


def _text(where: str, value: object, *, empty: bool = False) -> str:
    if not isinstance(value, str) or (not value and not empty):
        raise SelftestError(f"{where}: expected a non-empty string, got {value!r}")
    return value


def parse_catalogue(data: dict, source: str = "<catalogue>") -> Catalogue:
    """Check a parsed catalogue table and build the :class:`Catalogue`.

    Format: ``matrix = "path"``, ``tests = ["path", ...]`` and one ``[[mutant]]``
    table per fault with ``id``, ``file``, ``class`` (one of :data:`CLASSES`),
    ``description``, ``old`` and ``new`` (``new != old``).
    """
    known = {"matrix", "tests", "mutant"}
    for key in data:
        if key not in known:
            raise SelftestError(f"{source}: {key}: unknown key (valid: {', '.join(sorted(known))})")
    matrix = _text(f"{source}: matrix", data.get("matrix"))
    tests = data.get("tests", [])
    if not isinstance(tests, list) or not all(isinstance(t, str) and t for t in tests):
        raise SelftestError(f"{source}: tests: expected an array of test module paths, got {tests!r}")
    entries = data.get("mutant", [])
    if not isinstance(entries, list) or not entries:
        raise SelftestError(f"{source}: mutant: expected at least one [[mutant]] table")
    mutants, seen = [], set()
    fields_ = {"id", "file", "class", "description", "old", "new"}
    for i, m in enumerate(entries):
        where = f"{source}: mutant[{i}]"
        if not isinstance(m, dict):
            raise SelftestError(f"{where}: expected a table, got {m!r}")
        for key in m:
            if key not in fields_:
                raise SelftestError(f"{where}.{key}: unknown key (valid: {', '.join(sorted(fields_))})")
        mid = _text(f"{where}.id", m.get("id"))
        if not _ID.fullmatch(mid):
            raise SelftestError(f"{where}.id: expected letters, digits and '-', got {mid!r}")
        where = f"{source}: mutant {mid}"
        if mid in seen:
            raise SelftestError(f"{where}: id given twice")
        seen.add(mid)
        cls = m.get("class")
        if cls not in CLASSES:
            raise SelftestError(f"{where}.class: expected one of {', '.join(CLASSES)}, got {cls!r}")
        old, new = _text(f"{where}.old", m.get("old")), _text(f"{where}.new", m.get("new"), empty=True)
        if old == new:
            raise SelftestError(f"{where}.new: identical to old (a fault must change the source)")
        mutant = Mutant(mid, _text(f"{where}.file", m.get("file")), old, new, cls,
                        _text(f"{where}.description", m.get("description")))
        twin = next((t for t in mutants if (t.file, t.old, t.new) == (mutant.file, old, new)), None)
        if twin is not None:
            raise SelftestError(f"{where}: the same edit of {mutant.file} as mutant {twin.id} (one fault "
                                "counted twice)")
        mutants.append(mutant)
    return Catalogue(tuple(mutants), matrix, tuple(tests))


def load_catalogue(path: str | Path) -> Catalogue:
    """Read a catalogue file (TOML)."""
    try:
        with Path(path).open("rb") as fh:
            data = tomllib.load(fh)
    except OSError as err:
        raise SelftestError(f"catalogue: cannot read {path} ({err.strerror})") from None
    except tomllib.TOMLDecodeError as err:
        raise SelftestError(f"catalogue: {path} is not valid TOML ({err})") from None
    return parse_catalogue(data, str(path))


def stale_reason(mutant: Mutant, root: Path) -> str | None:
    """Why ``mutant`` cannot be applied to the tree at ``root``; ``None`` if ``old`` occurs exactly once."""
    path = Path(root) / mutant.file
    try:
        text = path.read_text(encoding="utf-8")
    except OSError:
        return f"stale: {mutant.file} does not exist"
    count = text.count(mutant.old)
    if count != 1:
        return f"stale: old text occurs {count} times in {mutant.file} (must be exactly once)"
    return None
