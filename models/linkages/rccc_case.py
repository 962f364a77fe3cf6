"""The RCCC linkage (Yang 1971) as a case: ``[mechanism]``, ``[geometry]``, ``[motion]``, ``[bodies]``,
``[loads]``, checked with one-line errors (``docs/conventions.md``, "RCCC")."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from dualmech.core.inertia import BodyInertia
from dualmech.core.motion import CrankMotion
from dualmech.models.inputs import (
    ACCELERATION,
    ANGLE_DEG,
    LENGTH,
    MAX_LENGTH_RATIO,
    TORQUE,
    CaseError,
    check_number,
    check_vector,
)
from dualmech.models.linkages.case_tables import (
    link_body,
    motion_table,
    name_and_units,
    opening,
)

#: Link lengths and twists of the table, per row: (length key, twist key); the ground link last.
LINK_KEYS = (("input_link", "input_twist_deg"), ("coupler", "coupler_twist_deg"),
             ("output_link", "output_twist_deg"), ("frame_offset", "frame_twist_deg"))
#: Keys of each table of an RCCC case and whether each is required.
SCHEMA: dict[str, dict[str, bool]] = {
    "mechanism": {"kind": True, "branch": False},
    "geometry": {"input_offset": False, **{k: True for pair in LINK_KEYS for k in pair}},
    "motion": {"crank_rpm": True, "crank_accel": False, "angles_deg": False},
    "loads": {"output_torque": False, "gravity": False},
    "bodies": {"input_link": True, "coupler": True, "output_link": True},
}
#: Smallest |sin| of a twist: the start estimate takes the common normals from the axes' cross products.
MIN_SIN_TWIST = 1e-3
#: The moving links, in the order of the table's rows.
LINKS = ("input_link", "coupler", "output_link")


@dataclass(frozen=True)
class RcccGeometry:
    """``a[i]``, ``alpha[i]`` (rad): length and twist of row ``i``'s link, from axis ``z(i+1)`` to
    ``z(i+2)`` (``z5 = z1``); ``s1`` the input joint's constant offset along ``z1``."""

    a: tuple[float, float, float, float]
    alpha: tuple[float, float, float, float]
    s1: float

    @property
    def size(self) -> float:
        """The loop's length scale: the largest of its lengths (at least one is non-zero)."""
        return max(abs(self.s1), *map(abs, self.a))


@dataclass(frozen=True)
class RcccCase:
    """A checked RCCC case; the drive torque is always solved, ``output_torque`` (default 0) is the
    moment about ``+z4`` of the ground on the output link at joint 4."""

    name: str
    units: str
    geometry: RcccGeometry
    motion: CrankMotion
    bodies: tuple[BodyInertia, BodyInertia, BodyInertia]
    output_torque: float
    gravity: np.ndarray
    branch: int


def _geometry(g: dict) -> RcccGeometry:
    lengths = tuple(check_number(f"geometry.{key}", g[key], LENGTH) for key, _ in LINK_KEYS)
    twists = tuple(math.radians(check_number(f"geometry.{key}", g[key], ANGLE_DEG)) for _, key in LINK_KEYS)
    geom = RcccGeometry(lengths, twists, check_number("geometry.input_offset", g.get("input_offset", 0.0),
                                                      LENGTH))
    if geom.size == 0.0:
        raise CaseError("geometry: every length is 0; give a non-zero link length")
    for (_, key), twist in zip(LINK_KEYS, twists):
        if abs(math.sin(twist)) < MIN_SIN_TWIST:
            raise CaseError(f"geometry.{key}: {math.degrees(twist)!r} deg makes two joint axes parallel; "
                            f"this solver needs skew axes (|sin(twist)| >= {MIN_SIN_TWIST:g})")
    for (key, _), length in zip(LINK_KEYS[1:3], lengths[1:3]):
        if abs(length) * MAX_LENGTH_RATIO < geom.size and length != 0.0:
            raise CaseError(f"geometry.{key}: {length!r} is less than 1/{MAX_LENGTH_RATIO:g} of the "
                            f"mechanism's largest length {geom.size:g}; such a link is lost in the rounding")
    return geom


def rccc_from_dict(data: Any) -> RcccCase:
    """Validate a parsed RCCC case table and build the :class:`RcccCase`.

    Raises
    ------
    CaseError
        One line naming the key, the value received and what would be valid.
    """
    branch = opening(data, SCHEMA, "rccc", "the sign of the spherical transmission det[z2, z3, z4]")
    geom = _geometry(data["geometry"])
    size = geom.size
    bodies = tuple(link_body(link, data["bodies"][link], max(abs(a), 1e-3 * size))
                   for link, a in zip(LINKS, geom.a))
    loads = data["loads"]
    torque = check_number("loads.output_torque", loads.get("output_torque", 0.0), TORQUE)
    gravity = check_vector("loads.gravity", loads.get("gravity", [0.0, 0.0, 0.0]), ACCELERATION)
    name, units = name_and_units(data)
    return RcccCase(name, units, geom, motion_table(data["motion"]), bodies, torque, gravity, branch)
