"""Any single loop table as a Pinocchio tree cut at its last joint (``docs/conventions.md``, "Loop tables").

::

    universe ──[joint 1]──> link 1 ──[joint 2]──> link 2 ── ... ──[joint n-1]──> link n-1
        ▲                                                                             │
        └──────────── joint n: the cut, its constraint rows (frame B on the ground, ──┘
                      frame A' on link n-1) closed by :mod:`.closure`

Joint ``i`` (0-based ``k``) of the table is placed in its parent link's frame by the previous row's
:math:`X(\\alpha_{k-1} + \\varepsilon a_{k-1})` (the identity for the first joint: frame {1} is the world)
followed by the constant part of its own motion that comes before its variables: a translation ``s`` along
``z`` for R and U (it commutes with the turn), a turn ``theta`` about ``z`` for P.  Its variables are
Pinocchio joints whose child frame is the table's link frame, so the bodies' mass properties go in as given:

====  ======================================================  ==========================================
type  Pinocchio joints                                         coordinates (``q`` = ``v`` entries)
====  ======================================================  ==========================================
R     ``RZ``                                                   ``theta``
P     ``PZ``                                                   ``s``
C     ``RZ`` then ``PZ`` (a massless body between)             ``theta``, ``s``
U     ``RZ`` then ``RY`` (massless between: ``Z(theta) Y(eta)``)  ``theta``, ``eta``
S     ``Spherical`` (a quaternion; ``v`` the relative angular velocity in the link's axes)
====  ======================================================  ==========================================

**The cut.**  Frame ``A`` is frame {n} on link n-1 (the link frame moved by row n-1's ``X``), ``A'`` that
frame moved by joint n's constant part (as above), and ``B = X(alpha_n + eps a_n)^-1`` the ground's frame
that joint n's motion must reach: ``A' . (joint n's free motion) = B``.  Joint n's constraint is a list of
scalar rows, each *linear* :math:`(p_{A'} - p_B)\\cdot b_k = 0` (no slide along ``B``'s axis ``k``),
*angular* :math:`u_{A', i}\\cdot b_k = 0` (two axes kept normal, no turn about their cross product; its
spurious root, the axes opposite, is refused by the closure) or *rotation*: component ``k`` of
:math:`\\log(R_B^T R_{A'})` (no turn at all; dot products would have spurious roots there, e.g. a cyclic
permutation of the axes):

====  =========================  ========================================================
type  linear rows (axes of B)    angular rows (axis of A', axis of B), rotation rows
====  =========================  ========================================================
R     x, y, z                    (z, x), (z, y)
P     x, y                       rotation x, y, z
C     x, y                       (z, x), (z, y)
U     x, y, z                    (z, y): the first axis normal to the second
S     x, y, z                    --
====  =========================  ========================================================

**Idle spin.**  A link between two S joints may spin about the line of their centres (its x axis) without
moving anything: the spin is fixed by a *gauge row*, the link's angular velocity along its own x axis
(the local ``Jacobian``'s angular x row) held at zero, and its angular acceleration likewise (the in-house
engine's zero-spin gauge).  The closure's position steps are minimum-norm, so they do not turn it either.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from dualmech.core.inertia import BodyInertia
from dualmech.models.loop.description import LoopMechanism

#: Each joint type's scalar coordinates in Pinocchio's order (an S joint has none: a quaternion).
COORDINATES: dict[str, tuple[str, ...]] = {"R": ("theta",), "P": ("s",), "C": ("theta", "s"),
                                           "U": ("theta", "eta"), "S": ()}
#: Each type's constraint rows at the cut (module docstring): ``("lin", None, k)``, ``("ang", i, k)`` or
#: ``("rot", None, k)``.
CUT_ROWS: dict[str, tuple[tuple[str, int | None, int], ...]] = {
    "R": (("lin", None, 0), ("lin", None, 1), ("lin", None, 2), ("ang", 2, 0), ("ang", 2, 1)),
    "P": (("lin", None, 0), ("lin", None, 1), ("rot", None, 0), ("rot", None, 1), ("rot", None, 2)),
    "C": (("lin", None, 0), ("lin", None, 1), ("ang", 2, 0), ("ang", 2, 1)),
    "U": (("lin", None, 0), ("lin", None, 1), ("lin", None, 2), ("ang", 2, 1)),
    "S": (("lin", None, 0), ("lin", None, 1), ("lin", None, 2)),
}
_PIN_JOINTS = {"R": ("RZ",), "P": ("PZ",), "C": ("RZ", "PZ"), "U": ("RZ", "RY"), "S": ("Spherical",)}


@dataclass(frozen=True)
class LoopModel:
    """A table's Pinocchio tree, its cut and the indices the judge needs.

    Attributes
    ----------
    mechanism : LoopMechanism
    model, data : pin.Model, pin.Data
    link_joints : tuple of int
        Pinocchio joint whose child frame is link ``k``'s link frame (``k = 0 .. n-2``).
    coordinates : dict of (joint, name) -> (q index, v index)
        Every scalar coordinate of the tree joints (0-based table joint, ``theta``/``s``/``eta``).
    points : tuple of int
        Pinocchio frame at each joint's point (frame {k}'s origin, a U joint's moved by its ``s``), joints
        ``0 .. n-1``: the point the reaction moments are taken about.
    cut : int
        Frame ``A'`` on link n-1 (module docstring).
    ground : pin.SE3
        Frame ``B``, world.
    rows : tuple
        The cut's constraint rows (:data:`CUT_ROWS` of joint n's type).
    spins : tuple of int
        Link joints (:attr:`link_joints` entries) of the links between two S joints: their gauge rows.
    prescribed : tuple of int
        ``v`` indices of the prescribed coordinates (the drive's, a C drive's slide too).
    free : tuple of int
        Every other ``v`` index.
    length : float
        The table's largest constant length (or 1): linear rows are divided by it.
    """

    mechanism: LoopMechanism
    model: pin.Model
    data: pin.Data
    link_joints: tuple[int, ...]
    coordinates: dict[tuple[int, str], tuple[int, int]]
    points: tuple[int, ...]
    cut: int
    ground: pin.SE3
    rows: tuple[tuple[str, int | None, int], ...]
    spins: tuple[int, ...]
    prescribed: tuple[int, ...]
    free: tuple[int, ...]
    length: float


def _rot(axis: int, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    r = np.eye(3)
    r[i, i], r[i, j], r[j, i], r[j, j] = c, -s, s, c
    return r


def link_step(alpha: float, a: float) -> pin.SE3:
    """:math:`X(\\alpha + \\varepsilon a)`: a turn ``alpha`` about x and a slide ``a`` along it."""
    return pin.SE3(_rot(0, alpha), np.array([a, 0.0, 0.0]))


def constant_part(kind: str, theta: float, s: float) -> pin.SE3:
    """The constant part of a joint's motion placed before its variables (module docstring)."""
    if kind in ("R", "U"):
        return pin.SE3(np.eye(3), np.array([0.0, 0.0, s]))
    if kind == "P":
        return pin.SE3(_rot(2, theta), np.zeros(3))
    return pin.SE3.Identity()


def pin_inertia(body: BodyInertia) -> pin.Inertia:
    """A link's mass, centre of mass and inertia about it (link frame) as a ``pin.Inertia``."""
    return pin.Inertia(float(body.mass), np.asarray(body.com, float), np.asarray(body.inertia, float))


def _point(kind: str, s: float) -> pin.SE3:
    """A joint's point in frame {k}: its origin, a U joint's moved by ``s`` to where its axes meet."""
    return pin.SE3(np.eye(3), np.array([0.0, 0.0, s if kind == "U" else 0.0]))


def _frame(model: pin.Model, name: str, parent: int, placement: pin.SE3) -> int:
    return model.addFrame(pin.Frame(name, parent, placement, pin.FrameType.OP_FRAME), False)


def build_model(mechanism: LoopMechanism) -> LoopModel:
    """The Pinocchio tree of ``mechanism`` cut at its last joint (module docstring).

    Raises a one-line :class:`ValueError` if the drive is the last joint (the cut has no coordinates).
    """
    joints, n = mechanism.joints, len(mechanism.joints)
    if mechanism.drive.joint == n - 1:
        raise ValueError(f"drive.joint: the Pinocchio judge cuts the loop at the last joint ({n}), so it "
                         f"cannot be driven; drive one of joints 1..{n - 1}")
    model = pin.Model()
    model.name = mechanism.name
    model.gravity = pin.Motion(np.asarray(mechanism.gravity, float), np.zeros(3))
    parent, step = 0, pin.SE3.Identity()
    links, points, coordinates = [], [], {}
    for k, joint in enumerate(joints[:-1]):
        points.append(_frame(model, f"point{k + 1}", parent, step * _point(joint.type, joint.s)))
        placement = step * constant_part(joint.type, joint.theta, joint.s)
        names = COORDINATES[joint.type]
        for m, kind in enumerate(_PIN_JOINTS[joint.type]):
            parent = model.addJoint(parent, getattr(pin, f"JointModel{kind}")(), placement,
                                    f"joint{k + 1}_{kind}")
            placement = pin.SE3.Identity()
            if names:
                coordinates[(k, names[m])] = (model.joints[parent].idx_q, model.joints[parent].idx_v)
        model.appendBodyToJoint(parent, pin_inertia(mechanism.bodies[k]), pin.SE3.Identity())
        links.append(parent)
        step = link_step(joint.alpha, joint.a)
    last = joints[-1]
    points.append(_frame(model, f"point{n}", parent, step * _point(last.type, last.s)))
    cut = _frame(model, "cut", parent, step * constant_part(last.type, last.theta, last.s))
    spins = tuple(links[k] for k in range(n - 1) if joints[k].type == "S" and joints[k + 1].type == "S")
    prescribed = tuple(coordinates[key][1] for key in mechanism.prescribed)
    free = tuple(v for v in range(model.nv) if v not in prescribed)
    return LoopModel(mechanism, model, model.createData(), tuple(links), coordinates, tuple(points), cut,
                     link_step(last.alpha, last.a).inverse(), CUT_ROWS[last.type], spins, prescribed, free,
                     mechanism.length)
