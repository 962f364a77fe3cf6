"""The tolerance SPEC: which case keys vary, and by which distribution around their nominal values.

A SPEC is a TOML file (``docs/conventions.md``, "Tolerance analysis")::

    description = "the offsets of the thesis, section 3.2, as tolerance ranges"
    [tolerances]
    "geometry.slider_offset" = { dist = "uniform", low = -10.0, high = 10.0 }
    "geometry.slider_twist_deg" = { dist = "normal", sd = 2.0 }
    "geometry.crank_axial_shift" = { dist = "truncnormal", sd = 1.0, low = -2.0, high = 2.0 }

Every offset is added to the case's nominal value of the key, in the case's units (degrees for
angles).  Nested tables (``[tolerances.geometry]`` with ``slider_offset = {...}``) are the same
keys.  Errors are :class:`SpecError` (a ``ValueError``): one line naming the key, the value
received and what would be valid.  A sampled design is built by
:func:`~dualmech.models.case.case_from_dict`, so every perturbed value is checked by the case
loader's own ranges (``docs/conventions.md``, "Input ranges").
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from scipy.special import ndtr

from dualmech.models.case import Case, case_from_dict
from dualmech.models.inputs import CaseError, Range, check_keys, key_text, show
from dualmech.models.toml_input import read_toml


class SpecError(ValueError):
    """A tolerance SPEC that cannot be used; the message is one line."""


#: Slider-crank case keys a SPEC may vary (scalars of the case file; ``docs/conventions.md``, "Case files";
#: another kind's: :mod:`~dualmech.models.tolerance.tables`).
#: Body masses may be varied even when the case derives them from a shape and a density: the
#: sampled design then states the mass, and the inertia keeps its shape (scaled by the mass).
KEYS: tuple[str, ...] = (
    "geometry.crank_length", "geometry.rod_length", "geometry.slider_offset", "geometry.slider_twist_deg",
    "geometry.crank_axial_shift", "motion.axial_amplitude", "motion.crank_rpm",
    "bodies.crank_radius", "bodies.rod_radius", "bodies.slider_side", "bodies.density",
    "bodies.weight_density",
    "bodies.crank.mass", "bodies.rod.mass", "bodies.slider.mass", "loads.drive_torque", "loads.slider_force",
)
#: Parameters of each distribution (offsets from nominal, the key's units).
DISTRIBUTIONS: dict[str, tuple[str, ...]] = {
    "normal": ("sd",),
    "uniform": ("low", "high"),
    "truncnormal": ("sd", "low", "high"),
}
#: Most keys in one SPEC: each is an input of the sensitivities and of the Sobol estimates, and costs its own
#: solves of the sensitivity check (nine designs); a loop table of six joints states about 32 numbers.
MAX_KEYS = 32
#: Bound on any offset parameter: the case loader's bound on its numbers (``SCALE``).
OFFSET = Range(-1e15, 1e15, "an offset in the key's units")
#: A truncated normal must keep at least this probability mass, else its samples lose precision.
MIN_TRUNC_MASS = 1e-12


@dataclass(frozen=True)
class Tolerance:
    """One varied key: ``dist`` with parameters ``sd``, ``low``, ``high`` (offsets; NaN where unused)."""

    key: str
    dist: str
    sd: float
    low: float
    high: float

    def variance(self) -> float:
        """Variance of the offset (key units squared); the linear propagation's input."""
        if self.dist == "normal":
            return self.sd**2
        if self.dist == "uniform":
            return (self.high - self.low) ** 2 / 12.0
        return float(_truncnorm(self).var())

    def std(self) -> float:
        """Standard deviation of the offset (key units), without squaring (an sd of 1e-300 stays 1e-300)."""
        if self.dist == "normal":
            return self.sd
        if self.dist == "uniform":
            return (self.high - self.low) / math.sqrt(12.0)
        return float(_truncnorm(self).std())

    def mean(self) -> float:
        """Mean of the offset (key units)."""
        if self.dist == "normal":
            return 0.0
        if self.dist == "uniform":
            return 0.5 * (self.low + self.high)
        return float(_truncnorm(self).mean())


def _truncnorm(t: Tolerance) -> Any:
    from scipy.stats import truncnorm

    return truncnorm(t.low / t.sd, t.high / t.sd, loc=0.0, scale=t.sd)


@dataclass(frozen=True)
class Spec:
    """A parsed SPEC: the varied keys in file order, and its description."""

    tolerances: tuple[Tolerance, ...]
    description: str = ""

    @property
    def keys(self) -> tuple[str, ...]:
        """The varied keys, in file order (the order of every per-key array)."""
        return tuple(t.key for t in self.tolerances)

    def to_dict(self) -> dict:
        """JSON-ready form (stored beside the samples; a resumed study must match it)."""
        return {"description": self.description, "tolerances": {
            t.key: {k: v for k, v in (("dist", t.dist), ("sd", t.sd), ("low", t.low), ("high", t.high))
                    if not (isinstance(v, float) and math.isnan(v))} for t in self.tolerances}}


def _flatten(table: dict, prefix: str, lines: dict[str, list[int]] | None = None) -> dict[str, Any]:
    """Dotted keys of nested tables; a table with a ``dist`` key is a leaf.

    A key reached twice (``"geometry.rod_length"`` and ``[tolerances.geometry] rod_length``, which TOML
    allows) is a :class:`SpecError` naming it and, with ``lines`` (:func:`key_lines`), its lines.
    """
    out: dict[str, Any] = {}
    for k, v in table.items():
        dotted = f"{prefix}{k}"
        nested = isinstance(v, dict) and "dist" not in v and v
        leaves = _flatten(v, dotted + ".", lines) if nested else {dotted: v}
        for key, entry in leaves.items():
            if key in out:
                where = (lines or {}).get(key, [])
                at = f" (lines {', '.join(map(str, where))})" if len(where) > 1 else ""
                raise SpecError(f"tolerances.{key_text(key)}: given twice{at}; give each key once")
            out[key] = entry
    return out


def key_lines(text: str) -> dict[str, list[int]]:
    """Line numbers (from 1) where each dotted key under ``tolerances`` is given, by a plain scan of the
    SPEC's text (``[table]`` headers and ``key = ...`` lines; for naming a repeated key)."""
    out: dict[str, list[int]] = {}
    table = ""
    for number, line in enumerate(text.splitlines(), 1):
        code = line.split("#", 1)[0].strip()
        header = code.startswith("[") and not code.startswith("[[")
        if header:
            table = name = _dotted(code.strip("[] "))
        elif "=" in code:
            name = ".".join(p for p in (table, _dotted(code.split("=", 1)[0])) if p)
        else:
            continue
        key = name.removeprefix("tolerances.")
        if name.startswith("tolerances.") and (not header or key in KEYS):
            out.setdefault(key, []).append(number)
    return out


def _dotted(key: str) -> str:
    """A TOML key as the dotted text :func:`_flatten` makes of it (quotes and spaces around dots dropped)."""
    return ".".join(p.strip().strip("\"'") for p in key.split("."))


def _tolerance(key: str, entry: Any) -> Tolerance:
    where = f"tolerances.{key_text(key)}"
    if not isinstance(entry, dict):
        raise SpecError(f"{where}: expected a table such as {{ dist = \"normal\", sd = 0.1 }}, "
                        f"got {show(entry)}")
    dist = entry.get("dist")
    if dist not in DISTRIBUTIONS:
        raise SpecError(f"{where}.dist: expected one of {', '.join(DISTRIBUTIONS)}, got {show(dist)}")
    allowed = ("dist",) + DISTRIBUTIONS[dist]
    for k in entry:
        if k not in allowed:
            raise SpecError(f"{where}.{key_text(k)}: not a parameter of {dist} (valid: {', '.join(allowed)})")
    values = {}
    for k in DISTRIBUTIONS[dist]:
        if k not in entry:
            raise SpecError(f"{where}.{k}: required for dist = {dist!r}")
        try:
            values[k] = OFFSET.check(f"{where}.{k}", entry[k])
        except CaseError as err:
            raise SpecError(str(err)) from None
    if "sd" in values and not values["sd"] > 0:
        raise SpecError(f"{where}.sd: expected a positive standard deviation, got {show(entry['sd'])}")
    if "low" in values and not values["low"] < values["high"]:
        raise SpecError(f"{where}: expected low < high, got low = {values['low']!r}, "
                        f"high = {values['high']!r}")
    if dist == "truncnormal" and ndtr(values["high"] / values["sd"]) - ndtr(values["low"] / values["sd"]) \
            < MIN_TRUNC_MASS:
        raise SpecError(f"{where}: low..high holds less than {MIN_TRUNC_MASS:g} of the normal's mass; "
                        "expected a range within a few sd of 0")
    nan = float("nan")
    return Tolerance(key, dist, values.get("sd", nan), values.get("low", nan), values.get("high", nan))


def spec_from_dict(data: Any, lines: dict[str, list[int]] | None = None) -> Spec:
    """Validate a parsed SPEC table (module docstring) and build the :class:`Spec`; ``lines``
    (:func:`key_lines` of its text) lets an error name the lines of a key given twice."""
    if not isinstance(data, dict):
        raise SpecError(f"spec: expected a table, got {show(data)}")
    check_keys("", data, ("tolerances", "description"), SpecError)
    description = data.get("description", "")
    if not isinstance(description, str):
        raise SpecError(f"description: expected a string, got {show(description)}")
    table = data.get("tolerances")
    if not isinstance(table, dict) or not table:
        raise SpecError(f"tolerances: expected a table of at least one key, got {show(table)}")
    flat = _flatten(table, "", lines)
    if len(flat) > MAX_KEYS:
        raise SpecError(f"tolerances: {len(flat)} keys; at most {MAX_KEYS}")
    return Spec(tuple(_tolerance(k, v) for k, v in flat.items()), description)


def load_spec(path: str | Path) -> Spec:
    """Read a SPEC file (TOML)."""
    if not Path(path).is_file():
        raise SpecError(f"spec: {show(str(path))} is not a file")
    data = read_toml(Path(path), SpecError)
    return spec_from_dict(data, key_lines(Path(path).read_text(encoding="utf-8")))


def _get(raw: dict, dotted: str) -> Any:
    node: Any = raw
    for part in dotted.split("."):
        if not isinstance(node, dict) or part not in node:
            return None
        node = node[part]
    return node


_ROW_KEY = re.compile(r"^(\w+)\[(\d+)\]\.(.+)$")


def key_list(keys: tuple[str, ...]) -> str:
    """``keys`` as one short text, the rows of an array of tables that state the same key together:
    ``"joint[1, 2, 4].a, joint[3].alpha_deg, drive.speed"``."""
    rows: dict[str, list[str]] = {}
    for key in keys:
        match = _ROW_KEY.match(key)
        pattern, row = (f"{match[1]}[{{}}].{match[3]}", match[2]) if match else (key, "")
        rows.setdefault(pattern, []).append(row)
    return ", ".join(pattern.format(", ".join(r)) if r[0] else pattern for pattern, r in rows.items())


def check_varied(spec: Spec, valid: tuple[str, ...]) -> None:
    """A one-line :class:`SpecError` for the first key of ``spec`` not in ``valid`` (the keys the case's
    kind lets vary), naming them (:func:`key_list`)."""
    for key in spec.keys:
        if key not in valid:
            raise SpecError(f"tolerances.{key_text(key)}: not a key that can vary (valid: {key_list(valid)})")


def nominal_values(case: Case, spec: Spec) -> np.ndarray:
    """The slider-crank case's value of every varied key, ``(k,)``, in the key's units.

    A key not in :data:`KEYS` is a :class:`SpecError` naming them.  A body mass the case derives from a
    shape and a density is the derived mass.  A key the case does not state (and cannot derive) is a
    :class:`SpecError`.
    """
    check_varied(spec, KEYS)
    out = []
    for key in spec.keys:
        value = _get(case.raw, key)
        if value is None and key.startswith("bodies.") and key.endswith(".mass"):
            value = getattr(case.bodies, key.split(".")[1]).mass
        if value is None and key == "motion.axial_amplitude":
            value = 0.0
        if value is None:
            raise SpecError(f"tolerances.{key}: the case {case.name!r} does not give this key; "
                            "vary only keys the case states")
        out.append(float(value))
    return np.array(out)


def design_case(case: Case, spec: Spec, values: np.ndarray, name: str) -> Case:
    """The case with every varied key set to ``values`` ``(k,)``, validated by the case loader.

    Raises :class:`~dualmech.models.case.CaseError` (one line, naming the key) where a sampled
    value leaves the loader's ranges (e.g. a negative crank length).
    """
    raw = {k: (dict(v) if isinstance(v, dict) else v) for k, v in case.raw.items()}
    raw["name"] = name
    for key, value in zip(spec.keys, values):
        node = raw
        *parents, leaf = key.split(".")
        for p in parents:
            node[p] = dict(node.get(p, {}))
            node = node[p]
        node[leaf] = float(value)
    return case_from_dict(raw)
