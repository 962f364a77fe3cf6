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

    [tolerances]                      # optional; defaults: DEFAULT_TOLERANCES below
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

Tolerances are looked up, most specific first: ``[tolerances.<engine>]``
quantity, then its group (``kinematics``, ``reactions``, ``stroke``), then the
same in ``[tolerances]``, then :data:`DEFAULT_TOLERANCES`.
"""

from __future__ import annotations

import itertools
import math
import re
from dataclasses import dataclass, field, replace
from importlib import resources
from pathlib import Path
from typing import Any

from dualmech.core.table import KINEMATIC_COLUMNS, REACTION_COLUMNS
from dualmech.models.case import Case, case_from_dict, load_case, preset_names
from dualmech.models.inputs import Range, check_text, key_text, show
from dualmech.models.toml_input import read_toml
from dualmech.validation import tolerances as tolerance_table
from dualmech.validation.engines import ENGINES
from dualmech.validation.tolerances import Tolerance

#: Columns a matrix may compare, in report order. ``residual`` is each engine's own
#: closure residual and is reported, not compared; ``theta1_deg`` is the abscissa.
COMPARABLE: tuple[str, ...] = (
    tuple(c for c in KINEMATIC_COLUMNS if c != "theta1_deg") + ("transmission",) + REACTION_COLUMNS
)
#: Tolerance groups: every comparable column belongs to exactly one; ``stroke`` is the
#: stroke difference (max S4 - min S4) of a judge against the reference.
GROUPS: dict[str, tuple[str, ...]] = {
    "kinematics": tuple(c for c in COMPARABLE if c not in REACTION_COLUMNS),
    "reactions": REACTION_COLUMNS,
    "stroke": ("stroke",),
    # status agreement bands (validation/compare.py): not columns, but judged per engine like them
    "dead_centre_band": ("dead_centre_band",),
    "assembly_limit_band": ("assembly_limit_band",),
}
#: Pseudo-quantities of the status agreement rules (validation/compare.py), resolved per judge like columns.
STATUS_BANDS: tuple[str, ...] = ("dead_centre_band", "assembly_limit_band")
#: Default tolerance names (in ``validation/tolerances.py``) per engine and group;
#: ``"*"`` is every judge not listed.  The rigid-body judges are held to the
#: issues' figures (1e-10 kinematics, 1e-9 reactions); the simulation more loosely:
#: it integrates the motion under servos and holds the loop by a soft constraint.
DEFAULT_TOLERANCES: dict[str, dict[str, str]] = {
    "*": {"kinematics": "MATRIX_KINEMATICS", "reactions": "MATRIX_REACTIONS", "stroke": "MATRIX_KINEMATICS",
          "dead_centre_band": "DEAD_CENTRE_STATUS_BAND", "assembly_limit_band": "ASSEMBLY_LIMIT_STATUS_BAND"},
    "pinocchio": {"kinematics": "PINOCCHIO_KINEMATICS", "reactions": "PINOCCHIO_REACTIONS",
                  "stroke": "PINOCCHIO_KINEMATICS", "dead_centre_band": "DEAD_CENTRE_STATUS_BAND",
                  "assembly_limit_band": "ASSEMBLY_LIMIT_STATUS_BAND"},
    "mujoco": {"kinematics": "MUJOCO_RIGID_KINEMATICS", "reactions": "MUJOCO_RIGID_REACTIONS",
               "stroke": "MUJOCO_RIGID_KINEMATICS", "dead_centre_band": "DEAD_CENTRE_STATUS_BAND",
               "assembly_limit_band": "ASSEMBLY_LIMIT_STATUS_BAND"},
    "mujoco-sim": {"kinematics": "MATRIX_SIM_KINEMATICS", "reactions": "SIM_REACTIONS", "stroke": "SIM_STROKE",
                   "dead_centre_band": "SIM_DEAD_CENTRE_STATUS_BAND",
                   "assembly_limit_band": "SIM_ASSEMBLY_LIMIT_STATUS_BAND"},
}
#: Short symbols for the thesis's link-joint constants (ids and legends).
DEFAULT_LABELS: dict[str, str] = {
    "geometry.crank_length": "a1",
    "geometry.rod_length": "a2",
    "geometry.slider_offset": "a4",
    "geometry.slider_twist_deg": "alpha4",
    "geometry.crank_axial_shift": "S1",
    "loads.drive_torque": "T",
    "loads.slider_force": "F",
}
_LOAD_KEYS = ("loads.drive_torque", "loads.slider_force")
_TOP_KEYS = {
    "name", "description", "base", "base_label", "engines", "reference", "quantities",
    "set", "labels", "load_modes", "sweep", "tolerances",
}
_SWEEP_KEYS = {"name", "label", "fixed", "grid", "cases", "include_base", "expect"}
_ID_SAFE = re.compile(r"[^A-Za-z0-9.=+_-]")
#: Declared expectations a sweep may state (``expect = ...``), with what each means.
EXPECTATIONS: dict[str, str] = {"no_assembly": "every case assembles at no crank position, on every engine"}
#: Most cases one matrix may expand to (modes x sweep points): each runs on every engine,
#: and 1,000 cases of 360 positions take ~8 min on the slowest judge (MuJoCo simulation,
#: 1.3 ms per position, README "Speed") on one core.
MAX_MATRIX_CASES = 1000
#: Most crank positions of one case in a validation run: every engine's whole table of a case is
#: held, stored and compared at once (~30 columns x 4 engines x 8 bytes x this, well under 1 GiB
#: with Python's overheads); longer studies stream through ``dualmech solve`` in chunks.
MAX_VALIDATE_POSITIONS = 20_000
#: Longest name that becomes a file or folder name (matrix name, case ids), characters.
MAX_NAME_CHARS = 100
#: Longest description or sweep label, characters (one line of a report).
MAX_TEXT_CHARS = 2000
#: A name safe as one file or folder name on any system: starts with a letter or digit.
_FILE_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9.=+_-]*")
#: Tolerances given as numbers: relative, so from 0 to 1 (beyond 100 % says nothing).
TOLERANCE_VALUE = Range(0.0, 1.0, "a relative tolerance")


class MatrixError(ValueError):
    """A matrix file or value that cannot be used; the message is one line."""


def check_file_name(key: str, name: Any) -> str:
    """``name`` if it is safe as one file or folder name, else a one-line :class:`MatrixError`.

    Safe: a non-empty string of at most :data:`MAX_NAME_CHARS` letters, digits and
    ``. _ + - =``, starting with a letter or digit, without ``..``.  So no path
    separator, no absolute path, no parent folder, no NUL or control character, no
    hidden file, nothing an option parser could take for an option.
    """
    if not isinstance(name, str) or not name:
        raise MatrixError(f"{key}: expected a non-empty name, got {show(name)}")
    bad = next((c for c in name if not (c.isascii() and (c.isalnum() or c in ".=+_-"))), None)
    why = (f"{len(name)} characters, more than {MAX_NAME_CHARS}" if len(name) > MAX_NAME_CHARS
           else f"{bad!r} is not allowed" if bad is not None
           else "'..' is not allowed" if ".." in name
           else "it must start with a letter or digit" if not _FILE_NAME.fullmatch(name) else "")
    if why:
        raise MatrixError(f"{key}: {show(name)} cannot be a file or folder name: {why} (use letters, digits "
                          f"and . _ + - =, at most {MAX_NAME_CHARS} characters)")
    return name


@dataclass(frozen=True)
class MatrixCase:
    """One concrete case of a matrix.

    Attributes
    ----------
    id : str
        Unique, file-name safe identifier, e.g. ``"torque_a4=10_S1=3.5"``.
    raw : dict
        The case table (as :func:`~dualmech.models.case.case_from_dict` takes it).
    mode : str
        Load mode name (``"torque"``, ``"force"``, or the base case's own mode).
    values : dict[str, Any]
        The dotted keys that differ from the base case, and their values.
    sweeps : tuple[str, ...]
        Names of the sweeps this case belongs to.
    labels : dict[str, str]
        Legend text per sweep name (only the keys that sweep varies, e.g. ``"a4=10"``;
        the base label for the base case).
    is_base : bool
        Whether this is the base case (in its load mode).
    expect : str or None
        The declared expectation of its sweep (a key of :data:`EXPECTATIONS`, e.g.
        ``"no_assembly"``), or ``None``: the case is expected to assemble.
    """

    id: str
    raw: dict
    mode: str
    values: dict[str, Any]
    sweeps: tuple[str, ...]
    labels: dict[str, str]
    is_base: bool
    expect: str | None = None

    def case(self) -> Case:
        """Build the :class:`~dualmech.models.case.Case`."""
        return case_from_dict(self.raw)


@dataclass(frozen=True)
class Sweep:
    """A named family of cases drawn together (e.g. the a4 sweep), per load mode."""

    name: str
    label: str
    keys: tuple[str, ...]  # the dotted keys it varies
    case_ids: dict[str, tuple[str, ...]]  # load mode -> case ids, base case first


@dataclass(frozen=True)
class ResolvedTolerance:
    """The tolerance applied to one (judge, quantity): its table name, value and reason."""

    name: str
    value: float
    reason: str


@dataclass(frozen=True)
class Matrix:
    """An expanded validation matrix (see the module docstring for the file format)."""

    name: str
    description: str
    source: str
    reference: str
    engines: tuple[str, ...]
    quantities: tuple[str, ...]
    modes: tuple[str, ...]
    cases: tuple[MatrixCase, ...]
    sweeps: tuple[Sweep, ...]
    labels: dict[str, str]
    tolerances: dict[str, dict[str, ResolvedTolerance]] = field(repr=False)  # judge -> quantity -> tol
    base: str = ""  # the base case as the file names it (a preset name or a case file)

    @property
    def of_thesis(self) -> bool:
        """Whether the base case is one of the thesis's presets (its findings then apply)."""
        return self.base.startswith(THESIS_PRESETS)

    @property
    def judges(self) -> tuple[str, ...]:
        """Engines compared against the reference."""
        return tuple(e for e in self.engines if e != self.reference)

    def tolerance(self, engine: str, quantity: str) -> ResolvedTolerance:
        """Tolerance for ``quantity`` (a column or ``"stroke"``) of judge ``engine``."""
        try:
            return self.tolerances[engine][quantity]
        except KeyError:
            raise MatrixError(f"tolerance: no entry for engine {engine!r}, quantity {quantity!r}") from None

    def case_by_id(self, case_id: str) -> MatrixCase:
        """The case named ``case_id``."""
        for c in self.cases:
            if c.id == case_id:
                return c
        raise MatrixError(f"case: {case_id!r} is not in matrix {self.name!r}")

    def with_engines(self, engines: tuple[str, ...]) -> "Matrix":
        """The same matrix run on ``engines`` (must include the reference)."""
        engines = tuple(dict.fromkeys(engines))
        _check_engines(engines, self.reference)
        tols = {e: self.tolerances.get(e) or {} for e in engines if e != self.reference}
        missing = [e for e, t in tols.items() if not t]
        if missing:
            raise MatrixError(f"engines: {missing[0]!r} has no tolerances in matrix {self.name!r}")
        return replace(self, engines=engines, tolerances=tols)

    def to_dict(self) -> dict:
        """JSON-ready form; :func:`matrix_from_dict` reads it back (used by stored runs)."""
        return {
            "name": self.name,
            "description": self.description,
            "source": self.source,
            "base": self.base,
            "reference": self.reference,
            "engines": list(self.engines),
            "quantities": list(self.quantities),
            "modes": list(self.modes),
            "labels": dict(self.labels),
            "cases": [
                {"id": c.id, "raw": c.raw, "mode": c.mode, "values": c.values, "sweeps": list(c.sweeps),
                 "labels": c.labels, "is_base": c.is_base, "expect": c.expect}
                for c in self.cases
            ],
            "sweeps": [
                {"name": s.name, "label": s.label, "keys": list(s.keys),
                 "case_ids": {m: list(ids) for m, ids in s.case_ids.items()}}
                for s in self.sweeps
            ],
            "tolerances": {
                e: {q: {"name": t.name, "value": t.value, "reason": t.reason} for q, t in qs.items()}
                for e, qs in self.tolerances.items()
            },
        }


def matrix_from_dict(d: dict) -> Matrix:
    """Inverse of :meth:`Matrix.to_dict`.

    The names that become file or folder names are checked again (a stored run may
    have been edited); a stored run without ``expect`` (older) reads as ``None``.
    """
    check_file_name("name", d["name"])
    for c in d["cases"]:
        check_file_name("case id", c["id"])
        _check_expect(f"case {c['id']}.expect", c.get("expect"))
    return Matrix(
        name=d["name"],
        description=d["description"],
        source=d["source"],
        base=d.get("base", ""),
        reference=d["reference"],
        engines=tuple(d["engines"]),
        quantities=tuple(d["quantities"]),
        modes=tuple(d["modes"]),
        cases=tuple(
            MatrixCase(c["id"], c["raw"], c["mode"], c["values"], tuple(c["sweeps"]), dict(c["labels"]),
                       c["is_base"], c.get("expect"))
            for c in d["cases"]
        ),
        sweeps=tuple(
            Sweep(s["name"], s["label"], tuple(s["keys"]), {m: tuple(ids) for m, ids in s["case_ids"].items()})
            for s in d["sweeps"]
        ),
        labels=dict(d["labels"]),
        tolerances={
            e: {q: ResolvedTolerance(t["name"], float(t["value"]), t["reason"]) for q, t in qs.items()}
            for e, qs in d["tolerances"].items()
        },
    )


# ----------------------------------------------------------------------------- file lookup

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
    raise MatrixError(f"matrix: {show(str(source))} is neither a file nor a bundled matrix "
                      f"({', '.join(names)})")


DEFAULT_MATRIX = "thesis-1991"
#: Base-case names of the thesis's worked example (its printed findings are about these).
THESIS_PRESETS: tuple[str, ...] = ("thesis/",)
#: The one sweep of a matrix that declares none: the base case alone.
BASE_ALONE: list[dict] = [{"name": "design", "label": "the base case alone", "cases": [{}], "include_base": False}]
#: Longest name a design matrix takes from its case (it becomes a folder name).
MAX_DESIGN_NAME = 80


# ----------------------------------------------------------------------------- parsing

def _flatten(table: Any, where: str, *, leaf_lists: bool = False) -> dict[str, Any]:
    """``{"a": {"b": 1}, "c.d": 2}`` -> ``{"a.b": 1, "c.d": 2}`` (TOML dotted or quoted keys).

    With ``leaf_lists`` the leaves are lists of values (a grid axis), and nesting stops there.
    """
    if not isinstance(table, dict):
        raise MatrixError(f"{where}: expected a table of dotted case keys, got {show(table)}")
    flat: dict[str, Any] = {}

    def walk(node: dict, prefix: str) -> None:
        for key, value in node.items():
            dotted = f"{prefix}.{key}" if prefix else key
            if isinstance(value, dict) and not (leaf_lists is False and _is_case_table(dotted)):
                walk(value, dotted)
            else:
                if dotted in flat:
                    raise MatrixError(f"{where}.{key_text(dotted)}: given twice")
                flat[dotted] = value

    walk(table, "")
    if leaf_lists:
        for key, value in flat.items():
            if not isinstance(value, list) or not value:
                raise MatrixError(f"{where}.{key_text(key)}: expected a non-empty array of values, "
                                  f"got {show(value)}")
    return flat


def _is_case_table(dotted: str) -> bool:
    """Case keys whose value is itself a table (set as a whole, not flattened further)."""
    return dotted in {"motion.angles_deg"} or (dotted.startswith("bodies.") and dotted.count(".") == 1
                                                and dotted.split(".")[1] in {"crank", "rod", "slider"})


def _check_engines(engines: tuple[str, ...], reference: str) -> None:
    for e in engines:
        if e not in ENGINES:
            raise MatrixError(f"engines: {show(e)} is not an engine (valid: {', '.join(ENGINES)})")
    if reference not in engines:
        raise MatrixError(f"reference: {show(reference)} must be one of the engines {list(engines)}")
    if len(engines) < 2:
        raise MatrixError(f"engines: {list(engines)} has no judge beside the reference {reference!r}")


def _tolerance_value(spec: Any, where: str) -> ResolvedTolerance:
    if isinstance(spec, str):
        tol = getattr(tolerance_table, spec, None)
        if not isinstance(tol, Tolerance):
            names = sorted(n for n, v in vars(tolerance_table).items() if isinstance(v, Tolerance))
            raise MatrixError(f"{where}: {show(spec)} is not a tolerance in validation/tolerances.py "
                              f"({', '.join(names)})")
        return ResolvedTolerance(spec, float(tol.value), tol.reason)
    try:
        value = TOLERANCE_VALUE.check(where, spec)
    except ValueError as err:
        raise MatrixError(f"{err} (or a tolerance name)") from None
    return ResolvedTolerance(f"{where}", value, "set in the matrix file")


def _group_of(quantity: str) -> str:
    return next(g for g, cols in GROUPS.items() if quantity in cols)


def resolve_tolerances(table: Any, judges: tuple[str, ...],
                       quantities: tuple[str, ...]) -> dict[str, dict[str, ResolvedTolerance]]:
    """Each judge's tolerance for every quantity, the stroke and the status bands.

    Parameters
    ----------
    table : dict or None
        The matrix file's ``[tolerances]`` table: ``quantity|group = value|name`` for every judge and
        ``[tolerances.<engine>]`` sub-tables for one judge; ``None`` for none.
    judges : tuple of str
        Engine names to resolve for.
    quantities : tuple of str
        Compared columns (a subset of ``COMPARABLE``).

    Returns
    -------
    dict
        ``{judge: {quantity: ResolvedTolerance}}``; the most specific setting wins
        (judge.quantity, judge.group, quantity, group), else the judge's default of the group.

    Raises
    ------
    MatrixError
        An unknown engine, quantity or group, or a value that is neither a number nor a tolerance name.
    """
    table = {} if table is None else table
    if not isinstance(table, dict):
        raise MatrixError(f"tolerances: expected a table, got {show(table)}")
    valid_keys = set(COMPARABLE) | set(GROUPS)
    general = {k: v for k, v in table.items() if not isinstance(v, dict)}
    per_engine = {k: v for k, v in table.items() if isinstance(v, dict)}
    for e, entries in per_engine.items():
        if e not in ENGINES:
            raise MatrixError(f"tolerances.{key_text(e)}: not an engine (valid: {', '.join(ENGINES)})")
        for k in entries:
            if k not in valid_keys:
                raise MatrixError(f"tolerances.{e}.{key_text(k)}: not a quantity or group "
                                  f"({', '.join(sorted(GROUPS))}, or a column)")
    for k in general:
        if k not in valid_keys:
            raise MatrixError(f"tolerances.{key_text(k)}: not a quantity or group "
                              f"({', '.join(sorted(GROUPS))}, or a column)")
    resolved: dict[str, dict[str, ResolvedTolerance]] = {}
    for e in judges:
        mine = per_engine.get(e, {})
        defaults = DEFAULT_TOLERANCES.get(e, DEFAULT_TOLERANCES["*"])
        resolved[e] = {}
        for q in (*quantities, "stroke", *STATUS_BANDS):
            g = _group_of(q)
            for where, src, key in ((f"tolerances.{e}.{q}", mine, q), (f"tolerances.{e}.{g}", mine, g),
                                    (f"tolerances.{q}", general, q), (f"tolerances.{g}", general, g)):
                if key in src:
                    resolved[e][q] = _tolerance_value(src[key], where)
                    break
            else:
                resolved[e][q] = _tolerance_value(defaults[g], f"default {g}")
    return resolved


def _format_value(v: Any) -> str:
    if isinstance(v, bool):
        return str(v).lower()
    if isinstance(v, float) or (isinstance(v, int) and v.bit_length() <= 1000):  # larger: no float
        return f"{v:g}"
    return _ID_SAFE.sub("_", show(v))[:24]


def _text(key: str, value: Any) -> str:
    """A one-line printable text (description, sweep label), else a one-line :class:`MatrixError`."""
    try:
        return check_text(key, value, MAX_TEXT_CHARS)
    except ValueError as err:
        raise MatrixError(str(err)) from None


def _check_positions(case_id: str, case: Case) -> None:
    """Refuse a case with more crank positions than :data:`MAX_VALIDATE_POSITIONS` (one line)."""
    n = int(case.motion.angles_deg.size)
    if n > MAX_VALIDATE_POSITIONS:
        raise MatrixError(f"case {case_id}: motion.angles_deg gives {n:,} crank positions; a validation run "
                          f"compares whole tables, at most {MAX_VALIDATE_POSITIONS:,} per case (use a coarser step, "
                          "or `dualmech solve`, which streams any length)")


def _check_expect(key: str, value: Any) -> str | None:
    """A declared expectation: ``None`` or a key of :data:`EXPECTATIONS`."""
    if value is not None and (not isinstance(value, str) or value not in EXPECTATIONS):
        raise MatrixError(f"{key}: {show(value)} is not an expectation (valid: "
                          + "; ".join(f"{k!r}: {v}" for k, v in EXPECTATIONS.items()) + ")")
    return value


def _expected(expect: str | None) -> str:
    return "to assemble" if expect is None else f"{expect!r}"


def _canonical(updates: dict[str, Any], base_raw: dict, order: list[str]) -> dict[str, Any]:
    """Updates that change the base case, in a stable key order."""
    out = {}
    for key in sorted(updates, key=order.index):
        node: Any = base_raw
        for part in key.split("."):
            node = node.get(part, _MISSING) if isinstance(node, dict) else _MISSING
        if node is _MISSING or node != updates[key]:
            out[key] = updates[key]
    return out


_MISSING = object()


def _with_mode(base: Case, mode_updates: dict[str, Any]) -> Case:
    """The base case switched to a load mode: the other load key is removed first.

    A case takes exactly one of the two loads, so this step cannot go through
    :meth:`Case.with_values`, which only sets keys; the remaining keys of the mode do.
    Without a load key (a matrix without ``[load_modes]``) the base case keeps its load.
    """
    load_key = next((k for k in _LOAD_KEYS if k in mode_updates), None)
    if load_key is None:
        return base.with_values({**mode_updates, "name": base.name})
    raw = {k: (dict(v) if isinstance(v, dict) else v) for k, v in base.raw.items()}
    loads = {k: v for k, v in raw.get("loads", {}).items() if f"loads.{k}" not in _LOAD_KEYS}
    loads[load_key.split(".")[1]] = mode_updates[load_key]
    raw["loads"] = loads
    rest = {k: v for k, v in mode_updates.items() if k != load_key}
    return case_from_dict(raw).with_values({**rest, "name": base.name})


def _load_base(spec: Any, matrix_file: Path | None) -> Case:
    if not isinstance(spec, str):
        raise MatrixError(f"base: expected a preset name or a case file, got {show(spec)}")
    if matrix_file is not None:
        candidate = matrix_file.parent / spec
        if candidate.is_file():
            return load_case(candidate)
    return load_case(spec)


def _sweep_points(sweep: dict, where: str, room: int) -> tuple[list[dict[str, Any]], tuple[str, ...]]:
    """The update dicts of one sweep (fixed values merged in) and the keys it varies.

    ``room`` is how many more cases the matrix may hold; a larger sweep is refused
    before its points are built.
    """
    fixed = _flatten(sweep.get("fixed", {}), f"{where}.fixed")
    has_grid, has_cases = "grid" in sweep, "cases" in sweep
    if has_grid == has_cases:
        raise MatrixError(f"{where}: give exactly one of grid (a Cartesian product) or cases (a list)")
    too_many = (f"{where}: more than {MAX_MATRIX_CASES:,} cases in the matrix (this sweep "
                "{} points); split it into several matrices")
    if has_grid:
        grid = _flatten(sweep["grid"], f"{where}.grid", leaf_lists=True)
        keys = tuple(grid)
        size = math.prod(len(v) for v in grid.values())
        if size > room:
            raise MatrixError(too_many.format(f"{size:,}"))
        points = [dict(zip(keys, combo)) for combo in itertools.product(*grid.values())]
    else:
        if not isinstance(sweep["cases"], list) or not sweep["cases"]:
            raise MatrixError(f"{where}.cases: expected a non-empty array of tables, "
                              f"got {show(sweep['cases'])}")
        if len(sweep["cases"]) > room:
            raise MatrixError(too_many.format(f"{len(sweep['cases']):,}"))
        points = [_flatten(p, f"{where}.cases[{i}]") for i, p in enumerate(sweep["cases"])]
        keys = tuple(dict.fromkeys(k for p in points for k in p))
    for p in points:
        clash = set(p) & set(fixed)
        if clash:
            raise MatrixError(f"{where}: {key_text(sorted(clash)[0])} is both fixed and swept")
    return [{**fixed, **p} for p in points], keys


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
    engines = data.get("engines", list(ENGINES))
    if not isinstance(engines, list) or not all(isinstance(e, str) for e in engines):
        raise MatrixError(f"engines: expected an array of engine names, got {show(engines)}")
    reference = data.get("reference", "dualmech")
    engines_t = tuple(dict.fromkeys(engines))
    _check_engines(engines_t, reference)
    quantities = data.get("quantities", list(COMPARABLE))
    if not isinstance(quantities, list) or not quantities:
        raise MatrixError(f"quantities: expected a non-empty array of column names, got {show(quantities)}")
    for q in quantities:
        if q not in COMPARABLE:
            raise MatrixError(f"quantities: {show(q)} is not a compared column "
                              f"(valid: {', '.join(COMPARABLE)})")
    quantities_t = tuple(q for q in COMPARABLE if q in quantities)

    labels = dict(DEFAULT_LABELS)
    for key, symbol in _flatten(data.get("labels", {}), "labels").items():
        labels[key] = check_file_name(f"labels.{key_text(key)}", symbol)  # symbols become part of case ids
    base_label = check_file_name("base_label", data.get("base_label", "base"))

    try:
        base = _load_base(data.get("base"), matrix_file)
        common = _flatten(data.get("set", {}), "set")
        if common:
            base = base.with_values({**common, "name": base.name})
    except ValueError as err:
        raise MatrixError(f"base: {err}") from None

    modes_table = data.get("load_modes")
    if modes_table is None:
        modes = {base.loads.mode: {}}
    else:
        if not isinstance(modes_table, dict) or not modes_table:
            raise MatrixError(f"load_modes: expected a table of mode = {{ key = value }}, "
                              f"got {show(modes_table)}")
        modes = {}
        for mode, updates in modes_table.items():
            check_file_name(f"load_modes.{key_text(mode)}", mode)  # modes start every case id
            modes[mode] = _flatten(updates, f"load_modes.{mode}")
            if sum(k in modes[mode] for k in _LOAD_KEYS) != 1:
                raise MatrixError(f"load_modes.{mode}: set exactly one of {' / '.join(_LOAD_KEYS)}")

    sweeps_in = data.get("sweep", BASE_ALONE)
    if not isinstance(sweeps_in, list) or not sweeps_in:
        raise MatrixError("sweep: expected [[sweep]] tables, or none (the base case alone)")
    expanded, total = [], 0
    for i, sw in enumerate(sweeps_in):
        where = f"sweep[{i}]"
        if not isinstance(sw, dict):
            raise MatrixError(f"{where}: expected a table, got {show(sw)}")
        for key in sw:
            if key not in _SWEEP_KEYS:
                raise MatrixError(f"{where}.{key_text(key)}: unknown key "
                                  f"(valid: {', '.join(sorted(_SWEEP_KEYS))})")
        sw_name = check_file_name(f"{where}.name", sw.get("name", f"sweep{i + 1}"))
        include_base = sw.get("include_base", True)
        if not isinstance(include_base, bool):
            raise MatrixError(f"{where}.include_base: expected true or false, got {show(include_base)}")
        expect = _check_expect(f"{where}.expect", sw.get("expect"))
        points, keys = _sweep_points(sw, where, MAX_MATRIX_CASES - total)
        total += len(points) + include_base
        if total * len(modes) > MAX_MATRIX_CASES:
            raise MatrixError(f"{where}: the matrix expands to more than {MAX_MATRIX_CASES:,} cases "
                              f"({len(modes)} load modes x sweep points); split it into several matrices")
        label = _text(f"{where}.label", sw.get("label", sw_name))
        expanded.append((sw_name, label, keys, points, include_base, expect))
    names = [e[0] for e in expanded]
    if len(set(names)) != len(names):
        raise MatrixError(f"sweep: names must be unique, got {names}")

    appearance = list(dict.fromkeys(k for e in expanded for p in e[3] for k in p))
    known = list(DEFAULT_LABELS)
    order = sorted(appearance, key=lambda k: (known.index(k) if k in known else len(known), appearance.index(k)))
    cases: dict[str, dict] = {}
    sweeps = []
    for mode, mode_updates in modes.items():
        try:
            mode_base = _with_mode(base, mode_updates)
        except ValueError as err:
            raise MatrixError(f"load_modes.{mode}: {err}") from None
        for sw_name, sw_label, keys, points, include_base, expect in expanded:
            ids = []
            added_base = [{}] if include_base else []
            for k, point in enumerate(added_base + points):
                values = _canonical(point, mode_base.raw, order)
                is_base = not values
                case_id = "_".join([mode, base_label] if is_base else
                                   [mode] + [f"{labels.get(k, k)}={_format_value(v)}" for k, v in values.items()])
                case_id = check_file_name(f"sweep {sw_name} ({mode}): case id", _ID_SAFE.sub("_", case_id))
                if case_id not in cases:
                    try:
                        case = mode_base.with_values({**values, "name": case_id})
                    except ValueError as err:
                        raise MatrixError(f"sweep {sw_name} ({mode}): {err}") from None
                    _check_positions(case_id, case)
                    cases[case_id] = {"raw": case.raw, "mode": mode, "values": values, "sweeps": [],
                                      "labels": {}, "is_base": is_base, "declared": {}}
                elif cases[case_id]["values"] != values:
                    raise MatrixError(f"sweep {sw_name}: two different cases share the id {case_id!r}; set [labels]")
                entry = cases[case_id]
                if k >= len(added_base):  # a point of the sweep: its expectation applies
                    entry["declared"][sw_name] = expect
                    if len(set(entry["declared"].values())) > 1:
                        first, first_expect = next(iter(entry["declared"].items()))
                        raise MatrixError(f"sweep {sw_name}: case {case_id} is expected {_expected(expect)} "
                                          f"here but {_expected(first_expect)} by sweep {first}")
                if sw_name not in entry["sweeps"]:
                    entry["sweeps"].append(sw_name)
                shown = {k: v for k, v in values.items() if k in keys} or values
                entry["labels"][sw_name] = base_label if is_base else ", ".join(
                    f"{labels.get(k, k)}={_format_value(v)}" for k, v in shown.items())
                if case_id not in ids:
                    ids.append(case_id)
            sweeps.append((sw_name, sw_label, keys, mode, tuple(ids)))

    sweep_objs = []
    for sw_name, sw_label, keys, *_ in expanded:
        per_mode = {mode: ids for n, _, _, mode, ids in sweeps if n == sw_name}
        sweep_objs.append(Sweep(sw_name, sw_label, keys, per_mode))
    matrix_cases = tuple(
        MatrixCase(cid, e["raw"], e["mode"], e["values"], tuple(e["sweeps"]), e["labels"], e["is_base"],
                   next(iter(e["declared"].values()), None))
        for cid, e in cases.items()
    )
    judges = tuple(e for e in engines_t if e != reference)
    return Matrix(
        name=name,
        description=description,
        source=source,
        base=data["base"],
        reference=reference,
        engines=engines_t,
        quantities=quantities_t,
        modes=tuple(modes),
        cases=matrix_cases,
        sweeps=tuple(sweep_objs),
        labels=labels,
        tolerances=resolve_tolerances(data.get("tolerances"), judges, quantities_t),
    )


def load_matrix(source: str | Path | None = None) -> Matrix:
    """Read and expand a matrix file, or a bundled matrix by name (default: ``thesis-1991``).

    A case file or a case preset is also accepted: it becomes :func:`design_matrix`.
    """
    if source is not None and is_case_source(source):
        return design_matrix(source)
    path = matrix_path(DEFAULT_MATRIX if source is None else source)
    return parse_matrix(read_toml(path, MatrixError), source=str(path), matrix_file=path)


def is_case_source(source: str | Path) -> bool:
    """Whether ``source`` names a case (a preset, or a TOML file with a ``[geometry]`` table), not a matrix."""
    if str(source) in preset_names():
        return True
    path = Path(source)
    return path.is_file() and "geometry" in read_toml(path, MatrixError)


def design_matrix(source: str | Path) -> Matrix:
    """The matrix of one design: case ``source`` (file or preset) in its own load, on every engine.

    Its name (and so the default output folder ``runs/<name>``) is the case's name made
    file-name safe; the reference is ``dualmech`` and every other engine judges it.
    """
    case = load_case(source)
    name = _ID_SAFE.sub("_", case.name).strip("._-")[:MAX_DESIGN_NAME] or "design"
    data = {"name": name, "description": f"one design: {case.name}", "base": str(source),
            "base_label": "design", "engines": list(ENGINES), "reference": "dualmech"}
    return parse_matrix(data, source=str(source), matrix_file=None)
