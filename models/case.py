"""Case files: one TOML file describes one generalized slider crank and its motion.

The keys and their meanings are listed in ``docs/conventions.md`` ("Case
files").  :func:`load_case` reads a file or a bundled preset and returns a
frozen :class:`Case`; every engine (in-house, Pinocchio, MuJoCo) builds its
model from this one record, so masses and inertias are computed once, here.

Errors are :class:`CaseError` (a ``ValueError``) with a one-line message that
names the key, the value received and what would be valid.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, replace
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from dualmech.core.inertia import BodyInertia, solid_cube, solid_cylinder_x
from dualmech.core.motion import CrankMotion


class CaseError(ValueError):
    """A case file or case value that cannot be used; the message is one line."""


@dataclass(frozen=True)
class Geometry:
    """Link-joint constants (thesis Table 1). Lengths in the case's length unit."""

    crank_length: float  # a1
    rod_length: float  # a2
    slider_offset: float  # a4
    slider_twist_deg: float  # alpha4
    crank_axial_shift: float  # constant part of S1

    @property
    def slider_twist(self) -> float:
        """alpha4 in radians."""
        return math.radians(self.slider_twist_deg)


@dataclass(frozen=True)
class Bodies:
    """Mass properties of the three moving bodies, each in its own body frame."""

    crank: BodyInertia
    rod: BodyInertia
    slider: BodyInertia


@dataclass(frozen=True)
class Loads:
    """Applied loads. Exactly one of ``drive_torque`` / ``slider_force`` is set."""

    drive_torque: float | None
    slider_force: float | None
    gravity: np.ndarray  # (3,), world axes

    @property
    def mode(self) -> str:
        """``"torque"`` when the drive torque is given, ``"force"`` when the slider load is."""
        return "torque" if self.drive_torque is not None else "force"


@dataclass(frozen=True)
class Case:
    """One slider-crank case: geometry, motion, bodies and loads."""

    name: str
    units: str
    geometry: Geometry
    motion: CrankMotion
    bodies: Bodies
    loads: Loads
    raw: dict  # the parsed TOML, after defaults; used to derive swept cases

    def with_values(self, updates: dict[str, Any]) -> "Case":
        """Return a new case with dotted keys replaced, e.g. ``{"geometry.slider_offset": 10}``."""
        raw = _deep_copy(self.raw)
        for dotted, value in updates.items():
            node = raw
            *parents, leaf = dotted.split(".")
            for p in parents:
                node = node.setdefault(p, {})
                if not isinstance(node, dict):
                    raise CaseError(f"{dotted}: {p!r} is not a table")
            node[leaf] = value
        if "name" not in updates:
            raw["name"] = self.name + "".join(f"|{k}={v}" for k, v in updates.items())
        return case_from_dict(raw)


# ----------------------------------------------------------------------------- schema

_SCHEMA: dict[str, dict[str, tuple[type | tuple, bool]]] = {
    "geometry": {
        "crank_length": ((int, float), True),
        "rod_length": ((int, float), True),
        "slider_offset": ((int, float), True),
        "slider_twist_deg": ((int, float), True),
        "crank_axial_shift": ((int, float), True),
    },
    "motion": {
        "crank_rpm": ((int, float), True),
        "crank_accel": ((int, float), False),
        "axial_amplitude": ((int, float), False),
        "axial_cycles": ((int, float), False),
        "angles_deg": (dict, False),
    },
    "bodies": {
        "crank_radius": ((int, float), False),
        "rod_radius": ((int, float), False),
        "slider_side": ((int, float), False),
        "density": ((int, float), False),
        "weight_density": ((int, float), False),
        "gravity_constant": ((int, float), False),
        "crank": (dict, False),
        "rod": (dict, False),
        "slider": (dict, False),
    },
    "loads": {
        "drive_torque": ((int, float), False),
        "slider_force": ((int, float), False),
        "gravity": (list, False),
    },
}
_TOP = {"name": (str, True), "units": (str, False), "description": (str, False)}
_BODY_KEYS = {"mass", "com", "inertia"}


def _deep_copy(d: Any) -> Any:
    if isinstance(d, dict):
        return {k: _deep_copy(v) for k, v in d.items()}
    if isinstance(d, list):
        return [_deep_copy(v) for v in d]
    return d


def _type_name(t: type | tuple) -> str:
    if t == (int, float):
        return "a number"
    return {str: "a string", dict: "a table", list: "an array"}[t]


def check_number(key: str, value: Any, *, positive: bool = False, nonneg: bool = False) -> float:
    """``value`` as a float, or a :class:`CaseError` naming ``key`` if it is not a finite (positive, >= 0) number."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) or not math.isfinite(value):
        raise CaseError(f"{key}: expected a finite number, got {value!r}")
    if positive and value <= 0:
        raise CaseError(f"{key}: expected a positive number, got {value!r}")
    if nonneg and value < 0:
        raise CaseError(f"{key}: expected a number >= 0, got {value!r}")
    return float(value)


def _check_keys(data: dict) -> None:
    for key in data:
        if key not in _TOP and key not in _SCHEMA:
            valid = ", ".join(sorted([*_TOP, *_SCHEMA]))
            raise CaseError(f"{key}: unknown key (valid top-level keys: {valid})")
    for key, (typ, required) in _TOP.items():
        if key in data and not isinstance(data[key], typ):
            raise CaseError(f"{key}: expected {_type_name(typ)}, got {data[key]!r}")
        if required and key not in data:
            raise CaseError(f"{key}: required key missing")
    for section, fields in _SCHEMA.items():
        table = data.get(section, {})
        if not isinstance(table, dict):
            raise CaseError(f"{section}: expected a table, got {table!r}")
        for key, value in table.items():
            if key not in fields:
                raise CaseError(
                    f"{section}.{key}: unknown key (valid: {', '.join(sorted(fields))})"
                )
            typ = fields[key][0]
            if isinstance(value, bool) or not isinstance(value, typ):
                raise CaseError(f"{section}.{key}: expected {_type_name(typ)}, got {value!r}")
        for key, (_, required) in fields.items():
            if required and key not in table:
                raise CaseError(f"{section}.{key}: required key missing")


# ----------------------------------------------------------------------------- sections

def _geometry(g: dict) -> Geometry:
    a1 = check_number("geometry.crank_length", g["crank_length"], positive=True)
    a2 = check_number("geometry.rod_length", g["rod_length"], positive=True)
    a4 = check_number("geometry.slider_offset", g["slider_offset"])
    alpha = check_number("geometry.slider_twist_deg", g["slider_twist_deg"])
    s1 = check_number("geometry.crank_axial_shift", g["crank_axial_shift"])
    return Geometry(a1, a2, a4, alpha, s1)


def _angles(spec: dict) -> np.ndarray:
    allowed = {"start", "stop", "step"}
    for key in spec:
        if key not in allowed:
            raise CaseError(f"motion.angles_deg.{key}: unknown key (valid: start, step, stop)")
    start = check_number("motion.angles_deg.start", spec.get("start", 0.0))
    stop = check_number("motion.angles_deg.stop", spec.get("stop", 360.0))
    step = check_number("motion.angles_deg.step", spec.get("step", 1.0))
    if step == 0:
        raise CaseError("motion.angles_deg.step: expected a non-zero number of degrees, got 0")
    count = math.ceil((stop - start) / step - 1e-9)
    if count <= 0:
        raise CaseError(
            f"motion.angles_deg: start={start!r}, stop={stop!r}, step={step!r} gives no angle "
            "(stop is exclusive; step must point from start to stop)"
        )
    if count > 10_000_000:
        raise CaseError(f"motion.angles_deg: {count} positions requested; at most 10,000,000 per case")
    return start + step * np.arange(count)


def _motion(m: dict) -> CrankMotion:
    rpm = check_number("motion.crank_rpm", m["crank_rpm"])
    return CrankMotion(
        angles_deg=_angles(m.get("angles_deg", {})),
        speed=2.0 * math.pi * rpm / 60.0,
        accel=check_number("motion.crank_accel", m.get("crank_accel", 0.0)),
        axial_amplitude=check_number("motion.axial_amplitude", m.get("axial_amplitude", 0.0)),
        axial_cycles=check_number("motion.axial_cycles", m.get("axial_cycles", 0.0)),
    )


def _vector(key: str, value: Any) -> np.ndarray:
    if not isinstance(value, list) or len(value) != 3:
        raise CaseError(f"{key}: expected an array of 3 numbers, got {value!r}")
    return np.array([check_number(f"{key}[{i}]", v) for i, v in enumerate(value)])


def _tensor(key: str, value: Any) -> np.ndarray:
    if isinstance(value, list) and len(value) == 3 and all(isinstance(v, list) for v in value):
        rows = [_vector(f"{key}[{i}]", row) for i, row in enumerate(value)]
        return np.array(rows)
    if isinstance(value, list) and len(value) == 3:
        return np.diag(_vector(key, value))
    raise CaseError(f"{key}: expected 3 principal moments or a 3x3 array, got {value!r}")


def _mass_per_volume(b: dict) -> float | None:
    has_density = "density" in b
    has_weight = "weight_density" in b or "gravity_constant" in b
    if has_density and has_weight:
        raise CaseError(
            "bodies.density: give either density or weight_density with gravity_constant, not both"
        )
    if has_density:
        return check_number("bodies.density", b["density"], positive=True)
    if has_weight:
        for key in ("weight_density", "gravity_constant"):
            if key not in b:
                raise CaseError(f"bodies.{key}: required with the other weight-based key")
        w = check_number("bodies.weight_density", b["weight_density"], positive=True)
        g = check_number("bodies.gravity_constant", b["gravity_constant"], positive=True)
        return w / g
    return None


def _body(name: str, b: dict, geom: Geometry, rho: float | None) -> BodyInertia:
    """Mass properties of one body: the default shape, then any explicit overrides."""
    explicit = b.get(name, {})
    for key in explicit:
        if key not in _BODY_KEYS:
            raise CaseError(f"bodies.{name}.{key}: unknown key (valid: com, inertia, mass)")
    shape_key = {"crank": "crank_radius", "rod": "rod_radius", "slider": "slider_side"}[name]
    default = None
    if shape_key in b and rho is not None:
        size = check_number(f"bodies.{shape_key}", b[shape_key], positive=True)
        if name == "crank":
            m = rho * math.pi * size**2 * geom.crank_length
            default = (m, [geom.crank_length / 2, 0, 0], solid_cylinder_x(m, geom.crank_length, size))
        elif name == "rod":
            m = rho * math.pi * size**2 * geom.rod_length
            default = (m, [geom.rod_length / 2, 0, 0], solid_cylinder_x(m, geom.rod_length, size))
        else:
            m = rho * size**3
            default = (m, [0, 0, 0], solid_cube(m, size))
    elif shape_key in b:
        check_number(f"bodies.{shape_key}", b[shape_key], positive=True)
    missing = [k for k in ("mass", "com", "inertia") if k not in explicit]
    if default is None and missing:
        raise CaseError(
            f"bodies.{name}: no mass properties: give bodies.{shape_key} with a density "
            f"(density, or weight_density and gravity_constant), or bodies.{name}.{missing[0]}"
        )
    mass = (
        check_number(f"bodies.{name}.mass", explicit["mass"], positive=True)
        if "mass" in explicit
        else default[0]
    )
    com = _vector(f"bodies.{name}.com", explicit["com"]) if "com" in explicit else np.array(default[1], float)
    inertia = _tensor(f"bodies.{name}.inertia", explicit["inertia"]) if "inertia" in explicit else default[2]
    if "inertia" not in explicit and "mass" in explicit and default is not None:
        inertia = inertia * (mass / default[0])  # same shape, new mass
    try:
        body = BodyInertia(mass, com, inertia)
    except ValueError as err:
        raise CaseError(f"bodies.{name}.{err}") from None
    if name == "rod":
        _check_rod_axisymmetric(body)
    return body


def _check_rod_axisymmetric(rod: BodyInertia) -> None:
    """Two ball joints leave the rod's spin free: its mass must not care about that spin."""
    scale = max(1.0, float(np.abs(rod.inertia).max()))
    off_axis = np.hypot(rod.com[1], rod.com[2])
    if off_axis > 1e-12 * max(1.0, abs(rod.com[0])):
        raise CaseError(
            f"bodies.rod.com: {rod.com.tolist()} is off the rod axis; two ball joints leave the "
            "rod's spin free, so its centre of mass must lie on the body x axis ([x, 0, 0])"
        )
    i = rod.inertia
    if abs(i[0, 1]) + abs(i[0, 2]) + abs(i[1, 2]) > 1e-12 * scale or abs(i[1, 1] - i[2, 2]) > 1e-12 * scale:
        raise CaseError(
            f"bodies.rod.inertia: {i.tolist()} is not axisymmetric about the rod axis; two ball "
            "joints leave the rod's spin free, so it must be diag(I_axial, I_t, I_t)"
        )


def _bodies(b: dict, geom: Geometry) -> Bodies:
    rho = _mass_per_volume(b)
    return Bodies(*(_body(name, b, geom, rho) for name in ("crank", "rod", "slider")))


def _loads(ld: dict) -> Loads:
    torque = ld.get("drive_torque")
    force = ld.get("slider_force")
    if (torque is None) == (force is None):
        got = "both" if torque is not None else "neither"
        raise CaseError(f"loads: got {got} of drive_torque / slider_force; give exactly one")
    gravity = _vector("loads.gravity", ld.get("gravity", [0.0, 0.0, 0.0]))
    return Loads(
        drive_torque=None if torque is None else check_number("loads.drive_torque", torque),
        slider_force=None if force is None else check_number("loads.slider_force", force),
        gravity=gravity,
    )


# ----------------------------------------------------------------------------- public

def case_from_dict(data: dict) -> Case:
    """Validate a parsed case table and build the :class:`Case`.

    Raises
    ------
    CaseError
        One line naming the key, the value and what would be valid.
    """
    if not isinstance(data, dict):
        raise CaseError(f"case: expected a table, got {data!r}")
    _check_keys(data)
    geom = _geometry(data["geometry"])
    return Case(
        name=data["name"],
        units=data.get("units", "consistent"),
        geometry=geom,
        motion=_motion(data["motion"]),
        bodies=_bodies(data.get("bodies", {}), geom),
        loads=_loads(data.get("loads", {})),
        raw=_deep_copy(data),
    )


def preset_names() -> list[str]:
    """Names of the bundled presets, ``"<group>/<stem>"`` (e.g. ``"thesis/ideal"``)."""
    root = resources.files("dualmech.models") / "cases"
    names = []
    for group in sorted(p for p in root.iterdir() if p.is_dir()):
        names += [f"{group.name}/{f.name[:-5]}" for f in sorted(group.iterdir(), key=lambda f: f.name)
                  if f.name.endswith(".toml")]
    return names


def preset_path(name: str) -> Path:
    """File of a bundled preset; ``name`` is ``"thesis/ideal"`` or a unique stem ``"ideal"``."""
    names = preset_names()
    matches = [n for n in names if n == name or n.split("/", 1)[1] == name]
    if len(matches) != 1:
        raise CaseError(f"case: {name!r} is neither a file nor a bundled preset (presets: {', '.join(names)})")
    group, stem = matches[0].split("/", 1)
    return Path(str(resources.files("dualmech.models") / "cases" / group / f"{stem}.toml"))


def load_case(source: str | Path) -> Case:
    """Read a case from a TOML file, or from a bundled preset name.

    Parameters
    ----------
    source : str or pathlib.Path
        A path to a ``.toml`` file, or a preset name as listed by :func:`preset_names`.
    """
    path = Path(source)
    if not path.is_file():
        path = preset_path(str(source))
    try:
        with path.open("rb") as fh:
            data = tomllib.load(fh)
    except tomllib.TOMLDecodeError as err:
        raise CaseError(f"{path}: not valid TOML ({err})") from None
    return case_from_dict(data)


def with_loads(case: Case, **updates: Any) -> Case:
    """Copy of ``case`` with its loads replaced (e.g. switching torque/force mode)."""
    return replace(case, loads=replace(case.loads, **updates))
