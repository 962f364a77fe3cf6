"""A single closed loop as a table of joints (thesis Table 1, any joint types): the mechanism description.

::

    joint i  (1-based, as the thesis numbers them)
      type    R revolute (theta)    P prismatic (s)     C cylindrical (theta, s)
              S spherical (a free rotation)             U universal (theta, then eta about the turned y)
      theta   constant angle about z_i   (a P joint's; the variable of the others)
      s       constant offset along z_i  (an R or U joint's; the variable of P and C)
      alpha   twist from z_i to z_(i+1) about the common normal x_(i+1)  } the link carried by joint i,
      a       length along that common normal, from axis i to axis i+1   } from joint i to joint i+1

Joint ``i`` connects link ``i-1`` to link ``i`` (link 0 = link n = the ground); its table row is
:math:`Z(\\theta_i + \\varepsilon S_i)\\, Y(\\eta_i)\\, X(\\alpha_i + \\varepsilon a_i)` (thesis eq. 1-4), so
the last joint's ``alpha``, ``a`` are the ground's own geometry, from the last axis back to axis 1,
and the loop closes when the product of all rows is the identity (eq. 5).  The world frame is the
frame of joint 1 (``z`` its axis).  Frames, signs and units: ``docs/conventions.md``, "Loop tables".

This module holds the frozen records only; :mod:`dualmech.models.loop.table_format` reads them
from a file's tables, :mod:`dualmech.models.loop.mobility` checks that the table moves with one
degree of freedom.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from dualmech.core.inertia import BodyInertia

#: The joint types and their freedoms (the number of joint variables).
FREEDOMS: dict[str, int] = {"R": 1, "P": 1, "C": 2, "S": 3, "U": 2}
JOINT_TYPES: tuple[str, ...] = tuple(FREEDOMS)
#: Which coordinate a joint may be driven by: an angle ``theta`` or a slide ``s`` (a C joint by its angle,
#: its slide then follows the axial law of :class:`Drive`).
DRIVABLE: dict[str, tuple[str, ...]] = {"R": ("theta",), "P": ("s",), "C": ("theta",)}
#: The free coordinates a given effort (:class:`Load`) may act along.
LOADABLE: dict[str, tuple[str, ...]] = {"R": ("theta",), "P": ("s",), "C": ("theta", "s")}


@dataclass(frozen=True)
class Joint:
    """One row of the table (module docstring): the joint's type and constant parts, the next link's
    dual angle :math:`\\alpha + \\varepsilon a`.

    Attributes
    ----------
    type : str
        ``"R"``, ``"P"``, ``"C"``, ``"S"`` or ``"U"``.
    alpha : float
        Twist from this joint's axis to the next about their common normal, rad.
    a : float
        Length of that common normal (case length unit).
    theta : float
        Constant angle about the joint axis, rad: a P joint's (the others' angle is a variable; must be 0
        for them).
    s : float
        Constant offset along the joint axis: an R or U joint's (must be 0 for P, C and S).
    start : tuple of float
        The joint's variables at the first drive position, as an assembled pose or a start estimate:
        R ``(theta,)`` rad, P ``(s,)``, C ``(theta, s)``, U ``(theta, eta)`` rad, S a rotation vector
        ``(rx, ry, rz)`` rad in the axes before the joint; empty: zeros (then searched).
    """

    type: str
    alpha: float = 0.0
    a: float = 0.0
    theta: float = 0.0
    s: float = 0.0
    start: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        if self.type not in FREEDOMS:
            raise ValueError(f"type: expected one of {', '.join(JOINT_TYPES)}, got {self.type!r}")
        for name in ("alpha", "a", "theta", "s"):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"{name}: expected a finite number, got {getattr(self, name)!r}")
        if self.theta != 0.0 and self.type != "P":
            raise ValueError(f"theta: a constant angle belongs to a P joint only, got {self.theta!r} "
                             f"on a {self.type} joint (its angle is a variable)")
        if self.s != 0.0 and self.type not in ("R", "U"):
            raise ValueError(f"s: a constant offset belongs to an R or U joint only, got {self.s!r} "
                             f"on a {self.type} joint")
        if self.start and len(self.start) != FREEDOMS[self.type]:
            raise ValueError(f"start: a {self.type} joint has {FREEDOMS[self.type]} variables, got "
                             f"{len(self.start)} values")

    @property
    def freedoms(self) -> int:
        """Number of joint variables :math:`f_i`."""
        return FREEDOMS[self.type]


@dataclass(frozen=True)
class Drive:
    """The driven joint and its prescribed motion.

    Attributes
    ----------
    joint : int
        Index (0-based) of the driven joint: an R (angle), a P (slide) or a C (angle, with its slide
        prescribed by the axial law).
    coordinate : str
        ``"theta"`` (an angle) or ``"s"`` (a slide) of that joint.
    positions : numpy.ndarray, shape (n,)
        The driven coordinate at every analysed position: rad or length.
    speed, accel : float
        Its first and second time derivatives (the same at every position, as a crank's snapshot
        states, ``core/motion.py``): rad/s, rad/s² or length/s, length/s².
    axial_shift, axial_amplitude, axial_cycles : float
        A C joint driven by its angle: its slide follows the thesis's law
        :math:`S = S_0 + S_{S}\\sin(\\alpha\\theta)` (eq. 27-28, :meth:`dualmech.core.motion.CrankMotion.at`),
        so both its variables are prescribed; 0 for every other drive.
    effort : float or None
        The drive effort (torque about, or force along, the driven axis on the driven link from the
        previous one) if it is given; ``None``: solved (then every :class:`Load` is given).
    """

    joint: int
    coordinate: str
    positions: np.ndarray
    speed: float
    accel: float = 0.0
    axial_shift: float = 0.0
    axial_amplitude: float = 0.0
    axial_cycles: float = 0.0
    effort: float | None = None

    def __post_init__(self) -> None:
        positions = np.asarray(self.positions, dtype=float).reshape(-1)
        if positions.size == 0 or not np.isfinite(positions).all():
            raise ValueError(f"positions: expected one or more finite numbers, got {positions.tolist()!r}")
        object.__setattr__(self, "positions", positions)
        if self.coordinate not in ("theta", "s"):
            raise ValueError(f"coordinate: expected 'theta' or 's', got {self.coordinate!r}")
        for name in ("speed", "accel", "axial_shift", "axial_amplitude", "axial_cycles"):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"{name}: expected a finite number, got {getattr(self, name)!r}")
        if self.effort is not None and not math.isfinite(self.effort):
            raise ValueError(f"effort: expected a finite number or none (solved), got {self.effort!r}")


@dataclass(frozen=True)
class Load:
    """A given effort along a joint's free coordinate: a torque about (``coordinate = "theta"``) or a
    force along (``"s"``) the joint's axis, exerted on the joint's following link by its previous one.

    ``value`` ``None`` marks the one effort solved for when the drive's effort is given.
    """

    joint: int
    coordinate: str
    value: float | None

    def __post_init__(self) -> None:
        if self.coordinate not in ("theta", "s"):
            raise ValueError(f"coordinate: expected 'theta' or 's', got {self.coordinate!r}")
        if self.value is not None and not math.isfinite(self.value):
            raise ValueError(f"value: expected a finite number or none (solved), got {self.value!r}")


@dataclass(frozen=True)
class LoopMechanism:
    """A single loop: joints, drive, bodies and loads (module docstring).

    Attributes
    ----------
    name : str
    joints : tuple of Joint
        In loop order; joint ``i`` carries link ``i`` (0-based: joint 0 = ground to link 1).
    drive : Drive
    bodies : tuple of BodyInertia
        One per moving link (``len(joints) - 1``), in the link frame of the joint that carries it
        (origin on that joint's axis at the foot of the next common normal, x along it, z the axis).
    loads : tuple of Load
    gravity : numpy.ndarray, shape (3,)
        Gravitational acceleration, world axes.
    limits : bool
        Whether the loop table's assembly-limit rule names its rows
        (:func:`~dualmech.models.loop.columns.limit_words`); ``False`` for a preset whose mechanism has its
        own rule (the RSSR's and RCCC's transmissions, :mod:`dualmech.models.loop.presets`).
    """

    name: str
    joints: tuple[Joint, ...]
    drive: Drive
    bodies: tuple[BodyInertia, ...]
    loads: tuple[Load, ...] = ()
    gravity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    limits: bool = True

    def __post_init__(self) -> None:
        n = len(self.joints)
        if n < 2:
            raise ValueError(f"joint: a loop needs at least 2 joints, got {n}")
        d = self.drive
        if not 0 <= d.joint < n:
            raise ValueError(f"drive.joint: expected 1..{n}, got {d.joint + 1}")
        kind = self.joints[d.joint].type
        if d.coordinate not in DRIVABLE.get(kind, ()):
            raise ValueError(f"drive.coordinate: joint[{d.joint + 1}] is {kind}, which cannot be driven by "
                             f"{d.coordinate!r} (R: theta, P: s, C: theta)")
        if (d.axial_amplitude or d.axial_shift) and not (kind == "C" and d.coordinate == "theta"):
            raise ValueError("drive.axial_shift: the axial law belongs to a C joint driven by its angle")
        if len(self.bodies) != n - 1:
            raise ValueError(f"body: expected one per moving link ({n - 1}), got {len(self.bodies)}")
        gravity = np.asarray(self.gravity, dtype=float).reshape(-1)
        if gravity.shape != (3,) or not np.isfinite(gravity).all():
            raise ValueError(f"gravity: expected 3 finite numbers, got {gravity.tolist()!r}")
        object.__setattr__(self, "gravity", gravity)
        self._check_loads()

    def _check_loads(self) -> None:
        seen = set()
        for k, load in enumerate(self.loads):
            if not 0 <= load.joint < len(self.joints):
                raise ValueError(f"load[{k + 1}].joint: expected 1..{len(self.joints)}, got {load.joint + 1}")
            kind = self.joints[load.joint].type
            if load.coordinate not in LOADABLE.get(kind, ()):
                raise ValueError(f"load[{k + 1}].coordinate: joint[{load.joint + 1}] is {kind}, it has no "
                                 f"free "
                                 f"{load.coordinate!r} (R: theta, P: s, C: theta or s)")
            key = (load.joint, load.coordinate)
            if key in seen or key in self.prescribed:
                raise ValueError(f"load[{k + 1}]: joint[{load.joint + 1}].{load.coordinate} is loaded twice "
                                 "or "
                                 "prescribed (the drive's effort is drive.effort)")
            seen.add(key)
        solved = sum(load.value is None for load in self.loads) + (self.drive.effort is None)
        if solved != 1:
            raise ValueError(f"loads: exactly one effort is solved for (drive.effort or one load's value "
                             f"left out), got {solved}")

    @property
    def driven_coordinate(self) -> tuple[int, str]:
        """``(joint, coordinate)`` of the drive."""
        return self.drive.joint, self.drive.coordinate

    @property
    def length(self) -> float:
        """The table's length: its largest constant length (``a``, ``s``), or 1 if it has none (the scale
        of its closure residuals and of a slide's rates against an angle's)."""
        size = max(max(abs(j.a), abs(j.s)) for j in self.joints)
        return size if size > 0.0 else 1.0

    @property
    def prescribed(self) -> tuple[tuple[int, str], ...]:
        """Every prescribed joint coordinate: the drive's, and a C joint's slide under the axial law."""
        d = self.drive
        if self.joints[d.joint].type == "C":
            return ((d.joint, "theta"), (d.joint, "s"))
        return ((d.joint, d.coordinate),)
