"""The MJCF of any loop table that MuJoCo can *simulate*: the rigid judge's tree, the loop cut inside the
ground.

::

    world                                     site "cut_ground" (the ground's link frame at joint n)
     └─ link1 ─ ... ─ link<n-1>               :func:`~.mjcf.loop_mjcf`'s tree, unchanged
                        └─ ground_half        joint n's MuJoCo joints (its free directions), site "cut_half"

    equality: weld "cut" site1="cut_half" site2="cut_ground"   (soft: solref, solimp of the settings)

**Why this cut.** MuJoCo's equalities hold two frames together entirely (``weld``) or two points
(``connect``); neither leaves a revolute, prismatic, cylindrical or universal joint's free directions free,
and the rigid MJCF's ``weld`` at joint n (:mod:`.mjcf`) holds them fixed.  Cutting at a spherical joint
would need one (the RSSR and slider crank tables have two, but not at joint n, and the RCCC none), and
re-rooting the chain there would change the world frame of every column.  Cutting *inside a link* works for
every table: the ground (link n) is split into the world and a second half, ``ground_half``, carried by
link n-1 through joint n's own MuJoCo joints (hinge, slide, ball, the U's two hinges: :data:`.mjcf.MJ_JOINTS`,
placed as :func:`.mjcf.placement` places any link), and the weld holds the two halves of the ground
together.  Its six rows are independent of the tree (joint n's freedoms are dofs now), so the table's
mobility is MuJoCo's too, and joint n's wrench is the one ``ground_half`` receives from link n-1.

**The ground half's mass.** MuJoCo refuses a moving body without mass, so ``ground_half`` weighs
:data:`HALF_MASS` of the lightest link (a point mass at its origin, inertia :data:`HALF_MASS` of that
link's smallest principal moment).  Welded to the world it moves only by the weld's softness, so its
inertia adds ~:data:`HALF_MASS` of a link's inertial forces to joint n's wrench (and its weight
:data:`HALF_MASS` of the lightest link's): far below what the simulation's time step leaves
(:mod:`.simulation`).  Every table body keeps its mass properties.

**Actuators.** The drive joint's coordinate (and a C drive's slide) is a position servo (``kp``, ``kv``
of :class:`SimSettings`; the caller's ``ctrl`` is ``q_ref + (kv/kp) qdot_ref``: PD with feed-forward of
the rate, as the slider crank's simulated judge); every load (given or solved) is a motor on its joint's
coordinate, gear 1, ``ctrl`` its effort on the joint's following link from the previous one.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np

from dualmech.models.loop.description import LoopMechanism
from dualmech.validation.judges.mujoco_loop.mjcf import (
    CUT_SITES,
    MJ_JOINTS,
    joint_name,
    loop_mjcf,
    placement,
)

#: The ground half's mass over the lightest link's (module docstring).
HALF_MASS = 1.0
#: Body and site of the ground half.
HALF_BODY, HALF_SITE = "ground_half", "cut_half"


@dataclass(frozen=True)
class SimSettings:
    """What the simulation MJCF holds beyond the table.

    Attributes
    ----------
    timestep : float
        Seconds.
    servo_kp, servo_kv : tuple of float
        Position and velocity gains of the drive's servos (its coordinate, then a C drive's slide): F·L/rad
        and F·L·s/rad for an angle, F/L and F·s/L for a slide.
    weld_solref : tuple of float
        The weld's time constant (s) and damping ratio.
    weld_solimp : tuple of float
        The weld's impedance ``(dmin, dmax, width, midpoint, power)``.
    """

    timestep: float
    servo_kp: tuple[float, ...]
    servo_kv: tuple[float, ...]
    weld_solref: tuple[float, float]
    weld_solimp: tuple[float, float, float, float, float]


def _text(values) -> str:
    return " ".join(repr(float(v)) for v in np.ravel(values))


def servoed(mechanism: LoopMechanism) -> list[str]:
    """MuJoCo joint names of the drive's servos, in the order of :attr:`SimSettings.servo_kp`."""
    d = mechanism.drive
    names = [joint_name(d.joint, d.coordinate)]
    if mechanism.joints[d.joint].type == "C":
        names.append(joint_name(d.joint, "s"))
    return names


def loaded(mechanism: LoopMechanism) -> list[str]:
    """MuJoCo joint names of the loads' motors, in the order of ``mechanism.loads``."""
    return [joint_name(load.joint, load.coordinate) for load in mechanism.loads]


def loop_sim_mjcf(mechanism: LoopMechanism, settings: SimSettings) -> str:
    """The simulation MJCF of ``mechanism`` (module docstring).

    Returns
    -------
    str
        A ``<mujoco>`` document: ``qpos`` holds joints 1 .. n-1's variables as the rigid MJCF's, then joint
        n's (``ground_half``'s); actuators: the servos (:func:`servoed`), then the motors (:func:`loaded`).
    """
    root = ET.fromstring(loop_mjcf(mechanism))
    joints = mechanism.joints
    n = len(joints)
    option = root.find("option")
    option.set("timestep", repr(float(settings.timestep)))
    option.set("integrator", "implicitfast")
    last = next(b for b in root.iter("body") if b.get("name") == f"link{n - 1}")
    pos, quat = placement(mechanism, n)
    half = ET.SubElement(last, "body", name=HALF_BODY, pos=_text(pos), quat=_text(quat))
    for coordinate, kind, axis in MJ_JOINTS[joints[-1].type]:
        attrs = {"name": joint_name(n - 1, coordinate), "type": kind, "pos": "0 0 0"}
        if axis:
            attrs["axis"] = axis
        ET.SubElement(half, "joint", **attrs)
    heaviest = max(mechanism.bodies, key=lambda b: b.mass)
    moment = HALF_MASS * float(np.linalg.eigvalsh(np.asarray(heaviest.inertia)).max())
    ET.SubElement(half, "inertial", pos="0 0 0", mass=repr(HALF_MASS * heaviest.mass),
                  diaginertia=_text([moment] * 3))
    ET.SubElement(half, "site", name=HALF_SITE)
    equality = root.find("equality")
    for child in list(equality):
        equality.remove(child)
    ET.SubElement(equality, "weld", name="cut", site1=HALF_SITE, site2=CUT_SITES[1],
                  solref=_text(settings.weld_solref), solimp=_text(settings.weld_solimp))
    actuators = ET.SubElement(root, "actuator")
    for name, kp, kv in zip(servoed(mechanism), settings.servo_kp, settings.servo_kv):
        ET.SubElement(actuators, "position", name=f"servo_{name}", joint=name, kp=repr(float(kp)),
                      kv=repr(float(kv)))
    for name in loaded(mechanism):
        ET.SubElement(actuators, "motor", name=f"load_{name}", joint=name, gear="1")
    ET.indent(root)
    return ET.tostring(root, encoding="unicode") + "\n"


__all__ = ["HALF_BODY", "HALF_MASS", "HALF_SITE", "SimSettings", "loaded", "loop_sim_mjcf", "servoed"]
