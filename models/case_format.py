"""The case file's format: its tables and keys, their types and ranges, and the reading of each table.

:func:`parse_tables` turns a parsed case table (a TOML file's, or the keyword arguments of
:class:`~dualmech.models.case.Case`) into the checked parts of a case: geometry, motion, bodies, loads,
joints.  The keys and their meanings are listed in ``docs/conventions.md`` ("Case files"); every number is
checked against a stated :class:`~dualmech.models.inputs.Range` before it is used (``docs/conventions.md``,
"Input ranges").  Errors are :class:`~dualmech.models.inputs.CaseError` (a ``ValueError``) of one line
naming the key, the value received and what would be valid.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from dualmech.core.motion import CrankMotion
from dualmech.models.bodies import bodies_from_table
from dualmech.models.inputs import (
    ACCELERATION,
    ANGLE_DEG,
    AXIAL_CYCLES,
    CRANK_ACCEL,
    CRANK_RPM,
    FORCE,
    LENGTH,
    MAX_CASE_NAME,
    MAX_LENGTH_RATIO,
    MAX_POSITIONS,
    POSITIVE_LENGTH,
    TORQUE,
    CaseError,
    NumberReader,
    Range,
    check_keys,
    check_number,
    check_text,
    check_vector,
    show,
)
from dualmech.models.kinds import KINDS, LINKAGE_KINDS, SLIDER_CRANK
from dualmech.models.mechanism import JOINT_TYPES, Bodies, Geometry, Joints, Loads
from dualmech.models.units import UNIT_SYSTEMS

#: The unit-system labels a case may state (``units = ...``; :mod:`dualmech.models.units`).
#: Nothing is converted; the label only says what the numbers mean.
KNOWN_UNITS: dict[str, str] = {label: system.description for label, system in UNIT_SYSTEMS.items()}
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
    "mechanism": {"kind": (str, False)},
    "joints": {name: (str, False) for name in JOINT_TYPES},
    "loads": {
        "drive_torque": ((int, float), False),
        "slider_force": ((int, float), False),
        "gravity": (list, False),
    },
    "simulation": {"steps_per_degree": ((int, float), False)},
}
_TOP = {"name": (str, True), "units": (str, False), "description": (str, False)}


def deep_copy(d: Any) -> Any:
    if isinstance(d, dict):
        return {k: deep_copy(v) for k, v in d.items()}
    if isinstance(d, list):
        return [deep_copy(v) for v in d]
    return d


def _type_name(t: type | tuple) -> str:
    if t == (int, float):
        return "a number"
    return {str: "a string", dict: "a table", list: "an array"}[t]


def _check_keys(data: dict) -> None:
    check_keys("", data, [*_TOP, *_SCHEMA])
    for key, (typ, required) in _TOP.items():
        if key in data and not isinstance(data[key], typ):
            raise CaseError(f"{key}: expected {_type_name(typ)}, got {show(data[key])}")
        if required and key not in data:
            raise CaseError(f"{key}: required key missing")
    for section, fields in _SCHEMA.items():
        table = data.get(section, {})
        if not isinstance(table, dict):
            raise CaseError(f"{section}: expected a table, got {show(table)}")
        check_keys(section, table, fields)
        for key, value in table.items():
            typ = fields[key][0]
            if isinstance(value, bool) or not isinstance(value, typ):
                raise CaseError(f"{section}.{key}: expected {_type_name(typ)}, got {show(value)}")
        for key, (_, required) in fields.items():
            if required and key not in table:
                raise CaseError(f"{section}.{key}: required key missing")


# ----------------------------------------------------------------------------- sections

def _geometry(g: dict, number: NumberReader = check_number) -> Geometry:
    a1 = number("geometry.crank_length", g["crank_length"], POSITIVE_LENGTH)
    a2 = number("geometry.rod_length", g["rod_length"], POSITIVE_LENGTH)
    a4 = number("geometry.slider_offset", g["slider_offset"], LENGTH)
    alpha = number("geometry.slider_twist_deg", g["slider_twist_deg"], ANGLE_DEG)
    s1 = number("geometry.crank_axial_shift", g["crank_axial_shift"], LENGTH)
    return Geometry(a1, a2, a4, alpha, s1)


#: ``[simulation] steps_per_degree``: whole steps, and few enough that a revolution stays seconds of MuJoCo.
SIMULATION_STEPS = Range(1, 1024, "a whole number of steps per degree")


def _simulation_steps(sim: dict) -> int | None:
    """``[simulation] steps_per_degree`` (``None`` if not given); a one-line error outside
    :data:`SIMULATION_STEPS`."""
    value = sim.get("steps_per_degree")
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int):
        raise CaseError(f"simulation.steps_per_degree: expected {SIMULATION_STEPS.describe()}, "
                        f"got {show(value)}")
    return int(SIMULATION_STEPS.check("simulation.steps_per_degree", value))


def check_kind(data: dict) -> None:
    """Refuse a ``[mechanism]`` that is not a table or names a kind other than the slider crank's (the other
    kinds have their own case format, read by every verb: ``docs/conventions.md``, "Linkages", "Loop
    tables"), in one line; before any other key is checked, since another kind's keys are not unknown
    keys here."""
    mechanism = data.get("mechanism", {})
    if not isinstance(mechanism, dict):
        raise CaseError(f"mechanism: expected a table such as [mechanism] kind = {SLIDER_CRANK!r}, "
                        f"got {show(mechanism)}")
    kind = mechanism.get("kind", SLIDER_CRANK)
    if not isinstance(kind, str):
        raise CaseError(f"mechanism.kind: expected a string, one of {', '.join(KINDS)}; "
                        f"got {show(kind)}")
    if kind in LINKAGE_KINDS:
        raise CaseError(f"mechanism.kind: {show(kind)} is read by dualmech solve, simulate, validate and "
                        "tolerance (in Python: dualmech.solve and the other verbs, by file or bundled name), "
                        f"not by the slider crank's reader (valid here: {SLIDER_CRANK})")
    if kind != SLIDER_CRANK:
        raise CaseError(f"mechanism.kind: {show(kind)} is not a known mechanism (valid: "
                        f"{', '.join(KINDS)})")


def _angles(spec: dict) -> np.ndarray:
    check_keys("motion.angles_deg", spec, ("start", "stop", "step"))
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


def _motion(m: dict, number: NumberReader = check_number) -> CrankMotion:
    rpm = number("motion.crank_rpm", m["crank_rpm"], CRANK_RPM)
    return CrankMotion(
        angles_deg=_angles(m.get("angles_deg", {})),
        speed=2.0 * math.pi * rpm / 60.0,
        accel=number("motion.crank_accel", m.get("crank_accel", 0.0), CRANK_ACCEL),
        axial_amplitude=number("motion.axial_amplitude", m.get("axial_amplitude", 0.0), LENGTH),
        axial_cycles=number("motion.axial_cycles", m.get("axial_cycles", 0.0), AXIAL_CYCLES),
    )


def _loads(ld: dict, number: NumberReader = check_number) -> Loads:
    torque = ld.get("drive_torque")
    force = ld.get("slider_force")
    if (torque is None) == (force is None):
        got = "both" if torque is not None else "neither"
        raise CaseError(f"loads: got {got} of drive_torque / slider_force; give exactly one")
    gravity = check_vector("loads.gravity", ld.get("gravity", [0.0, 0.0, 0.0]), ACCELERATION)
    return Loads(
        drive_torque=None if torque is None else number("loads.drive_torque", torque, TORQUE),
        slider_force=None if force is None else number("loads.slider_force", force, FORCE),
        gravity=gravity,
    )


def _joints(j: dict, motion: CrankMotion) -> Joints:
    for key, value in j.items():
        if value not in JOINT_TYPES[key]:
            raise CaseError(f"joints.{key}: {show(value)} is not a joint type here "
                            f"(valid: {', '.join(JOINT_TYPES[key])})")
    joints = Joints(**j)
    if joints.crank == "revolute" and motion.axial_amplitude != 0.0:
        raise CaseError(f"motion.axial_amplitude: {motion.axial_amplitude!r} moves the crank along its axis, "
                        "which a revolute crank (joints.crank) cannot; use 0 or crank = \"cylindrical\"")
    return joints


def _check_proportions(g: Geometry, m: CrankMotion) -> None:
    size = max(g.crank_length, g.rod_length, abs(g.slider_offset), abs(g.crank_axial_shift),
               abs(m.axial_amplitude))
    for key, length in (("geometry.crank_length", g.crank_length), ("geometry.rod_length", g.rod_length)):
        if length * MAX_LENGTH_RATIO < size:
            raise CaseError(f"{key}: {length!r} is less than 1/{MAX_LENGTH_RATIO:g} of the mechanism's "
                            f"largest length {size:g}; such a link is lost in the rounding of positions")


def case_numbers(data: dict,
                 number: NumberReader = check_number) -> tuple[Geometry, CrankMotion, Bodies, Loads]:
    """The numeric parts of a case table (keys known to be valid): geometry, motion, bodies, loads.

    Every scalar is read by ``number`` (:data:`~dualmech.models.inputs.NumberReader`): the checked
    float for :func:`case_from_dict`; the tolerance study's sensitivities read the checked float plus
    an imaginary step on the varied key, so the case's derived numbers (the speed from the rpm, the
    bodies' mass properties from their shapes) carry its derivative by the same code
    (:mod:`dualmech.models.tolerance.sensitivity`).
    """
    geom = _geometry(data["geometry"], number)
    motion, bodies = _motion(data["motion"], number), bodies_from_table(data.get("bodies", {}), geom, number)
    return geom, motion, bodies, _loads(data.get("loads", {}), number)


def parse_tables(data: dict) -> dict[str, Any]:
    """The validated parts of a case table (the fields of :class:`~dualmech.models.case.Case`), or a one-line
    :class:`CaseError`."""
    check_kind(data)
    _check_keys(data)
    geom, motion, bodies, loads = case_numbers(data)
    _check_proportions(geom, motion)
    joints = _joints(data.get("joints", {}), motion)
    units = data.get("units", "consistent")
    if units not in KNOWN_UNITS:
        raise CaseError(f"units: {show(units)} is not a known unit label (valid: {', '.join(KNOWN_UNITS)})")
    steps = _simulation_steps(data.get("simulation", {}))
    name = check_text("name", data["name"], MAX_CASE_NAME)  # last: a derived name shows the values above
    return {"name": name, "units": units, "geometry": geom, "motion": motion, "bodies": bodies,
            "loads": loads, "raw": deep_copy(data), "joints": joints, "simulation_steps": steps}


def check_top_keys(data: dict) -> None:
    """A one-line :class:`CaseError` for a key of ``data`` that is no table or top-level key of a case."""
    check_keys("", data, [*_TOP, *_SCHEMA])
