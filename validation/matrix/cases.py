"""Matrices of whole cases, of any kind: which cases, on which engines, against which reference.

The slider crank's own format (:mod:`dualmech.validation.matrix.parse`) sweeps the keys of one base case; a
matrix may instead list whole cases, of any kinds, mixed (``docs/matrix-format.md``, "Matrices of listed
cases")::

    name = "linkages"
    description = "the bundled RSSR and RCCC on every engine"
    cases = ["rssr", "rccc", "thesis/a4-30-s1-3"]   # bundled cases of any kind, or case files (relative to
                                                    # this file first); ``linkages``: the same, its old name
    engines = ["dualmech", "pinocchio", "mujoco", "mujoco-sim"]   # optional; default every engine
    reference = "dualmech"           # optional; default dualmech

    [[sweep]]                        # optional, any number: one case per value of one key of a case
    case = "rscr"                    # as an entry of cases
    key = "joint[2].a"               # tables by name, [[rows]] by number from 1 (a loop table's joint row)
    values = [0.11, 0.12, 0.13]

Each engine solves the cases it can (:func:`~dualmech.validation.engines.solves`: the simulation only a
linkage case that gives the output torque and closes at every angle; the Exudyn judge a loop table driven at
its first joint); the others are *not applicable* to it, each with its reason (:func:`not_applicable`).  The
tolerances are each judge's defaults (:data:`~dualmech.validation.matrix.tolerances.DEFAULT_TOLERANCES`): a
slider crank's per column, every other kind's per group (``kinematics``, ``reactions``:
:func:`~dualmech.validation.matrix.tolerances.group_tolerances`).  A slider-crank case is run in its own load
mode; the listed slider-crank cases form one sweep, ``cases``, for the report's figures.  One case of a
kind other than the slider crank given to ``dualmech validate`` instead of a matrix is the matrix of that case
on every engine.

The slider crank's own format, a ``base`` case with ``set`` and ``[[sweep]]`` tables of ``grid``,
``cases``, ``fixed`` and ``include_base`` (:mod:`dualmech.validation.matrix.parse`), also takes a case of
another kind as its base: its keys are the base case's (``"joint[2].a"``), and every point is one case of this
matrix, named ``<base_label>-<key>=<value>_...`` (``base_label``: the base case's own name by default; a key
by its ``[labels]`` symbol if it has one).  Its ``quantities``, ``[load_modes]``, ``[tolerances]`` and
``expect`` are the slider crank's columns, loads and status rules, so such a base refuses them in one line.
"""

from __future__ import annotations

import copy
import re
from pathlib import Path
from typing import Any

from dualmech.models.catalogue import bundled_case_path, bundled_cases
from dualmech.models.inputs import CaseError, check_keys, key_text, show
from dualmech.models.kinds import SLIDER_CRANK, case_from_data, kind_of
from dualmech.models.toml_input import read_toml
from dualmech.validation.engines import DEFAULT_ENGINES, ENGINES, refusal, solves
from dualmech.validation.matrix.data import (
    COMPARABLE,
    MAX_MATRIX_CASES,
    Matrix,
    MatrixCase,
    MatrixError,
    Sweep,
    check_file_name,
)
from dualmech.validation.matrix.expand import ID_SAFE, flatten, sweep_points
from dualmech.validation.matrix.parse import bundled_matrices, design_matrix, matrix_path
from dualmech.validation.matrix.tolerances import group_tolerances, resolve_tolerances

#: Keys of a matrix of listed cases; ``cases`` (or its old name ``linkages``) is the one that marks it.
KEYS: tuple[str, ...] = ("name", "description", "cases", "linkages", "engines", "reference", "sweep")
#: Keys of one ``[[sweep]]``.
SWEEP_KEYS: tuple[str, ...] = ("case", "key", "values")
#: One step of a swept key: a table's name, or an array of tables' name and row number (from 1).
_STEP = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*)(?:\[([0-9]+)\])?$")
#: Most cases a matrix of listed cases may hold.
MAX_LISTED_CASES = 100
#: Keys of the slider crank's matrix format that a base of another kind takes (module docstring).
BASE_KEYS: tuple[str, ...] = ("name", "description", "base", "base_label", "engines", "reference", "set",
                              "labels", "sweep")
#: Keys of one ``[[sweep]]`` of that format that such a base takes.
BASE_SWEEP_KEYS: tuple[str, ...] = ("name", "label", "grid", "cases", "fixed", "include_base")
#: The one sweep of a based matrix that declares none: the base case alone.
BASE_ALONE: tuple[dict, ...] = ({"cases": [{}], "include_base": False},)
#: The sweep the listed slider-crank cases of a matrix form (for the report's sweep figures).
LISTED = "cases"


def case_of(mc: MatrixCase) -> Any:
    """The checked case record of matrix case ``mc``, of its kind (:func:`~dualmech.models.kinds.
    case_from_data`)."""
    return case_from_data(mc.raw)


def not_applicable(matrix: Matrix) -> dict[str, dict[str, str]]:
    """Per case id, the matrix's engines that do not solve it, each with why
    (:func:`~dualmech.validation.engines.refusal`, one line); cases every engine solves are left out."""
    out: dict[str, dict[str, str]] = {}
    for mc in matrix.cases:
        if not mc.engines or len(mc.engines) == len(matrix.engines):
            continue
        case = case_of(mc)
        why = {e: w for e in matrix.engines if e not in mc.engines and (w := refusal(e, case)) is not None}
        out.update({mc.id: why} if why else {})
    return out


def listed_matrix(name: str, description: str, source: str, engines: tuple[str, ...], reference: str,
                  cases: list[MatrixCase]) -> Matrix:
    """The :class:`~dualmech.validation.matrix.data.Matrix` of whole ``cases`` of any kinds (module
    docstring) on ``engines``: each case's own engines (every engine that solves it, of which the matrix runs
    those of ``engines``), the slider-crank cases' columns, load modes and one sweep, and every judge's
    default tolerances, per column and per group."""
    judges = tuple(e for e in ENGINES if e != reference)  # every one: --engines may name any
    sliders = [mc for mc in cases if mc.is_slider_crank]
    quantities = COMPARABLE if sliders else ()
    columns = resolve_tolerances(None, judges, quantities) if sliders else {e: {} for e in judges}
    tolerances = {e: {**columns[e], **group_tolerances(e)} for e in judges}
    modes = tuple(dict.fromkeys(mc.mode for mc in sliders))
    ids = {m: tuple(mc.id for mc in sliders if mc.mode == m) for m in modes}
    sweeps = (Sweep(LISTED, "the listed slider-crank cases", (), ids),) if sliders else ()
    every = tuple(dict.fromkeys([reference, *ENGINES]))
    return Matrix(name, description, source, reference, every, quantities, modes, tuple(cases), sweeps,
                  {}, tolerances).with_engines(engines)


def matrix_case(case_id: str, data: dict) -> MatrixCase:
    """The matrix case ``case_id`` of the parsed case table ``data`` of any kind, with every engine that
    solves it (a matrix runs those of its own): a slider crank in its own load mode (as
    :func:`~dualmech.validation.matrix.parse.design_matrix` runs one design), any other kind as given (no
    load mode, sweep or expectation)."""
    case = case_from_data(data)
    kind = kind_of(case)
    own = tuple(e for e in ENGINES if solves(e, kind, case))
    if kind != SLIDER_CRANK:
        return MatrixCase(case_id, data, "", {}, (), {}, False, None, own)
    design = design_matrix(case).cases[0]
    return MatrixCase(case_id, {**design.raw, "name": case_id}, design.mode, {}, (LISTED,), {LISTED: case_id},
                      False, None, own)


def _matrix_file(source: str | Path) -> Path | None:
    """The file of ``source`` if it is a TOML file or a bundled matrix's name, else ``None``."""
    path = Path(source)
    if path.is_file():
        return path
    return matrix_path(source) if str(source) in bundled_matrices() else None


def is_listed_source(source: str | Path | None) -> bool:
    """Whether ``dualmech validate SOURCE`` is read here: a case of a kind other than the slider crank
    (bundled name or file), a matrix of listed cases (a file or bundled matrix with a ``cases`` or
    ``linkages`` key), or a matrix whose base is a case of another kind.  Never raises: anything else is for
    the slider crank's matrix reader."""
    if source is None:
        return False
    if _other_kind(source):
        return True
    try:
        path = _matrix_file(source)
        data = read_toml(path, MatrixError) if path is not None else {}
        return ("cases" in data and "base" not in data) or "linkages" in data or (
            "base" in data and _other_kind(_case_file(data["base"], path)))
    except (MatrixError, OSError, TypeError):
        return False


def _other_kind(source: Any) -> bool:
    """Whether ``source`` (a file or a bundled name) is a case of a kind other than the slider crank."""
    try:
        return kind_of(_read_case(str(source))) != SLIDER_CRANK
    except (CaseError, OSError, TypeError):
        return False


def load_listed_matrix(source: str | Path) -> Matrix:
    """The matrix of ``source`` (:func:`is_listed_source`): a matrix file or bundled name, or one case.

    Raises
    ------
    MatrixError, CaseError
        One line naming the key, the value and what would be valid.
    """
    if _other_kind(source):
        entry = _entry(str(source), None, "case")  # a Path as well as its text
        return listed_matrix(entry.id, f"one {kind_of(entry.raw)} case: {entry.raw.get('name', entry.id)}",
                             str(source), DEFAULT_ENGINES, "dualmech", [entry])
    path = _matrix_file(source)
    if path is None:
        raise MatrixError(f"matrix: {show(str(source))} is neither a case nor a matrix of cases")
    data = read_toml(path, MatrixError)
    if "base" in data:
        return parse_based_matrix(data, str(path), path)
    return parse_listed_matrix(data, str(path), path)


def parse_listed_matrix(data: dict, source: str, matrix_file: Path | None = None) -> Matrix:
    """A parsed matrix table of listed cases (module docstring) as a :class:`Matrix`; one-line errors."""
    for key in data:
        if key not in KEYS:
            raise MatrixError(f"{key_text(key)}: unknown key of a matrix of listed cases (valid: "
                              f"{', '.join(KEYS)})")
    if "cases" in data and "linkages" in data:
        raise MatrixError("linkages: the old name of cases; give one of them")
    name, description = check_file_name("name", data.get("name")), _description(data)
    where = "cases" if "cases" in data else "linkages"
    listed = data.get(where)
    if not isinstance(listed, list) or not listed or len(listed) > MAX_LISTED_CASES:
        raise MatrixError(f"{where}: expected a list of 1 to {MAX_LISTED_CASES} cases (bundled names or case "
                          f"files), got {show(listed)}")
    engines, reference = _engines(data, "engines")
    cases = [_entry(s, matrix_file, f"{where}[{i}]") for i, s in enumerate(listed)]
    sweeps = data.get("sweep", [])
    if not isinstance(sweeps, list):
        raise MatrixError(f"sweep: expected [[sweep]] tables (case, key, values), got {show(sweeps)}")
    cases += [e for k, sweep in enumerate(sweeps) for e in _sweep(k, sweep, matrix_file)]
    if len(cases) > MAX_LISTED_CASES:
        raise MatrixError(f"sweep: {len(cases)} cases with the sweeps; a matrix of listed cases runs at most "
                          f"{MAX_LISTED_CASES}")
    ids = [c.id for c in cases]
    twice = next((i for i in ids if ids.count(i) > 1), None)
    if twice is not None:
        raise MatrixError(f"{where}: two cases are named {twice!r}; every case needs its own name")
    return listed_matrix(name, description, source, engines, reference, cases)


def parse_based_matrix(data: dict, source: str, matrix_file: Path | None = None) -> Matrix:
    """A parsed matrix table of the slider crank's format whose ``base`` is a case of another kind (module
    docstring) as a :class:`Matrix`: the base case with ``set``, and one case per point of each
    ``[[sweep]]`` (the base beside each unless ``include_base = false``; a case that several sweeps give is
    run once); one-line errors."""
    for key in data:
        if key not in BASE_KEYS:
            raise MatrixError(f"{key_text(key)}: not a key of a matrix whose base is not a slider crank ("
                              f"valid: "
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
    engines, reference = _engines(data, "engines")
    cases: dict[str, MatrixCase] = {}
    for i, sweep in enumerate(sweeps):
        for values in _points(sweep, f"sweep[{i}]", MAX_LISTED_CASES - len(cases)):
            text = "_".join(f"{labels.get(k, k)}={v}" for k, v in values.items())
            entry = _with_values(base, {**common, **values}, f"{label}-{text}" if text else label,
                                 f"sweep[{i}]", f"sweep[{i}]")
            if cases.setdefault(entry.id, entry).raw != entry.raw:
                raise MatrixError(f"sweep[{i}]: two different cases are named {entry.id!r}")
    if len(cases) > MAX_LISTED_CASES:
        raise MatrixError(f"sweep: {len(cases)} cases; a matrix of cases runs at most {MAX_LISTED_CASES}")
    return listed_matrix(name, description, source, engines, reference, list(cases.values()))


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
        raise MatrixError(f"{where}: more than {MAX_LISTED_CASES} cases in the matrix (this sweep "
                          f"{len(points)}); a matrix of cases runs at most {MAX_LISTED_CASES}")
    return [{}] * include_base + points


def _description(data: dict) -> str:
    """The matrix's ``description``: one line of text (default ``""``)."""
    description = data.get("description", "")
    if not isinstance(description, str) or "\n" in description:
        raise MatrixError(f"description: expected one line of text, got {show(description)}")
    return description


def _entry(source: Any, matrix_file: Path | None, where: str) -> MatrixCase:
    """One listed case: a file relative to the matrix file (tried first), a file, or a bundled name."""
    return _checked(_case_data(source, matrix_file, where), where)


def _checked(data: dict, where: str) -> MatrixCase:
    """The matrix case of a parsed case table ``data`` (checked by its kind's reader); its id from its
    name."""
    case_id = ID_SAFE.sub("_", str(data.get("name", "case"))).strip("._-")[:80] or "case"
    return matrix_case(check_file_name(f"{where} name", case_id), data)


def _sweep(k: int, sweep: Any, matrix_file: Path | None) -> list[MatrixCase]:
    """The cases of ``[[sweep]]`` number ``k`` (0-based): its case with ``key`` set to each of ``values``,
    each named ``<name>-<key>=<value>``."""
    where = f"sweep[{k + 1}]"
    if not isinstance(sweep, dict):
        raise MatrixError(f"{where}: expected a table of case, key, values, got {show(sweep)}")
    check_keys(where, sweep, SWEEP_KEYS, MatrixError)
    base = _case_data(sweep.get("case"), matrix_file, f"{where}.case")
    key, values = sweep.get("key"), sweep.get("values")
    if not isinstance(values, list) or not values or len(values) > MAX_LISTED_CASES:
        raise MatrixError(f"{where}.values: expected a list of 1 to {MAX_LISTED_CASES} values, got "
                          f"{show(values)}")
    return [_with_values(base, {key: value}, f"{base.get('name', 'case')}-{key}={value}", where,
                         f"{where}.key") for value in values]


def _with_values(base: dict, values: dict[str, Any], name: str, where: str, keys_where: str) -> MatrixCase:
    """The matrix case of case table ``base`` with each key of ``values`` set (:func:`_swept`; a key the
    case does not have is one line naming ``keys_where``) and named ``name``; a value its kind's reader
    refuses is one line naming ``where``, the key and the value."""
    data = copy.deepcopy(base)
    for key, value in values.items():
        parent, leaf = _swept(data, key, keys_where)
        parent[leaf] = value
    data["name"] = name
    try:
        return _checked(data, where)
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


def _read_case(source: str) -> dict:
    """The parsed case table of a case file or a bundled case's name, of any kind."""
    path = Path(source)
    return read_toml(path if path.is_file() else bundled_case_path(source), CaseError)


def _case_data(source: Any, matrix_file: Path | None, where: str) -> dict:
    """The parsed case table of ``source``: a file relative to the matrix file (tried first), a file, or a
    bundled name; a one-line MatrixError for anything else."""
    if not isinstance(source, str):
        raise MatrixError(f"{where}: expected a bundled case or a case file, got {show(source)}")
    try:
        return _read_case(_case_file(source, matrix_file))
    except CaseError as err:
        names = ", ".join(name for name, _, _ in bundled_cases())
        raise MatrixError(f"{where}: {show(source)} is not a case ({err}; bundled: {names})") from None


def _engines(data: dict, where: str) -> tuple[tuple[str, ...], str]:
    """``engines`` (reference first, each once) and ``reference``, checked."""
    engines = data.get("engines", list(DEFAULT_ENGINES))
    if not isinstance(engines, list) or not all(isinstance(e, str) for e in engines):
        raise MatrixError(f"{where}: expected a list of engine names, got {show(engines)}")
    for e in engines:
        if e not in ENGINES:
            raise MatrixError(f"{where}: {e!r} is not an engine (valid: {', '.join(ENGINES)})")
    reference = data.get("reference", "dualmech")
    if reference not in engines:
        raise MatrixError(f"reference: {show(reference)} must be one of the engines ({', '.join(engines)})")
    unique = tuple(dict.fromkeys([reference, *engines]))
    if len(unique) < 2:
        raise MatrixError(f"{where}: {show(engines)} has no judge; give the reference and at least one other")
    return unique, reference
