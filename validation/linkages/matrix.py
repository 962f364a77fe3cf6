"""The linkage matrix: which linkage cases (RSSR, RCCC), on which engines, against which reference.

The slider crank's matrix (:mod:`dualmech.validation.matrix`) sweeps the keys of one base case of the
slider crank's format; a linkage case has its own format (``[mechanism] kind``), so a linkage matrix
lists whole cases (``docs/matrix-format.md``, "Linkage matrices")::

    name = "linkages"
    description = "the bundled RSSR and RCCC on every engine"
    linkages = ["rssr", "rccc"]      # bundled linkage cases, or case files (relative to this file first)
    engines = ["dualmech", "pinocchio", "mujoco", "mujoco-sim"]   # optional; default every engine
    reference = "dualmech"           # optional; default dualmech

Each engine solves the cases it can (:func:`~dualmech.validation.linkages.engines.solves`: the
simulation only a case that gives the output torque and closes at every angle); the tolerances are
the slider crank's defaults per judge (:data:`~dualmech.validation.matrix.tolerances.DEFAULT_TOLERANCES`),
not set here.  A linkage
case given to ``dualmech validate`` instead of a matrix is the matrix of that case on every engine.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from dualmech.models.inputs import key_text, show
from dualmech.models.linkages import (
    KINDS,
    bundled_names,
    is_linkage,
    linkage_case,
    linkage_kind,
    read_linkage,
)
from dualmech.models.toml_input import read_toml
from dualmech.validation.linkages.engines import ENGINES, solves
from dualmech.validation.matrix import MatrixError, check_file_name
from dualmech.validation.matrix.expand import ID_SAFE
from dualmech.validation.matrix.parse import bundled_matrices, matrix_path

#: Keys of a linkage matrix file; ``linkages`` is the one that marks it as one.
KEYS: tuple[str, ...] = ("name", "description", "linkages", "engines", "reference")
#: Most cases a linkage matrix may list.
MAX_LINKAGE_CASES = 100


@dataclass(frozen=True)
class LinkageEntry:
    """One case of a linkage matrix: ``id`` (its ``name``, file-name safe), the ``source`` as written, its
    ``kind`` and the checked ``case`` (:func:`~dualmech.models.linkages.linkage_case`)."""

    id: str
    source: str
    kind: str
    case: Any


@dataclass(frozen=True)
class LinkageMatrix:
    """The cases of a linkage run, its engines (reference first) and where it was read from."""

    name: str
    description: str
    source: str
    engines: tuple[str, ...]
    reference: str
    cases: tuple[LinkageEntry, ...]

    @property
    def judges(self) -> tuple[str, ...]:
        """Every engine but the reference."""
        return tuple(e for e in self.engines if e != self.reference)

    def engines_of(self, entry: LinkageEntry) -> tuple[str, ...]:
        """The matrix's engines that solve ``entry`` (the others are not applicable to it)."""
        return tuple(e for e in self.engines if solves(e, entry.kind, entry.case))

    def with_engines(self, names: tuple[str, ...]) -> LinkageMatrix:
        """The same cases on ``names`` only (the reference among them; ``--engines``)."""
        return replace(self, engines=_engines({"engines": list(names), "reference": self.reference},
                                              "--engines")[0])


def _matrix_file(source: str | Path) -> Path | None:
    """The file of ``source`` if it is a TOML file or a bundled matrix's name, else ``None``."""
    path = Path(source)
    if path.is_file():
        return path
    return matrix_path(source) if str(source) in bundled_matrices() else None


def is_linkage_source(source: str | Path | None) -> bool:
    """Whether ``dualmech validate SOURCE`` is a linkage run: a linkage case (bundled stem or file with a
    linkage ``[mechanism] kind``) or a linkage matrix (a file or bundled matrix with a ``linkages`` key).
    Never raises: anything else is for the slider crank's matrix reader."""
    if source is None:
        return False
    if is_linkage(source):
        return True
    try:
        path = _matrix_file(source)
        return path is not None and "linkages" in read_toml(path, MatrixError)
    except (MatrixError, OSError):
        return False


def load_linkage_matrix(source: str | Path) -> LinkageMatrix:
    """The linkage matrix of ``source``: a linkage matrix file or bundled name, or one linkage case.

    Raises
    ------
    MatrixError, CaseError
        One line naming the key, the value and what would be valid.
    """
    if is_linkage(source):
        entry = _entry(str(source), None, "case")  # a Path as well as its text (the Python API)
        return LinkageMatrix(entry.id, f"one linkage case: {entry.case.name}", str(source), tuple(ENGINES),
                             "dualmech", (entry,))
    path = _matrix_file(source)
    if path is None:
        raise MatrixError(f"matrix: {show(str(source))} is neither a linkage case nor a linkage matrix")
    return parse_linkage_matrix(read_toml(path, MatrixError), str(path), path)


def parse_linkage_matrix(data: dict, source: str, matrix_file: Path | None = None) -> LinkageMatrix:
    """A parsed linkage matrix table (module docstring) as a :class:`LinkageMatrix`; one-line errors."""
    for key in data:
        if key not in KEYS:
            raise MatrixError(f"{key_text(key)}: unknown linkage matrix key (valid: {', '.join(KEYS)})")
    name = check_file_name("name", data.get("name"))
    description = data.get("description", "")
    if not isinstance(description, str) or "\n" in description:
        raise MatrixError(f"description: expected one line of text, got {show(description)}")
    listed = data.get("linkages")
    if not isinstance(listed, list) or not listed or len(listed) > MAX_LINKAGE_CASES:
        raise MatrixError(f"linkages: expected a list of 1 to {MAX_LINKAGE_CASES} linkage cases (bundled "
                          f"names or case files), got {show(listed)}")
    cases = tuple(_entry(s, matrix_file, f"linkages[{i}]") for i, s in enumerate(listed))
    ids = [c.id for c in cases]
    twice = next((i for i in ids if ids.count(i) > 1), None)
    if twice is not None:
        raise MatrixError(f"linkages: two cases are named {twice!r}; every case needs its own name")
    engines, reference = _engines(data, "engines")
    return LinkageMatrix(name, description, source, engines, reference, cases)


def _entry(source: Any, matrix_file: Path | None, where: str) -> LinkageEntry:
    """One listed case: a file relative to the matrix file (tried first), a file, or a bundled stem."""
    if not isinstance(source, str):
        raise MatrixError(f"{where}: expected a bundled linkage case or a case file, got {show(source)}")
    candidate = matrix_file.parent / source if matrix_file is not None else None
    target = str(candidate) if candidate is not None and candidate.is_file() else source
    if not is_linkage(target):
        raise MatrixError(f"{where}: {show(source)} is not a linkage case (a bundled name: "
                          f"{', '.join(bundled_names())}, or a file whose [mechanism] kind is one of "
                          f"{', '.join(KINDS)})")
    data = read_linkage(target)
    case = linkage_case(data)
    case_id = ID_SAFE.sub("_", case.name).strip("._-")[:80] or "case"
    return LinkageEntry(check_file_name(f"{where} name", case_id), source, linkage_kind(data), case)


def _engines(data: dict, where: str) -> tuple[tuple[str, ...], str]:
    """``engines`` (reference first, each once) and ``reference``, checked."""
    engines = data.get("engines", list(ENGINES))
    if not isinstance(engines, list) or not all(isinstance(e, str) for e in engines):
        raise MatrixError(f"{where}: expected a list of engine names, got {show(engines)}")
    for e in engines:
        if e not in ENGINES:
            raise MatrixError(f"{where}: {e!r} is not an engine of the linkages "
                              f"(valid: {', '.join(ENGINES)})")
    reference = data.get("reference", "dualmech")
    if reference not in engines:
        raise MatrixError(f"reference: {show(reference)} must be one of the engines ({', '.join(engines)})")
    unique = tuple(dict.fromkeys([reference, *engines]))
    if len(unique) < 2:
        raise MatrixError(f"{where}: {show(engines)} has no judge; give the reference and at least one other")
    return unique, reference
