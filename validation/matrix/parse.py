"""Validation matrices: which cases, which engines, which quantities, which tolerances.

A matrix file (TOML) names a base case and sweeps over any dotted case key;
:func:`load_matrix` expands it into concrete cases with
:meth:`dualmech.models.case.Case.with_values`.  The format, by example::

    name = "thesis-1991"
    description = "Rahman (1991), section 3.2"
    base = "thesis/ideal"            # preset name, or a case file relative to this file
    base_label = "ideal"             # how the base case is named in ids and legends
    engines = ["dualmech", "pinocchio", "mujoco", "mujoco-sim"]
    reference = "dualmech"           # every other engine is judged against this one
    quantities = ["S4", "j1_fx"]     # optional; default: every compared column
    set = { "motion.angles_deg" = { start = 0.0, stop = 360.0, step = 1.0 } }   # on every case

    [labels]                          # optional short symbols for keys (ids, legends)
    "geometry.slider_offset" = "a4"

    [load_modes]                      # optional; every case is run in every mode
    torque = { "loads.drive_torque" = 100.0 }
    force = { "loads.slider_force" = -100.0 }

    [[sweep]]
    name = "a4"
    fixed = { "geometry.crank_axial_shift" = 3.5 }
    grid = { "geometry.slider_offset" = [10.0, 20.0, 30.0] }    # Cartesian product
    include_base = true                                          # the base case beside it

    [[sweep]]
    name = "pairs"
    cases = [ { "geometry.slider_offset" = 10.0, "geometry.crank_axial_shift" = 1.0 } ]

    [[sweep]]
    name = "beyond"
    expect = "no_assembly"           # optional; every case of this sweep assembles nowhere
    include_base = false
    grid = { "geometry.slider_offset" = [60.0, 80.0] }

    [tolerances]                      # optional; defaults: matrix/tolerances.py
    kinematics = "MATRIX_KINEMATICS"  # a name in validation/tolerances.py, or a number
    [tolerances.mujoco-sim]
    reactions = "SIM_REACTIONS"
    S4_ddot = 1e-4

Keys may be written quoted (``"geometry.slider_offset" = ...``) or as TOML
dotted keys (``geometry.slider_offset = ...``); both mean the same case key.
A load mode sets one of ``loads.drive_torque`` / ``loads.slider_force`` and
removes the other from the base case (a case takes exactly one).  A case that
several sweeps produce (e.g. the base case) is run once and belongs to all.

``expect`` declares what a sweep's cases must do instead of assembling; the only
value is ``"no_assembly"``: each of its cases is expected to assemble at no crank
position, and every engine must agree (the comparison checks it).  It applies to
the sweep's own points, not to the base case ``include_base`` adds; a case that
two sweeps declare differently is refused.  ``MatrixCase.expect`` carries it
(``None``: the case is expected to assemble).

Names that become file or folder names are refused, never rewritten, unless they
are :func:`check_file_name` safe: the matrix ``name`` (the default output folder
``runs/<name>``), sweep names, load-mode names, ``base_label``, ``[labels]``
symbols and the case ids built from them (``cases/<id>.json``).  A matrix expands
to at most :data:`MAX_MATRIX_CASES` cases; ``[load_modes]`` may be left out (every
case then keeps the base case's load).

Tolerances are looked up as :mod:`~dualmech.validation.matrix.tolerances` says.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path
from typing import Any

from dualmech.models.case import Case, load_case, preset_names
from dualmech.models.inputs import check_keys, check_text, key_text, show
from dualmech.models.kinds import SLIDER_CRANK
from dualmech.models.toml_input import read_toml
from dualmech.validation.engines import engines_for
from dualmech.validation.matrix.data import (
    COMPARABLE,
    MAX_MATRIX_CASES,
    MAX_TEXT_CHARS,
    Matrix,
    MatrixError,
    check_engines,
    check_expect,
    check_file_name,
)
from dualmech.validation.matrix.expand import (
    DEFAULT_LABELS,
    ID_SAFE,
    LOAD_KEYS,
    SweepSpec,
    expand_cases,
    flatten,
    sweep_points,
)
from dualmech.validation.matrix.tolerances import resolve_tolerances

_TOP_KEYS = {
    "name",
    "description",
    "base",
    "base_label",
    "engines",
    "reference",
    "quantities",
    "set",
    "labels",
    "load_modes",
    "sweep",
    "tolerances",
}
_SWEEP_KEYS = {"name", "label", "fixed", "grid", "cases", "include_base", "expect"}

DEFAULT_MATRIX = "thesis-1991"
#: The one sweep of a matrix that declares none: the base case alone.
BASE_ALONE: list[dict] = [
    {"name": "design", "label": "the base case alone", "cases": [{}], "include_base": False}
]
#: Longest name a design matrix takes from its case (it becomes a folder name).
MAX_DESIGN_NAME = 80


def bundled_matrices() -> list[str]:
    """Names of the matrices shipped with dualmech (e.g. ``"thesis-1991"``)."""
    root = resources.files("dualmech.validation") / "matrices"
    return sorted(f.name[:-5] for f in root.iterdir() if f.name.endswith(".toml"))


def matrix_path(source: str | Path) -> Path:
    """The file of a matrix: an existing path, or the name of a bundled matrix."""
    path = Path(source)
    if path.is_file():
        return path
    names = bundled_matrices()
    if str(source) in names:
        return Path(str(resources.files("dualmech.validation") / "matrices" / f"{source}.toml"))
    raise MatrixError(
        f"matrix: {show(str(source))} is neither a file nor a bundled matrix ({', '.join(names)})"
    )


def _text(key: str, value: Any) -> str:
    """A one-line printable text (description, sweep label), else a one-line :class:`MatrixError`."""
    try:
        return check_text(key, value, MAX_TEXT_CHARS)
    except ValueError as err:
        raise MatrixError(str(err)) from None


def _load_base(spec: Any, matrix_file: Path | None) -> Case:
    if isinstance(spec, Case):  # a design built in Python (design_matrix)
        return spec
    if not isinstance(spec, str):
        raise MatrixError(f"base: expected a preset name or a case file, got {show(spec)}")
    if matrix_file is not None:
        candidate = matrix_file.parent / spec
        if candidate.is_file():
            return load_case(candidate)
    return load_case(spec)


def parse_matrix(data: dict, source: str = "<matrix>", matrix_file: Path | None = None) -> Matrix:
    """Expand a parsed matrix table into concrete cases (see the module docstring).

    Raises
    ------
    MatrixError
        One line naming the key, the value and what would be valid; also when a
        swept case is not a valid case (the case's own message is included).
    """
    if not isinstance(data, dict):
        raise MatrixError(f"matrix: expected a table, got {show(data)}")
    for key in data:
        if key not in _TOP_KEYS:
            raise MatrixError(f"{key_text(key)}: unknown matrix key (valid: {', '.join(sorted(_TOP_KEYS))})")
    name = check_file_name("name", data.get("name"))
    description = _text("description", data.get("description", ""))
    engines, reference = _engines(data)
    quantities = _quantities(data.get("quantities", list(COMPARABLE)))
    labels = dict(DEFAULT_LABELS)
    for key, symbol in flatten(data.get("labels", {}), "labels").items():
        labels[key] = check_file_name(f"labels.{key_text(key)}", symbol)  # symbols become part of case ids
    base_label = check_file_name("base_label", data.get("base_label", "base"))
    base = _base_case(data, matrix_file)
    modes = _load_modes(data.get("load_modes"), base)
    specs = _sweep_specs(data.get("sweep", BASE_ALONE), len(modes))
    cases, sweeps = expand_cases(base, modes, specs, labels, base_label)
    judges = tuple(e for e in engines if e != reference)
    return Matrix(
        name=name,
        description=description,
        source=source,
        base=data["base"].name if isinstance(data["base"], Case) else data["base"],
        reference=reference,
        engines=engines,
        quantities=quantities,
        modes=tuple(modes),
        cases=cases,
        sweeps=sweeps,
        labels=labels,
        tolerances=resolve_tolerances(data.get("tolerances"), judges, quantities),
    )


def _engines(data: dict) -> tuple[tuple[str, ...], str]:
    """The matrix's engines (each once, in the file's order) and its reference engine."""
    engines = data.get("engines", list(engines_for(SLIDER_CRANK)))
    if not isinstance(engines, list) or not all(isinstance(e, str) for e in engines):
        raise MatrixError(f"engines: expected an array of engine names, got {show(engines)}")
    reference = data.get("reference", "dualmech")
    engines_t = tuple(dict.fromkeys(engines))
    check_engines(engines_t, reference)
    return engines_t, reference


def _quantities(quantities: Any) -> tuple[str, ...]:
    """The compared columns the file names, in :data:`COMPARABLE` order."""
    if not isinstance(quantities, list) or not quantities:
        raise MatrixError(f"quantities: expected a non-empty array of column names, got {show(quantities)}")
    for q in quantities:
        if q not in COMPARABLE:
            raise MatrixError(
                f"quantities: {show(q)} is not a compared column (valid: {', '.join(COMPARABLE)})"
            )
    return tuple(q for q in COMPARABLE if q in quantities)


def _base_case(data: dict, matrix_file: Path | None) -> Case:
    """The base case with the matrix's ``set`` values applied."""
    try:
        base = _load_base(data.get("base"), matrix_file)
        common = flatten(data.get("set", {}), "set")
        if common:
            base = base.with_values({**common, "name": base.name})
    except ValueError as err:
        raise MatrixError(f"base: {err}") from None
    return base


def _load_modes(modes_table: Any, base: Case) -> dict[str, dict[str, Any]]:
    """Load mode name -> its dotted-key updates; without ``[load_modes]`` the base case's own mode alone."""
    if modes_table is None:
        return {base.loads.mode: {}}
    if not isinstance(modes_table, dict) or not modes_table:
        raise MatrixError(
            f"load_modes: expected a table of mode = {{ key = value }}, got {show(modes_table)}"
        )
    modes = {}
    for mode, updates in modes_table.items():
        check_file_name(f"load_modes.{key_text(mode)}", mode)  # modes start every case id
        modes[mode] = flatten(updates, f"load_modes.{mode}")
        if sum(k in modes[mode] for k in LOAD_KEYS) != 1:
            raise MatrixError(f"load_modes.{mode}: set exactly one of {' / '.join(LOAD_KEYS)}")
    return modes


def _sweep_specs(sweeps_in: Any, n_modes: int) -> list[SweepSpec]:
    """The ``[[sweep]]`` tables checked, with their points; at most :data:`MAX_MATRIX_CASES` cases in all."""
    if not isinstance(sweeps_in, list) or not sweeps_in:
        raise MatrixError("sweep: expected [[sweep]] tables, or none (the base case alone)")
    specs, total = [], 0
    for i, sw in enumerate(sweeps_in):
        where = f"sweep[{i}]"
        if not isinstance(sw, dict):
            raise MatrixError(f"{where}: expected a table, got {show(sw)}")
        check_keys(where, sw, _SWEEP_KEYS, MatrixError)
        sw_name = check_file_name(f"{where}.name", sw.get("name", f"sweep{i + 1}"))
        include_base = sw.get("include_base", True)
        if not isinstance(include_base, bool):
            raise MatrixError(f"{where}.include_base: expected true or false, got {show(include_base)}")
        expect = check_expect(f"{where}.expect", sw.get("expect"))
        points, keys = sweep_points(sw, where, MAX_MATRIX_CASES - total)
        total += len(points) + include_base
        if total * n_modes > MAX_MATRIX_CASES:
            raise MatrixError(
                f"{where}: the matrix expands to more than {MAX_MATRIX_CASES:,} cases "
                f"({n_modes} load modes x sweep points); split it into several matrices"
            )
        label = _text(f"{where}.label", sw.get("label", sw_name))
        specs.append(SweepSpec(sw_name, label, keys, points, include_base, expect))
    names = [s.name for s in specs]
    if len(set(names)) != len(names):
        raise MatrixError(f"sweep: names must be unique, got {names}")
    return specs


def read_matrix(source: str | Path | Case | None = None) -> Matrix:
    """Read and expand a matrix file of the slider crank's format, or a bundled one by name (default:
    ``thesis-1991``).

    A slider crank's case file, preset or :class:`Case` is also accepted: it becomes :func:`design_matrix`.
    Every other source is :mod:`~dualmech.validation.matrix.cases`'s (:func:`~dualmech.validation.matrix.
    sources.load_matrix` decides).
    """
    if isinstance(source, Case) or (source is not None and is_case_source(source)):
        return design_matrix(source)
    path = matrix_path(DEFAULT_MATRIX if source is None else source)
    return parse_matrix(read_toml(path, MatrixError), source=str(path), matrix_file=path)


def is_case_source(source: str | Path) -> bool:
    """Whether ``source`` names a case, not a matrix: a preset, or a TOML file with a ``[geometry]`` table."""
    if str(source) in preset_names():
        return True
    path = Path(source)
    return path.is_file() and "geometry" in read_toml(path, MatrixError)


def design_matrix(source: str | Path | Case) -> Matrix:
    """The matrix of one design: case ``source`` (file, preset or a :class:`Case` built in Python) in its
    own load, on every engine.

    Its name (and so the default output folder ``runs/<name>``) is the case's name made
    file-name safe; the reference is ``dualmech`` and every other engine judges it.
    """
    case = source if isinstance(source, Case) else load_case(source)
    name = ID_SAFE.sub("_", case.name).strip("._-")[:MAX_DESIGN_NAME] or "design"
    data = {
        "name": name,
        "description": f"one design: {case.name}",
        "base": case if isinstance(source, Case) else str(source),
        "base_label": "design",
        "engines": list(engines_for(SLIDER_CRANK)),
        "reference": "dualmech",
    }
    return parse_matrix(data, source=case.name if isinstance(source, Case) else str(source), matrix_file=None)
