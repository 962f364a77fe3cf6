"""What every linkage case shares: table checks, ``[motion]``, ``[bodies.<link>]``, name and units.

Every number goes through :func:`~dualmech.models.inputs.check_number` with a stated
:class:`~dualmech.models.inputs.Range`; unknown keys, missing keys and wrong types are refused
naming the key, the value received and what would be valid (``docs/conventions.md``, "RSSR").
"""

from __future__ import annotations

from typing import Any

import numpy as np

from dualmech.core.inertia import BodyInertia, solid_cylinder_x
from dualmech.core.motion import CrankMotion
from dualmech.models.bodies import _tensor as inertia_tensor
from dualmech.models.case_format import KNOWN_UNITS, _motion
from dualmech.models.inputs import (
    LENGTH,
    MAX_CASE_NAME,
    POSITIVE_LENGTH,
    POSITIVE_MASS,
    CaseError,
    check_keys,
    check_number,
    check_text,
    check_vector,
    show,
)

#: Keys of one ``[bodies.<link>]`` table.
BODY_KEYS = ("mass", "radius", "com", "inertia")


def check_tables(data: dict, schema: dict[str, dict[str, bool]]) -> None:
    """Unknown, missing and mistyped keys of the top level and of every table of ``schema`` (key ->
    whether it is required)."""
    top = {"name", "units", "description", *schema}
    check_keys("", data, top)
    if "name" not in data:
        raise CaseError("name: required key missing")
    for section, keys in schema.items():
        table = data.get(section)
        if not isinstance(table, dict):
            raise CaseError(f"{section}: expected a table, got {show(table)}")
        check_keys(section, table, keys)
        for key, required in keys.items():
            if required and key not in table:
                raise CaseError(f"{section}.{key}: required key missing")



def link_body(link: str, b: Any, length: float, axisymmetric: bool = False) -> BodyInertia:
    """``[bodies.<link>]``: ``mass``, then ``inertia`` or a ``radius`` (uniform solid cylinder along the
    body x axis from the joint to the pin), ``com`` (default: the link's midpoint ``[L/2, 0, 0]``)."""
    key = f"bodies.{link}"
    if not isinstance(b, dict):
        raise CaseError(f"{key}: expected a table, got {show(b)}")
    check_keys(key, b, BODY_KEYS)
    if "mass" not in b:
        raise CaseError(f"{key}.mass: required key missing")
    mass = check_number(f"{key}.mass", b["mass"], POSITIVE_MASS)
    if ("inertia" in b) == ("radius" in b):
        raise CaseError(f"{key}: give exactly one of inertia (3 moments or 3x3) or radius (a solid "
                        f"cylinder), got {'both' if 'inertia' in b else 'neither'}")
    if "inertia" in b:
        inertia = inertia_tensor(f"{key}.inertia", b["inertia"])
    else:
        inertia = solid_cylinder_x(mass, length, check_number(f"{key}.radius", b["radius"], POSITIVE_LENGTH))
    com = check_vector(f"{key}.com", b["com"], LENGTH) if "com" in b else np.array([length / 2, 0.0, 0.0])
    try:
        body = BodyInertia(mass, com, inertia)
    except ValueError as err:
        raise CaseError(f"{key}.{err}") from None
    if axisymmetric:
        _check_axisymmetric(link, body)
    return body


def _check_axisymmetric(link: str, body: BodyInertia) -> None:
    """Two ball joints leave a link's spin free (zero-spin gauge): its mass must not see that spin."""
    i = body.inertia
    if np.hypot(body.com[1], body.com[2]) > 1e-12 * float(np.linalg.norm(body.com)):
        raise CaseError(f"bodies.{link}.com: {body.com.tolist()} is off the link's axis; two ball joints "
                        "leave its spin free, so the centre of mass must be [x, 0, 0]")
    off = abs(i[0, 1]) + abs(i[0, 2]) + abs(i[1, 2])
    if off + abs(i[1, 1] - i[2, 2]) > 1e-12 * float(np.abs(i).max()):
        raise CaseError(f"bodies.{link}.inertia: {i.tolist()} is not axisymmetric; two ball joints leave "
                        "its spin free, so it must be diag(I_axial, I_t, I_t)")


def motion_table(m: dict) -> CrankMotion:
    """``[motion]``: ``crank_rpm``, ``crank_accel``, ``angles_deg`` (as the slider crank's)."""
    if not isinstance(m.get("angles_deg", {}), dict):
        raise CaseError(f"motion.angles_deg: expected a table {{start, stop, step}}, "
                        f"got {show(m['angles_deg'])}")
    return _motion(m)


def opening(data: Any, schema: dict[str, dict[str, bool]], kind: str, meaning: str) -> int:
    """Check that ``data`` is a case table of ``schema`` whose ``[mechanism] kind`` is ``kind``, and return
    its ``branch``: 1 (default) or -1, ``meaning`` says of what it is the sign."""
    if not isinstance(data, dict):
        raise CaseError(f"case: expected a table, got {show(data)}")
    check_tables(data, schema)
    if data["mechanism"]["kind"] != kind:
        raise CaseError(f"mechanism.kind: {show(data['mechanism']['kind'])} is not the {kind.upper()} "
                        f"(expected {kind!r})")
    branch = data["mechanism"].get("branch", 1)
    if isinstance(branch, bool) or branch not in (1, -1):
        raise CaseError(f"mechanism.branch: expected 1 or -1 ({meaning}), got {show(branch)}")
    return int(branch)


def name_and_units(data: dict) -> tuple[str, str]:
    """``name`` and ``units`` (and a valid ``description``) of a case table."""
    units = data.get("units", "consistent")
    if units not in KNOWN_UNITS:
        raise CaseError(f"units: {show(units)} is not a known unit label (valid: {', '.join(KNOWN_UNITS)})")
    if "description" in data:
        check_text("description", data["description"], 10 * MAX_CASE_NAME)
    return check_text("name", data["name"], MAX_CASE_NAME), units
