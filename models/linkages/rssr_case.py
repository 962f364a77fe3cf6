"""The RSSR spatial four-bar as a case: its ``[mechanism]``, ``[geometry]``, ``[motion]``, ``[bodies]``
and ``[loads]`` tables, checked with one-line errors (``docs/conventions.md``, "RSSR").

Every number goes through :func:`~dualmech.models.inputs.check_number` with a stated
:class:`~dualmech.models.inputs.Range`; unknown keys, missing keys and wrong types are
refused naming the key, the value received and what would be valid.
"""

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
    POSITIVE_LENGTH,
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

#: Keys of each table of an RSSR case and whether each is required.
SCHEMA: dict[str, dict[str, bool]] = {
    "mechanism": {"kind": True, "branch": False},
    "geometry": {"input_crank": True, "input_offset": False, "coupler": True, "output_crank": True,
                 "output_offset": False, "frame_offset": True, "frame_twist_deg": True},
    "motion": {"crank_rpm": True, "crank_accel": False, "angles_deg": False},
    "loads": {"drive_torque": False, "output_torque": False, "gravity": False},
    "bodies": {"input_crank": True, "coupler": True, "output_crank": True},
}
#: The links, in the order of the table's rows, and the length each runs along its body x axis.
LINKS = ("input_crank", "coupler", "output_crank")


@dataclass(frozen=True)
class RssrGeometry:
    """Lengths (case units) and the frame twist (radians) of ``docs/conventions.md``, "RSSR"."""

    a1: float  # input crank: pin P2 at distance a1 from the z axis
    s1: float  # input offset: P2 at height s1 along z
    a2: float  # coupler, P2 -> P3
    a3: float  # output crank: pin P3 at distance a3 from the output axis
    h: float  # output offset: the output crank's foot Q4 = F + h k4
    a4: float  # frame offset: the output axis passes through F = (-a4, 0, 0)
    alpha4: float  # frame twist (rad): k4 = (0, sin alpha4, cos alpha4)

    @property
    def k4(self) -> np.ndarray:
        """Output axis direction, world axes, ``(3,)``."""
        return np.array([0.0, math.sin(self.alpha4), math.cos(self.alpha4)])

    @property
    def foot(self) -> np.ndarray:
        """``Q4 = F + h k4``, the output crank's foot on its axis, world, ``(3,)``."""
        return np.array([-self.a4, 0.0, 0.0]) + self.h * self.k4

    def ground_rotation(self) -> np.ndarray:
        """``G4 = Rx(-alpha4)`` ``(3, 3)``: x = world x, z = k4 (the output crank's axes at ``phi4 = 0``)."""
        c, s = math.cos(self.alpha4), math.sin(self.alpha4)
        return np.array([[1.0, 0.0, 0.0], [0.0, c, s], [0.0, -s, c]])


@dataclass(frozen=True)
class RssrCase:
    """A checked RSSR case.

    ``bodies`` are (input crank, coupler, output crank) in their body frames
    (``docs/conventions.md``, "RSSR"); ``drive_torque`` / ``output_torque``: exactly one is
    a number, the other ``None``; ``gravity`` ``(3,)`` world; ``branch`` +1 or -1, the sign of
    the output transmission ``t4`` the solution keeps.
    """

    name: str
    units: str
    geometry: RssrGeometry
    motion: CrankMotion
    bodies: tuple[BodyInertia, BodyInertia, BodyInertia]
    drive_torque: float | None
    output_torque: float | None
    gravity: np.ndarray
    branch: int

    @property
    def mode(self) -> str:
        """``"torque"`` (drive torque given, output torque solved) or ``"output"`` (the reverse)."""
        return "torque" if self.drive_torque is not None else "output"


def _geometry(g: dict) -> RssrGeometry:
    lengths = {key: check_number(f"geometry.{key}", g[key], POSITIVE_LENGTH)
               for key in ("input_crank", "coupler", "output_crank")}
    offsets = {key: check_number(f"geometry.{key}", g.get(key, 0.0), LENGTH)
               for key in ("input_offset", "output_offset", "frame_offset")}
    twist = check_number("geometry.frame_twist_deg", g["frame_twist_deg"], ANGLE_DEG)
    size = max([*lengths.values(), *map(abs, offsets.values())])
    for key, length in lengths.items():
        if length * MAX_LENGTH_RATIO < size:
            raise CaseError(f"geometry.{key}: {length!r} is less than 1/{MAX_LENGTH_RATIO:g} of the "
                            f"mechanism's largest length {size:g}; such a link is lost in the rounding")
    return RssrGeometry(lengths["input_crank"], offsets["input_offset"], lengths["coupler"],
                        lengths["output_crank"], offsets["output_offset"], offsets["frame_offset"],
                        math.radians(twist))


def _loads(ld: dict) -> tuple[float | None, float | None, np.ndarray]:
    torque, output = ld.get("drive_torque"), ld.get("output_torque")
    if (torque is None) == (output is None):
        got = "both" if torque is not None else "neither"
        raise CaseError(f"loads: got {got} of drive_torque / output_torque; give exactly one")
    gravity = check_vector("loads.gravity", ld.get("gravity", [0.0, 0.0, 0.0]), ACCELERATION)
    return (None if torque is None else check_number("loads.drive_torque", torque, TORQUE),
            None if output is None else check_number("loads.output_torque", output, TORQUE), gravity)


def rssr_from_dict(data: Any) -> RssrCase:
    """Validate a parsed RSSR case table and build the :class:`RssrCase`.

    Raises
    ------
    CaseError
        One line naming the key, the value received and what would be valid.
    """
    branch = opening(data, SCHEMA, "rssr", "the sign of the output transmission t4")
    geom = _geometry(data["geometry"])
    motion = motion_table(data["motion"])
    lengths = (geom.a1, geom.a2, geom.a3)
    bodies = tuple(link_body(link, data["bodies"][link], length, link == "coupler")
                   for link, length in zip(LINKS, lengths))
    torque, output, gravity = _loads(data["loads"])
    name, units = name_and_units(data)
    return RssrCase(name, units, geom, motion, bodies, torque, output, gravity, branch)
