"""The generalized slider crank as a description: link-joint constants, derived geometry, bodies, loads.

One :class:`~dualmech.models.case.Case` holds a :class:`Geometry` (thesis Table 1), the
:class:`Bodies` and the :class:`Loads`; every engine builds its model from them.  The derived
geometry every engine needs (the slider line's point ``F`` and axis ``k4``, the crank pin
``P2``) is computed here, once (``docs/conventions.md``, "Frames"; world axes, z the crank axis)::

    P2 = (a1 cos theta1, a1 sin theta1, S1)    the crank pin (ball joint 2)
    F  = (-a4, 0, 0)                           the slider line's foot of the common normal a4
    k4 = (0, sin alpha4, cos alpha4)           the slider axis
    P3 = F - S4 k4                             the slider pin (ball joint 3), |P3 - P2| = a2
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from dualmech.core.dual import scalar_type
from dualmech.core.inertia import BodyInertia


def slider_line(offset: float | np.ndarray, twist: float | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``F`` and ``k4`` of the slider line, each ``(..., 3)`` for ``offset`` ``a4`` and ``twist`` ``alpha4``
    (radians) of shape ``(...)``: ``F = (-a4, 0, 0)``, ``k4 = (0, sin alpha4, cos alpha4)`` (thesis Table 1,
    row 4; ``docs/conventions.md``)."""
    offset, twist = np.asarray(offset, dtype=scalar_type(offset)), np.asarray(twist, dtype=scalar_type(twist))
    zero = np.zeros(np.broadcast_shapes(offset.shape, twist.shape))
    return (np.stack([-offset + zero, zero, zero], -1),
            np.stack([zero, np.sin(twist) + zero, np.cos(twist) + zero], -1))


def crank_pin(crank_length: float | np.ndarray, theta: np.ndarray, s1: np.ndarray) -> np.ndarray:
    """``P2 = (a1 cos theta1, a1 sin theta1, S1)``, ``(n, 3)`` (world) for ``theta`` and ``s1`` ``(n,)``."""
    return np.stack([crank_length * np.cos(theta), crank_length * np.sin(theta), s1], -1)


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
        return self.slider_twist_deg * (math.pi / 180.0)  # math.radians' product, for a complex step too

    @property
    def foot(self) -> np.ndarray:
        """``F``, the point of the slider line on the common normal ``a4`` (world, ``(3,)``)."""
        return slider_line(self.slider_offset, self.slider_twist)[0]

    @property
    def k4(self) -> np.ndarray:
        """The slider axis ``k4``, a unit vector (world, ``(3,)``): ``P3 = F - S4 k4``."""
        return slider_line(self.slider_offset, self.slider_twist)[1]


#: The joint types a case may choose (``[joints]``; ``docs/conventions.md``, "Joints"), first = default.
JOINT_TYPES: dict[str, tuple[str, ...]] = {
    "crank": ("cylindrical", "revolute"),
    "rod_crank": ("ball",),
    "rod_slider": ("ball", "universal"),
}


@dataclass(frozen=True)
class Joints:
    """The joint types of the slider crank (``[joints]``; defaults: today's mechanism).

    ``crank``: ``"cylindrical"`` (``S1`` prescribed, may vary) or ``"revolute"`` (``S1`` fixed);
    ``rod_crank``: ``"ball"``; ``rod_slider``: ``"ball"`` or ``"universal"`` (slider-side axis ``k4``,
    rod-side axis along ``u x k4``: the rod's spin is then determined, not a gauge).
    """

    crank: str = "cylindrical"
    rod_crank: str = "ball"
    rod_slider: str = "ball"

    @property
    def universal(self) -> bool:
        """The rod meets the slider in a universal joint."""
        return self.rod_slider == "universal"

    @property
    def is_default(self) -> bool:
        """Today's mechanism: cylindrical crank, ball-ball rod."""
        return self == Joints()


@dataclass(frozen=True)
class Bodies:
    """Mass properties of the three moving bodies, each in its own body frame."""

    crank: BodyInertia
    rod: BodyInertia
    slider: BodyInertia

    @property
    def ordered(self) -> tuple[BodyInertia, BodyInertia, BodyInertia]:
        """``(crank, rod, slider)``, the order of the loop's moving links."""
        return self.crank, self.rod, self.slider


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
