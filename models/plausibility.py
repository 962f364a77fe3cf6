"""Is a case's size plausible for the unit system it states?  Lengths in mm under ``units = "m-kg-s"``.

Nothing is converted (:mod:`dualmech.models.units`), so a case whose numbers are in another unit
than its label says still solves, to numbers that are wrong by powers of ten: the IFToMM crank
entered in mm under ``m-kg-s`` weighs 1.2e8 kg and needs 1.3e16 N·m.  :func:`implausible` returns
one line per implausible derived size, naming the likely cause; :func:`warn_implausible` issues
those of a case of any kind as :class:`ImplausibleUnitsWarning` (a :class:`UserWarning`, never an error: an
unusual mechanism may be real).  The bounds, in SI, and their reasons are in ``docs/conventions.md``
("Plausible sizes"); a case with unstated units (``consistent``) is not checked.
"""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np

from dualmech.models.case import Case
from dualmech.models.kinds import KIND_HOMES, kind_of, resolve
from dualmech.models.units import FOOT, INCH, UnitSystem, unit_system

#: Longest plausible link (a1, a2, |a4|), m: larger than any machine's slider crank (a ship's engine
#: stroke is ~3.5 m, its connecting rod ~8 m).
LONGEST_LINK_M = 100.0
#: Shortest plausible crank or rod, m: a MEMS slider crank's crank is ~0.1 mm.
SHORTEST_LINK_M = 1e-4
#: Heaviest plausible body, kg: a ship engine's crankshaft throw and rod are tonnes to tens of tonnes.
HEAVIEST_BODY_KG = 1e5
#: Lightest plausible body with a mass at all, kg: a steel cube of the shortest link's size (0.1 mm)
#: weighs 8e-9 kg; 1e-12 kg is below any solid body of a plausible size.
LIGHTEST_BODY_KG = 1e-12
#: Largest plausible ratio of a body's radius of gyration sqrt(I_max / m) to the longest link: a body
#: is within the mechanism's size (a flywheel on the crank reaches ~2); 10 leaves room, and an inertia
#: entered in kg·mm² under m-kg-s is 1000 times over.
GYRATION_PER_LINK = 10.0
#: Length units a misplaced number may be in, metres per unit (for the likely cause).
LENGTH_UNITS: dict[str, float] = {"mm": 1e-3, "cm": 1e-2, "m": 1.0, "in": INCH, "ft": FOOT}
#: Their names in a sentence.
LENGTH_NAMES: dict[str, str] = {"mm": "millimetres", "cm": "centimetres", "m": "metres", "in": "inches",
                                "ft": "feet"}
#: Density of steel, kg/m³ (the example a warning gives in the case's units).
STEEL_KG_M3 = 7850.0
#: Typical link length, m, for the guess of the unit the lengths look like (the middle of the plausible
#: range, on a log scale, of common machines: 1 mm .. 10 m).
TYPICAL_LINK_M = 0.3


class ImplausibleUnitsWarning(UserWarning):
    """A derived size (link, mass, inertia) is implausible for the case's stated unit system."""


def _links(case: Case) -> dict[str, float]:
    g = case.geometry
    return {"a1": g.crank_length, "a2": g.rod_length, "a4": abs(g.slider_offset)}


def _looks_like(value: float, system: UnitSystem) -> str | None:
    """The length unit (other than the system's) in which ``value`` is a typical link, if one is plausible."""
    best, best_d = None, math.inf
    for unit, metres in LENGTH_UNITS.items():
        size = value * metres
        if unit == system.length or not SHORTEST_LINK_M <= size <= 10.0:
            continue
        d = abs(math.log10(size / TYPICAL_LINK_M))
        if d < best_d:
            best, best_d = unit, d
    return best


def _length_warnings(case: Case, system: UnitSystem) -> list[str]:
    links = _links(case)
    name, longest = max(links.items(), key=lambda kv: kv[1])
    shortest_name, shortest = min(((k, v) for k, v in links.items() if k != "a4"), key=lambda kv: kv[1])
    found = []
    for key, value, bad, bound in (
        (name, longest, longest * system.metre > LONGEST_LINK_M, f"longer than {LONGEST_LINK_M:g} m"),
        (shortest_name, shortest, 0 < shortest * system.metre < SHORTEST_LINK_M,
         f"shorter than {SHORTEST_LINK_M * 1e3:g} mm"),
    ):
        if not bad:
            continue
        guess = _looks_like(value, system)
        cause = f"lengths look like {guess}; " if guess else ""
        found.append(f"link {key} = {value:g} {system.length} is {bound}, implausible for units = "
                     f"{case.units!r}: {cause}in {case.units} lengths are in {LENGTH_NAMES[system.length]}")
    return found


def _body_warnings(case: Case, system: UnitSystem, lengths_wrong: bool) -> list[str]:
    found = []
    steel = STEEL_KG_M3 * system.metre**3 / system.kilogram
    cause = ("it follows from the lengths above" if lengths_wrong else
             f"check the density (in {system.of('density')}: steel is {steel:.3g}) or the mass "
             f"(in {system.mass})")
    longest = max(_links(case).values())
    for body, b in zip(("crank", "rod", "slider"), case.bodies.ordered):
        kg = b.mass * system.kilogram
        if kg > HEAVIEST_BODY_KG or 0 < kg < LIGHTEST_BODY_KG:
            bound = (f"over {HEAVIEST_BODY_KG:g} kg" if kg > HEAVIEST_BODY_KG
                     else f"under {LIGHTEST_BODY_KG:g} kg")
            si = "" if system.mass == "kg" else f" ({kg:.3g} kg)"
            found.append(f"{body} mass {b.mass:.3g} {system.mass}{si} is {bound}, implausible for "
                         f"units = {case.units!r}: {cause}")
            continue
        i_max = float(np.max(np.linalg.eigvalsh(np.real(b.inertia)))) if b.mass > 0 else 0.0
        if b.mass > 0 and longest > 0 and math.sqrt(max(i_max, 0.0) / b.mass) > GYRATION_PER_LINK * longest:
            k = math.sqrt(i_max / b.mass)
            found.append(f"{body} inertia {i_max:.3g} {system.of('inertia')}: its radius of gyration "
                         f"{k:.3g} {system.length} is {k / longest:.3g} times the longest link, implausible: "
                         f"in {case.units} an inertia is in {system.of('inertia')} (not, e.g., "
                         f"{system.mass}·mm²)")
    return found


def implausible(case: Case) -> list[str]:
    """One line per derived size of ``case`` implausible for its unit system (module docstring); empty
    when all are plausible or the units are unstated."""
    system = unit_system(case.units)
    if not system.length:
        return []
    lengths = _length_warnings(case, system)
    return lengths + _body_warnings(case, system, bool(lengths))


def warnings_of(case: Any) -> list[str]:
    """The implausible sizes of a checked case of any kind: its kind's ``warnings``
    (:data:`~dualmech.models.kinds.KIND_HOMES`; the slider crank's are :func:`implausible`), else none."""
    home = KIND_HOMES[kind_of(case)].warnings
    return resolve(home)(case) if home else []


def warn_implausible(case: Any, stacklevel: int = 2) -> list[str]:
    """:func:`warnings_of`, each line issued as an :class:`ImplausibleUnitsWarning`; the lines."""
    found = warnings_of(case)
    for line in found:
        warnings.warn(f"{case.name}: {line}", ImplausibleUnitsWarning, stacklevel=stacklevel + 1)
    return found


def masses_line(case: Case) -> str:
    """``"body masses: crank 1.2 kg, rod 3.4 kg, slider 0.5 kg"`` (no unit when the units are unstated)."""
    unit = unit_system(case.units).mass
    return "body masses: " + ", ".join(f"{name} {b.mass:.6g} {unit}".rstrip()
                                       for name, b in zip(("crank", "rod", "slider"), case.bodies.ordered))
