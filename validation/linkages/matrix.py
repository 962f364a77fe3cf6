"""The linkage matrix: which linkage cases (RSSR, RCCC, loop tables), on which engines, against which
reference.

The slider crank's matrix (:mod:`dualmech.validation.matrix`) sweeps the keys of one base case of the
slider crank's format; a linkage case has its own format (``[mechanism] kind``), so a linkage matrix
lists whole cases (``docs/matrix-format.md``, "Linkage matrices")::

    name = "linkages"
    description = "the bundled RSSR and RCCC on every engine"
    linkages = ["rssr", "rccc"]      # bundled linkage cases, or case files (relative to this file first)
    engines = ["dualmech", "pinocchio", "mujoco", "mujoco-sim"]   # optional; default every engine
    reference = "dualmech"           # optional; default dualmech

    [[sweep]]                        # optional, any number: one case per value of one key of a case
    case = "rscr"                    # as an entry of linkages
    key = "joint[2].a"               # tables by name, [[rows]] by number from 1 (a loop table's joint row)
    values = [0.11, 0.12, 0.13]

Each engine solves the cases it can (:func:`~dualmech.validation.engines.solves`: the
simulation only a case that gives the output torque and closes at every angle); the tolerances are
the slider crank's defaults per judge (:data:`~dualmech.validation.matrix.tolerances.DEFAULT_TOLERANCES`),
not set here.  A linkage
case given to ``dualmech validate`` instead of a matrix is the matrix of that case on every engine.

The slider crank's own format, a ``base`` case with ``set`` and ``[[sweep]]`` tables of ``grid``,
``cases``, ``fixed`` and ``include_base`` (:mod:`dualmech.validation.matrix`), also takes a linkage case
as its base: its keys are the base case's (``"joint[2].a"``), and every point is one case of this matrix,
named ``<base_label>-<key>=<value>_...`` (``base_label``: the base case's own name by default; a key by
its ``[labels]`` symbol if it has one).  Its ``quantities``, ``[load_modes]``, ``[tolerances]`` and
``expect`` are the slider crank's columns, loads and status rules, so a linkage base refuses them in one
line.
"""

from __future__ import annotations

import copy
import re
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from dualmech.models.inputs import CaseError, check_keys, key_text, show
from dualmech.models.kinds import LINKAGE_KINDS, kind_of
from dualmech.models.linkages import bundled_names, is_linkage, linkage_case, read_linkage
from dualmech.models.toml_input import read_toml
from dualmech.validation.engines import DEFAULT_ENGINES, ENGINES, refusal, solves
from dualmech.validation.matrix import MatrixError, check_file_name
from dualmech.validation.matrix.data import MAX_MATRIX_CASES
from dualmech.validation.matrix.expand import ID_SAFE, flatten, sweep_points
from dualmech.validation.matrix.parse import bundled_matrices, matrix_path

#: Keys of a linkage matrix file; ``linkages`` is the one that marks it as one.
KEYS: tuple[str, ...] = ("name", "description", "linkages", "engines", "reference", "sweep")
#: Keys of one ``[[sweep]]``.
SWEEP_KEYS: tuple[str, ...] = ("case", "key", "values")
#: One step of a swept key: a table's name, or an array of tables' name and row number (from 1).
_STEP = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*)(?:\[([0-9]+)\])?$")
#: Most cases a linkage matrix may list.
MAX_LINKAGE_CASES = 100
#: Keys of the slider crank's matrix format that a linkage base takes (module docstring).
BASE_KEYS: tuple[str, ...] = ("name", "description", "base", "base_label", "engines", "reference", "set",
                              "labels", "sweep")
#: Keys of one ``[[sweep]]`` of that format that a linkage base takes.
BASE_SWEEP_KEYS: tuple[str, ...] = ("name", "label", "grid", "cases", "fixed", "include_base")
#: The one sweep of a based matrix that declares none: the base case alone.
BASE_ALONE: tuple[dict, ...] = ({"cases": [{}], "include_base": False},)


@dataclass(frozen=True)
class LinkageEntry:
    """One case of a linkage matrix: ``id`` (its ``name``, file-name safe), the ``source`` as written, its
    ``kind``, the checked ``case`` (:func:`~dualmech.models.linkages.linkage_case`) and its parsed case
    table ``data`` (what a run stores and its workers read)."""

    id: str
    source: str
    kind: str
    case: Any
    data: dict


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

    def not_applicable(self) -> dict[str, dict[str, str]]:
        """Per case id, the matrix's engines that do not solve it, each with why (:func:`refusal`, one line);
        cases every engine solves are left out."""
        out: dict[str, dict[str, str]] = {}
        for entry in self.cases:
            why = {e: w for e in self.engines if (w := refusal(e, entry.case)) is not None}
            out.update({entry.id: why} if why else {})
        return out

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
        data = read_toml(path, MatrixError) if path is not None else {}
        return "linkages" in data or ("base" in data and is_linkage(_case_file(data["base"], path)))
    except (MatrixError, OSError, TypeError):
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
        return LinkageMatrix(entry.id, f"one linkage case: {entry.case.name}", str(source), DEFAULT_ENGINES,
                             "dualmech", (entry,))
    path = _matrix_file(source)
    if path is None:
        raise MatrixError(f"matrix: {show(str(source))} is neither a linkage case nor a linkage matrix")
    data = read_toml(path, MatrixError)
    if "base" in data:
        return parse_based_linkage_matrix(data, str(path), path)
    return parse_linkage_matrix(data, str(path), path)


def parse_linkage_matrix(data: dict, source: str, matrix_file: Path | None = None) -> LinkageMatrix:
    """A parsed linkage matrix table (module docstring) as a :class:`LinkageMatrix`; one-line errors."""
    for key in data:
        if key not in KEYS:
            raise MatrixError(f"{key_text(key)}: unknown linkage matrix key (valid: {', '.join(KEYS)})")
    name, description = check_file_name("name", data.get("name")), _description(data)
    listed = data.get("linkages")
    if not isinstance(listed, list) or not listed or len(listed) > MAX_LINKAGE_CASES:
        raise MatrixError(f"linkages: expected a list of 1 to {MAX_LINKAGE_CASES} linkage cases (bundled "
                          f"names or case files), got {show(listed)}")
    cases = tuple(_entry(s, matrix_file, f"linkages[{i}]") for i, s in enumerate(listed))
    sweeps = data.get("sweep", [])
    if not isinstance(sweeps, list):
        raise MatrixError(f"sweep: expected [[sweep]] tables (case, key, values), got {show(sweeps)}")
    cases += tuple(e for k, sweep in enumerate(sweeps) for e in _sweep(k, sweep, matrix_file))
    if len(cases) > MAX_LINKAGE_CASES:
        raise MatrixError(f"sweep: {len(cases)} cases with the sweeps; a linkage matrix runs at most "
                          f"{MAX_LINKAGE_CASES}")
    ids = [c.id for c in cases]
    twice = next((i for i in ids if ids.count(i) > 1), None)
    if twice is not None:
        raise MatrixError(f"linkages: two cases are named {twice!r}; every case needs its own name")
    engines, reference = _engines(data, "engines")
    return LinkageMatrix(name, description, source, engines, reference, cases)


def parse_based_linkage_matrix(data: dict, source: str, matrix_file: Path | None = None) -> LinkageMatrix:
    """A parsed matrix table of the slider crank's format whose ``base`` is a linkage case (module
    docstring) as a :class:`LinkageMatrix`: the base case with ``set``, and one case per point of each
    ``[[sweep]]`` (the base beside each unless ``include_base = false``; a case that several sweeps give is
    run once); one-line errors."""
    for key in data:
        if key not in BASE_KEYS:
            raise MatrixError(f"{key_text(key)}: not a key of a matrix whose base is a linkage case (valid: "
                              f"{', '.join(BASE_KEYS)}; its columns, loads and tolerances are its kind's)")
    name, description = check_file_name("name", data.get("name")), _description(data)
    base = _case_data(data.get("base"), matrix_file, "base")
    label = check_file_name("base_label", data.get("base_label", base.get("name", "base")))
    common = flatten(data.get("set", {}), "set")
    labels = {key: check_file_name(f"labels.{key_text(key)}", symbol)  # symbols become part of case ids
              for key, symbol in flatten(data.get("labels", {}), "labels").items()}
    sweeps = data.get("sweep", list(BASE_ALONE))
    if not isinstance(sweeps, list) or not sweeps:
        raise MatrixError("sweep: expected [[sweep]] tables, or none (the base case alone)")
    cases: dict[str, LinkageEntry] = {}
    for i, sweep in enumerate(sweeps):
        for values in _points(sweep, f"sweep[{i}]", MAX_LINKAGE_CASES - len(cases)):
            text = "_".join(f"{labels.get(k, k)}={v}" for k, v in values.items())
            entry = _with_values(base, {**common, **values}, f"{label}-{text}" if text else label,
                                 str(data["base"]), f"sweep[{i}]", f"sweep[{i}]")
            if cases.setdefault(entry.id, entry).data != entry.data:
                raise MatrixError(f"sweep[{i}]: two different cases are named {entry.id!r}")
    if len(cases) > MAX_LINKAGE_CASES:
        raise MatrixError(f"sweep: {len(cases)} cases; a linkage matrix runs at most {MAX_LINKAGE_CASES}")
    engines, reference = _engines(data, "engines")
    return LinkageMatrix(name, description, source, engines, reference, tuple(cases.values()))


def _points(sweep: Any, where: str, room: int) -> list[dict[str, Any]]:
    """The key values of each case of one ``[[sweep]]`` of a based matrix, the base's (``{}``) first
    unless ``include_base = false``; more than ``room`` cases are refused before any is built."""
    if not isinstance(sweep, dict):
        raise MatrixError(f"{where}: expected a table, got {show(sweep)}")
    check_keys(where, sweep, BASE_SWEEP_KEYS, MatrixError)
    check_file_name(f"{where}.name", sweep.get("name", "sweep"))
    include_base = sweep.get("include_base", True)
    if not isinstance(include_base, bool):
        raise MatrixError(f"{where}.include_base: expected true or false, got {show(include_base)}")
    points, _ = sweep_points(sweep, where, MAX_MATRIX_CASES)
    if len(points) + include_base > room:
        raise MatrixError(f"{where}: more than {MAX_LINKAGE_CASES} cases in the matrix (this sweep "
                          f"{len(points)}); a linkage matrix runs at most {MAX_LINKAGE_CASES}")
    return [{}] * include_base + points


def _description(data: dict) -> str:
    """The matrix's ``description``: one line of text (default ``""``)."""
    description = data.get("description", "")
    if not isinstance(description, str) or "\n" in description:
        raise MatrixError(f"description: expected one line of text, got {show(description)}")
    return description


def _entry(source: Any, matrix_file: Path | None, where: str) -> LinkageEntry:
    """One listed case: a file relative to the matrix file (tried first), a file, or a bundled stem."""
    data = _case_data(source, matrix_file, where)
    return _checked(data, source, where)


def _checked(data: dict, source: str, where: str) -> LinkageEntry:
    """The entry of a parsed case table ``data`` (checked by its kind's reader); its id from its name."""
    case = linkage_case(data)
    case_id = ID_SAFE.sub("_", case.name).strip("._-")[:80] or "case"
    return LinkageEntry(check_file_name(f"{where} name", case_id), source, kind_of(case), case, data)


def _sweep(k: int, sweep: Any, matrix_file: Path | None) -> list[LinkageEntry]:
    """The cases of ``[[sweep]]`` number ``k`` (0-based): its case with ``key`` set to each of ``values``,
    each named ``<name>-<key>=<value>``."""
    where = f"sweep[{k + 1}]"
    if not isinstance(sweep, dict):
        raise MatrixError(f"{where}: expected a table of case, key, values, got {show(sweep)}")
    check_keys(where, sweep, SWEEP_KEYS, MatrixError)
    base = _case_data(sweep.get("case"), matrix_file, f"{where}.case")
    key, values = sweep.get("key"), sweep.get("values")
    if not isinstance(values, list) or not values or len(values) > MAX_LINKAGE_CASES:
        raise MatrixError(f"{where}.values: expected a list of 1 to {MAX_LINKAGE_CASES} values, got "
                          f"{show(values)}")
    return [_with_values(base, {key: value}, f"{base.get('name', 'case')}-{key}={value}", str(sweep["case"]),
                         where, f"{where}.key") for value in values]


def _with_values(base: dict, values: dict[str, Any], name: str, source: str, where: str,
                 keys_where: str) -> LinkageEntry:
    """The entry of case table ``base`` with each key of ``values`` set (:func:`_swept`; a key the case
    does not have is one line naming ``keys_where``) and named ``name``; a value its kind's reader refuses
    is one line naming ``where``, the key and the value."""
    data = copy.deepcopy(base)
    for key, value in values.items():
        parent, leaf = _swept(data, key, keys_where)
        parent[leaf] = value
    data["name"] = name
    try:
        return _checked(data, source, where)
    except CaseError as err:
        given = ", ".join(f"{k} = {show(v)}" for k, v in values.items())
        raise MatrixError(f"{where}: {given}: {err}") from None


def _swept(data: dict, key: Any, where: str) -> tuple[dict, str]:
    """The table holding the swept ``key`` of a case table and the key's last name (its value may be new:
    the case's reader checks it)."""
    steps = key.split(".") if isinstance(key, str) else []
    matches = [_STEP.match(step) for step in steps]
    if not steps or not all(matches):
        raise MatrixError(f"{where}: expected a key like 'joint[2].a' or 'drive.speed', got {show(key)}")
    node: Any = data
    for i, m in enumerate(matches):
        name, row = m.group(1), m.group(2)
        last = i == len(matches) - 1 and row is None
        if not isinstance(node, dict) or (name not in node and not last):
            raise MatrixError(f"{where}: {show(key)}: the case has no {'.'.join(steps[:i + 1])!r}")
        if last:
            return node, name
        node = node[name]
        if row is not None:
            if not isinstance(node, list) or not 1 <= int(row) <= len(node):
                n = len(node) if isinstance(node, list) else 0
                raise MatrixError(f"{where}: {show(key)}: {name} has rows 1..{n}, got {row}")
            node = node[int(row) - 1]
        elif isinstance(node, list):
            raise MatrixError(f"{where}: {show(key)}: {name} is an array of rows: name one, e.g. {name}[1]")
    raise MatrixError(f"{where}: {show(key)}: a key ends at a value, not at a row")


def _case_file(source: str, matrix_file: Path | None) -> str:
    """Where case ``source`` of a matrix is read: a file relative to the matrix file if there is one, else
    ``source`` itself (a file, or a bundled stem)."""
    candidate = matrix_file.parent / source if matrix_file is not None else None
    return str(candidate) if candidate is not None and candidate.is_file() else source


def _case_data(source: Any, matrix_file: Path | None, where: str) -> dict:
    """The parsed case table of ``source``: a file relative to the matrix file (tried first), a file, or a
    bundled stem; a one-line MatrixError for anything that is not a linkage case."""
    if not isinstance(source, str):
        raise MatrixError(f"{where}: expected a bundled linkage case or a case file, got {show(source)}")
    target = _case_file(source, matrix_file)
    if not is_linkage(target):
        raise MatrixError(f"{where}: {show(source)} is not a linkage case (a bundled name: "
                          f"{', '.join(bundled_names())}, or a file whose [mechanism] kind is one of "
                          f"{', '.join(LINKAGE_KINDS)})")
    return read_linkage(target)


def _engines(data: dict, where: str) -> tuple[tuple[str, ...], str]:
    """``engines`` (reference first, each once) and ``reference``, checked."""
    engines = data.get("engines", list(DEFAULT_ENGINES))
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
