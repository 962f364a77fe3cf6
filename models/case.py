"""Case files: one TOML file describes one generalized slider crank and its motion.

The keys and their meanings are listed in ``docs/conventions.md`` ("Case
files").  :func:`load_case` reads a file or a bundled preset and returns a
frozen :class:`Case`; every engine (in-house, Pinocchio, MuJoCo) builds its
model from this one record, so masses and inertias are computed once, here.

Errors are :class:`CaseError` (a ``ValueError``) with a one-line message that
names the key, the value received and what would be valid.  Every number is
checked against a stated :class:`Range` before it is used (``docs/conventions.md``,
"Input ranges", gives the table and the reasons).
"""

from __future__ import annotations

import math
import reprlib
import unicodedata
from dataclasses import dataclass, replace
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from dualmech.core.inertia import BodyInertia, solid_cube, solid_cylinder_x
from dualmech.core.motion import CrankMotion
from dualmech.models.toml_input import read_toml
from dualmech.models.units import UNIT_SYSTEMS


class CaseError(ValueError):
    """A case file or case value that cannot be used; the message is one line."""


# ----------------------------------------------------------------------------- input ranges

#: Largest magnitude of any dimensional number of a case (lengths, masses, densities, forces,
#: torques, accelerations, inertias), in the case's own consistent units; quantities that must
#: be positive are also at least ``1 / SCALE``.  Why 1e15: the largest quantity the solver
#: forms is a moment of an inertia force, density x length^5 x speed^2; with a density from
#: weight_density / gravity_constant (<= SCALE^2), lengths <= SCALE and the speed below
#: MAX_CRANK_RPM (1.05e6 rad/s) it stays below 1e15^7 x 1.1e12 ~ 1e117, so its square (norms,
#: least squares) stays below 1e234, 74 decades under the float maximum 1.8e308; the smallest,
#: 1e-105, squares to 1e-210, far above the smallest normal float 2.2e-308.  Physically the
#: range covers every mechanism in every known unit system with decades to spare (an aerogel
#: in t/mm^3 is 1e-12, a 10 km lever in mm is 1e7).
SCALE = 1e15
#: Largest ratio of the mechanism's largest length (a1, a2, |a4|, |S1|, axial amplitude) to
#: the crank or rod length: a link 1e12 times smaller than the mechanism is below the rounding
#: of its positions (1e4 x 2.2e-16 ~ 1e-12 of the size; the closure's SVD failed at 1e16).
MAX_LENGTH_RATIO = 1e12
#: Largest crank speed magnitude, rpm (time is always seconds): the fastest rotors built
#: (MEMS turbines, ~1e6 rpm) with a factor 10 to spare.
MAX_CRANK_RPM = 1e7
#: Largest crank angular acceleration magnitude, rad/s^2: reaching MAX_CRANK_RPM
#: (1.05e6 rad/s) from rest in 0.1 ms.
MAX_CRANK_ACCEL = 1e10
#: Largest number of axial cycles per crank revolution (alpha of eq. 27): a 1000-lobe cam.
MAX_AXIAL_CYCLES = 1e3
#: Largest magnitude of an angle given in degrees: the rounding of such an angle
#: (1e6 x 2.2e-16 = 2e-10 deg) stays below the solver's closure tolerance.
MAX_ANGLE_DEG = 1e6
#: Most crank positions in one case (``motion.angles_deg``); the engines stream them in chunks.
MAX_POSITIONS = 10_000_000
#: Longest case name, characters (names appear in one-line messages and report titles; names
#: derived by ``Case.with_values`` list every changed key, and are cut to this length).
MAX_CASE_NAME = 1000
#: The unit-system labels a case may state (``units = ...``; :mod:`dualmech.models.units`).
#: Nothing is converted; the label only says what the numbers mean.
KNOWN_UNITS: dict[str, str] = {label: system.description for label, system in UNIT_SYSTEMS.items()}


class _ShortRepr(reprlib.Repr):
    """``repr`` cut to a few elements, safe for integers too long to print."""

    def __init__(self) -> None:
        super().__init__()
        self.maxlevel, self.maxlist, self.maxtuple, self.maxdict = 3, 6, 6, 6
        self.maxstring, self.maxother, self.maxlong = 60, 60, 30

    def repr_int(self, x: int, level: int) -> str:
        if x.bit_length() > 90:  # above ~27 digits: say how long, never build the digits
            return f"<an integer of about {int(x.bit_length() * math.log10(2)) + 1} digits>"
        return super().repr_int(x, level)


_SHORT = _ShortRepr()


def show(value: Any) -> str:
    """A short one-line ``repr`` of ``value`` for error messages (at most ~120 characters)."""
    text = " ".join(_SHORT.repr(value).split())
    return text if len(text) <= 120 else text[:117] + "..."


@dataclass(frozen=True)
class Range:
    """A closed interval of valid values for one kind of input, and how to name it in errors."""

    low: float
    high: float
    what: str  # e.g. "a positive length"

    def describe(self) -> str:
        """E.g. ``"a positive length from 1e-15 to 1e+15"``."""
        return f"{self.what} from {self.low:g} to {self.high:g}"

    def check(self, key: str, value: Any) -> float:
        """``value`` as a float, or a one-line :class:`CaseError` naming ``key``, the value and the range.

        Integers are compared exactly before any conversion, so a huge integer is
        refused instead of overflowing to ``inf``; ``bool`` is not a number here.
        """
        numeric = (int, float, np.integer, np.floating)
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, numeric):
            raise CaseError(f"{key}: expected a finite number ({self.describe()}), got {show(value)}")
        if isinstance(value, (int, np.integer)):
            ok = self.low <= value <= self.high
        else:
            ok = math.isfinite(value) and self.low <= value <= self.high
        if not ok:
            finite = "" if isinstance(value, (int, np.integer)) or math.isfinite(value) else "finite "
            raise CaseError(f"{key}: expected a {finite}number, {self.describe()}, got {show(value)}")
        return float(value)


LENGTH = Range(-SCALE, SCALE, "a length (case units)")
POSITIVE_LENGTH = Range(1.0 / SCALE, SCALE, "a positive length (case units)")
POSITIVE_MASS = Range(1.0 / SCALE, SCALE, "a positive mass (case units)")
POSITIVE_DENSITY = Range(1.0 / SCALE, SCALE, "a positive mass or weight per volume (case units)")
POSITIVE_ACCELERATION = Range(1.0 / SCALE, SCALE, "a positive acceleration (case units)")
ACCELERATION = Range(-SCALE, SCALE, "an acceleration (case units)")
INERTIA = Range(-SCALE, SCALE, "a moment of inertia (case units)")
FORCE = Range(-SCALE, SCALE, "a force (case units)")
TORQUE = Range(-SCALE, SCALE, "a torque (case units)")
ANGLE_DEG = Range(-MAX_ANGLE_DEG, MAX_ANGLE_DEG, "an angle in degrees")
CRANK_RPM = Range(-MAX_CRANK_RPM, MAX_CRANK_RPM, "a crank speed in rpm")
CRANK_ACCEL = Range(-MAX_CRANK_ACCEL, MAX_CRANK_ACCEL, "a crank acceleration in rad/s^2")
AXIAL_CYCLES = Range(-MAX_AXIAL_CYCLES, MAX_AXIAL_CYCLES, "axial cycles per crank revolution")


def key_text(key: Any) -> str:
    """A TOML key as it may appear in a one-line message: as is if short and plain, else quoted and cut."""
    if isinstance(key, str) and len(key) <= 60 and all(c.isalnum() or c in "._-+=" for c in key):
        return key
    return show(key)


def check_number(key: str, value: Any, limits: Range) -> float:
    """``value`` as a float within ``limits``, else a one-line :class:`CaseError` naming ``key``."""
    return limits.check(key, value)


def check_text(key: str, value: Any, max_chars: int) -> str:
    """A one-line printable string of at most ``max_chars`` characters, else a :class:`CaseError`."""
    if not isinstance(value, str):
        raise CaseError(f"{key}: expected a string, got {show(value)}")
    bad = next((c for c in value if unicodedata.category(c)[0] == "C"), None)
    if bad is not None:
        raise CaseError(f"{key}: control or non-printing character {bad!r} in {show(value)}; "
                        "expected one line of printable text")
    if len(value) > max_chars:
        raise CaseError(f"{key}: {len(value)} characters; at most {max_chars}")
    return value


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
            raw["name"] = (self.name + "".join(f"|{k}={v}" for k, v in updates.items()))[:MAX_CASE_NAME]
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


def _check_keys(data: dict) -> None:
    for key in data:
        if key not in _TOP and key not in _SCHEMA:
            valid = ", ".join(sorted([*_TOP, *_SCHEMA]))
            raise CaseError(f"{key_text(key)}: unknown key (valid top-level keys: {valid})")
    for key, (typ, required) in _TOP.items():
        if key in data and not isinstance(data[key], typ):
            raise CaseError(f"{key}: expected {_type_name(typ)}, got {show(data[key])}")
        if required and key not in data:
            raise CaseError(f"{key}: required key missing")
    for section, fields in _SCHEMA.items():
        table = data.get(section, {})
        if not isinstance(table, dict):
            raise CaseError(f"{section}: expected a table, got {show(table)}")
        for key, value in table.items():
            if key not in fields:
                raise CaseError(
                    f"{section}.{key_text(key)}: unknown key (valid: {', '.join(sorted(fields))})"
                )
            typ = fields[key][0]
            if isinstance(value, bool) or not isinstance(value, typ):
                raise CaseError(f"{section}.{key}: expected {_type_name(typ)}, got {show(value)}")
        for key, (_, required) in fields.items():
            if required and key not in table:
                raise CaseError(f"{section}.{key}: required key missing")


# ----------------------------------------------------------------------------- sections

def _geometry(g: dict) -> Geometry:
    a1 = check_number("geometry.crank_length", g["crank_length"], POSITIVE_LENGTH)
    a2 = check_number("geometry.rod_length", g["rod_length"], POSITIVE_LENGTH)
    a4 = check_number("geometry.slider_offset", g["slider_offset"], LENGTH)
    alpha = check_number("geometry.slider_twist_deg", g["slider_twist_deg"], ANGLE_DEG)
    s1 = check_number("geometry.crank_axial_shift", g["crank_axial_shift"], LENGTH)
    return Geometry(a1, a2, a4, alpha, s1)


def _angles(spec: dict) -> np.ndarray:
    allowed = {"start", "stop", "step"}
    for key in spec:
        if key not in allowed:
            raise CaseError(f"motion.angles_deg.{key_text(key)}: unknown key (valid: start, step, stop)")
    start = check_number("motion.angles_deg.start", spec.get("start", 0.0), ANGLE_DEG)
    stop = check_number("motion.angles_deg.stop", spec.get("stop", 360.0), ANGLE_DEG)
    step = check_number("motion.angles_deg.step", spec.get("step", 1.0), ANGLE_DEG)
    if step == 0:
        raise CaseError("motion.angles_deg.step: expected a non-zero number of degrees, got 0")
    span = stop - start  # finite: both ends are bounded
    if abs(span) > abs(step) * MAX_POSITIONS:  # decided before dividing: a tiny step cannot overflow
        raise CaseError(
            f"motion.angles_deg.step: {step!r} deg from {start!r} to {stop!r} gives more than "
            f"{MAX_POSITIONS:,} positions (the most per case); use a larger step"
        )
    count = math.ceil(span / step - 1e-9)
    if count <= 0:
        raise CaseError(
            f"motion.angles_deg: start={start!r}, stop={stop!r}, step={step!r} gives no angle "
            "(stop is exclusive; step must point from start to stop)"
        )
    return start + step * np.arange(count)


def _motion(m: dict) -> CrankMotion:
    rpm = check_number("motion.crank_rpm", m["crank_rpm"], CRANK_RPM)
    return CrankMotion(
        angles_deg=_angles(m.get("angles_deg", {})),
        speed=2.0 * math.pi * rpm / 60.0,
        accel=check_number("motion.crank_accel", m.get("crank_accel", 0.0), CRANK_ACCEL),
        axial_amplitude=check_number("motion.axial_amplitude", m.get("axial_amplitude", 0.0), LENGTH),
        axial_cycles=check_number("motion.axial_cycles", m.get("axial_cycles", 0.0), AXIAL_CYCLES),
    )


def _vector(key: str, value: Any, limits: Range) -> np.ndarray:
    if not isinstance(value, list) or len(value) != 3:
        raise CaseError(f"{key}: expected an array of 3 numbers, got {show(value)}")
    return np.array([check_number(f"{key}[{i}]", v, limits) for i, v in enumerate(value)])


def _tensor(key: str, value: Any) -> np.ndarray:
    if isinstance(value, list) and len(value) == 3 and all(isinstance(v, list) for v in value):
        rows = [_vector(f"{key}[{i}]", row, INERTIA) for i, row in enumerate(value)]
        return np.array(rows)
    if isinstance(value, list) and len(value) == 3:
        return np.diag(_vector(key, value, INERTIA))
    raise CaseError(f"{key}: expected 3 principal moments or a 3x3 array, got {show(value)}")


def _mass_per_volume(b: dict) -> float | None:
    has_density = "density" in b
    has_weight = "weight_density" in b or "gravity_constant" in b
    if has_density and has_weight:
        raise CaseError(
            "bodies.density: give either density or weight_density with gravity_constant, not both"
        )
    if has_density:
        return check_number("bodies.density", b["density"], POSITIVE_DENSITY)
    if has_weight:
        for key in ("weight_density", "gravity_constant"):
            if key not in b:
                raise CaseError(f"bodies.{key}: required with the other weight-based key")
        w = check_number("bodies.weight_density", b["weight_density"], POSITIVE_DENSITY)
        g = check_number("bodies.gravity_constant", b["gravity_constant"], POSITIVE_ACCELERATION)
        return w / g
    return None


def _body(name: str, b: dict, geom: Geometry, rho: float | None) -> BodyInertia:
    """Mass properties of one body: the default shape, then any explicit overrides."""
    explicit = b.get(name, {})
    for key in explicit:
        if key not in _BODY_KEYS:
            raise CaseError(f"bodies.{name}.{key_text(key)}: unknown key (valid: com, inertia, mass)")
    shape_key = {"crank": "crank_radius", "rod": "rod_radius", "slider": "slider_side"}[name]
    default = None
    if shape_key in b and rho is not None:
        size = check_number(f"bodies.{shape_key}", b[shape_key], POSITIVE_LENGTH)
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
        check_number(f"bodies.{shape_key}", b[shape_key], POSITIVE_LENGTH)
    missing = [k for k in ("mass", "com", "inertia") if k not in explicit]
    if default is None and missing:
        raise CaseError(
            f"bodies.{name}: no mass properties: give bodies.{shape_key} with a density "
            f"(density, or weight_density and gravity_constant), or bodies.{name}.{missing[0]}"
        )
    mass = (
        check_number(f"bodies.{name}.mass", explicit["mass"], POSITIVE_MASS)
        if "mass" in explicit
        else default[0]
    )
    com = (_vector(f"bodies.{name}.com", explicit["com"], LENGTH) if "com" in explicit
           else np.array(default[1], float))
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
    scale = float(np.abs(rod.inertia).max())  # relative tests: the verdict must not depend on the unit system
    off_axis = np.hypot(rod.com[1], rod.com[2])
    if off_axis > 1e-12 * float(np.linalg.norm(rod.com)):
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
    gravity = _vector("loads.gravity", ld.get("gravity", [0.0, 0.0, 0.0]), ACCELERATION)
    return Loads(
        drive_torque=None if torque is None else check_number("loads.drive_torque", torque, TORQUE),
        slider_force=None if force is None else check_number("loads.slider_force", force, FORCE),
        gravity=gravity,
    )


def _check_proportions(g: Geometry, m: CrankMotion) -> None:
    size = max(g.crank_length, g.rod_length, abs(g.slider_offset), abs(g.crank_axial_shift),
               abs(m.axial_amplitude))
    for key, length in (("geometry.crank_length", g.crank_length), ("geometry.rod_length", g.rod_length)):
        if length * MAX_LENGTH_RATIO < size:
            raise CaseError(f"{key}: {length!r} is less than 1/{MAX_LENGTH_RATIO:g} of the mechanism's "
                            f"largest length {size:g}; such a link is lost in the rounding of positions")


# ----------------------------------------------------------------------------- public

def case_from_dict(data: dict) -> Case:
    """Validate a parsed case table and build the :class:`Case`.

    Raises
    ------
    CaseError
        One line naming the key, the value and what would be valid.
    """
    if not isinstance(data, dict):
        raise CaseError(f"case: expected a table, got {show(data)}")
    _check_keys(data)
    geom = _geometry(data["geometry"])
    motion, bodies = _motion(data["motion"]), _bodies(data.get("bodies", {}), geom)
    _check_proportions(geom, motion)
    loads = _loads(data.get("loads", {}))
    units = data.get("units", "consistent")
    if units not in KNOWN_UNITS:
        raise CaseError(f"units: {show(units)} is not a known unit label (valid: {', '.join(KNOWN_UNITS)})")
    name = check_text("name", data["name"], MAX_CASE_NAME)  # last: a derived name shows the values above
    return Case(name=name, units=units, geometry=geom, motion=motion, bodies=bodies, loads=loads,
                raw=_deep_copy(data))


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
        raise CaseError(f"case: {show(name)} is neither a file nor a bundled preset (presets: {', '.join(names)})")
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
    return case_from_dict(read_toml(path, CaseError))


def with_loads(case: Case, **updates: Any) -> Case:
    """Copy of ``case`` with its loads replaced (e.g. switching torque/force mode)."""
    return replace(case, loads=replace(case.loads, **updates))
