"""Unit systems a case may state (``units = "m-N-s"``), and the unit of every output column.

Nothing is ever converted: a case's numbers are in one consistent system, and its
label only says which, so that reports and summaries can print units.  A label is
``<length>-<force or mass>-<time>``; the mass unit follows from the other three
(``docs/conventions.md``, "Units").
"""

from __future__ import annotations

from dataclasses import dataclass

from dualmech.core.table import FORCE_COLUMNS, MOMENT_COLUMNS

#: Metres in an inch and a foot, kilograms in a pound-mass, m/s² of standard gravity (exact, by definition).
INCH, FOOT, POUND, STANDARD_GRAVITY = 0.0254, 0.3048, 0.45359237, 9.80665
#: The mass unit of the inch-lbf-s system, lbf·s²/in, in kg (1 lbf = POUND · STANDARD_GRAVITY N).
LBF_S2_PER_IN = POUND * STANDARD_GRAVITY / INCH


@dataclass(frozen=True)
class UnitSystem:
    """Length, force, time and mass units of a consistent system (``""`` when unstated), and the SI size
    of its length and mass units (``metre``: metres per length unit, ``kilogram``: kilograms per mass
    unit; NaN when unstated), for plausibility checks only (nothing is converted)."""

    length: str
    force: str
    time: str
    mass: str
    description: str
    metre: float = float("nan")
    kilogram: float = float("nan")

    def of(self, dimension: str) -> str:
        """The unit of ``dimension`` (a key of :data:`DIMENSIONS`), e.g. ``"lbf·in"``; ``""`` if unstated."""
        if not self.length:
            return ""
        return {
            "length": self.length,
            "velocity": f"{self.length}/{self.time}",
            "acceleration": f"{self.length}/{self.time}²",
            "force": self.force,
            "moment": f"{self.force}·{self.length}",
            "ratio": "1",
            "angle": "deg",
            "mass": self.mass,
            "inertia": f"{self.mass}·{self.length}²",
            "density": f"{self.mass}/{self.length}³",
        }[dimension]


#: Every label a case may state, and what it means.
UNIT_SYSTEMS: dict[str, UnitSystem] = {
    "consistent": UnitSystem("", "", "", "", "unstated consistent units (the default)"),
    "m-kg-s": UnitSystem("m", "N", "s", "kg", "metre, newton, second; mass kg", 1.0, 1.0),
    "m-N-s": UnitSystem("m", "N", "s", "kg", "metre, newton, second; mass kg", 1.0, 1.0),
    "mm-N-s": UnitSystem("mm", "N", "s", "t", "millimetre, newton, second; mass tonne", 1e-3, 1e3),
    "cm-g-s": UnitSystem("cm", "dyn", "s", "g", "centimetre, dyne, second; mass g", 1e-2, 1e-3),
    "inch-lbf-s": UnitSystem("in", "lbf", "s", "lbf·s²/in", "inch, pound-force, second; mass lbf*s^2/in",
                             INCH, LBF_S2_PER_IN),
    "ft-lbf-s": UnitSystem("ft", "lbf", "s", "slug", "foot, pound-force, second; mass slug", FOOT,
                           POUND * STANDARD_GRAVITY / FOOT),
}

#: Dimension of every numeric output column (``core/table.py``; ``docs/conventions.md``).
DIMENSIONS: dict[str, str] = {
    "theta1_deg": "angle", "S1": "length", "S4": "length", "S4_dot": "velocity", "S4_ddot": "acceleration",
    "transmission": "ratio", "closure_condition": "ratio", "residual": "length",
    **{c: "force" for c in FORCE_COLUMNS},
    **{c: "moment" for c in MOMENT_COLUMNS},
}


def unit_system(label: str) -> UnitSystem:
    """The :class:`UnitSystem` of ``label``; ValueError naming the valid labels."""
    try:
        return UNIT_SYSTEMS[label]
    except (KeyError, TypeError):
        raise ValueError(f"units: {label!r} is not a known unit label "
                         f"(valid: {', '.join(UNIT_SYSTEMS)})") from None


def column_unit(column: str, label: str) -> str:
    """Unit of output ``column`` in the system ``label`` (``""`` for unstated units)."""
    return unit_system(label).of(DIMENSIONS[column])


def axis_label(column: str, label: str) -> str:
    """``"j1_fx [lbf]"``: a column with its unit, for plots and tables (no brackets when unstated)."""
    unit = column_unit(column, label)
    return f"{column} [{unit}]" if unit else column
