"""The MuJoCo model (MJCF) of a case: ball and cylindrical joints, the loop closed by a connect.

One case file builds the in-house model, the Pinocchio model and this MJCF, so
every mass property comes from ``case.bodies`` (``docs/conventions.md``,
"Body frames"); nothing is recomputed here.  The text is plain MJCF that
MuJoCo compiles and that Pinocchio's MJCF parser imports; this module does not
import MuJoCo (engines stay at the edge, ``validation/``).

Kinematic tree (one root body under ``<worldbody>``, as Pinocchio's parser wants)::

    world
     └─ ground            fixed, no joint, no mass: the root of both branches
         ├─ crank         joint 1 = hinge "crank_angle" + slide "crank_axial", both about/along +z
         │   └─ rod       joint 2 = ball "rod_ball" at the crank pin P2 = (a1, 0, 0) in the crank frame
         │       · site "rod_end" at (a2, 0, 0) in the rod frame
         └─ slider        joint 4 = slide "slider_stroke" along -k4 through F, qpos = S4
             · site "slider_pin" at P3 (the slider origin)

    equality: connect "joint3" site1="slider_pin" site2="rod_end"   (joint 3, the loop cut)

Coordinates (``qpos``): ``[theta1, S1, quat_rod (w, x, y, z), S4]``; velocities
(``qvel``): ``[theta1_dot, S1_dot, omega_rod (3, rod frame), S4_dot]``.
At ``qpos = 0`` (identity quaternion) the body frames are those of
``docs/conventions.md`` at ``theta1 = 0, S1 = 0``, except the rod, whose frame
starts parallel to the crank frame; closing the loop turns its x axis onto
``u = (P3 - P2)/a2`` (the rod's y, z are free: it is axisymmetric).

Actuators (for simulation; inert while ``ctrl = 0`` is not used by the rigid path):

* ``crank_angle_servo``, ``crank_axial_servo``: ``<general>`` servos with
  ``biastype="affine"`` (MuJoCo ignores ``biasprm`` otherwise), force
  :math:`k_p\\,\\mathrm{ctrl} - k_p q - k_v \\dot q`.  With
  :math:`\\mathrm{ctrl} = q_\\mathrm{ref} + (k_v/k_p)\\dot q_\\mathrm{ref}` this is
  the PD law :math:`k_p (q_\\mathrm{ref} - q) + k_v(\\dot q_\\mathrm{ref} - \\dot q)`.
* ``slider_load``: a motor on ``slider_stroke`` with ``gear = -1``; the joint
  axis is ``-k4``, so ``ctrl`` is the slider load ``k4 · (force of the ground on
  the slider)`` of the conventions.
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np

from dualmech.core.inertia import BodyInertia
from dualmech.models.case import Case

#: Names used in the MJCF; the MuJoCo engines look elements up by these.
BODY_NAMES = ("ground", "crank", "rod", "slider")
JOINT_NAMES = ("crank_angle", "crank_axial", "rod_ball", "slider_stroke")
SITE_NAMES = ("rod_end", "slider_pin")
ACTUATOR_NAMES = ("crank_angle_servo", "crank_axial_servo", "slider_load")
CONNECT_NAME = "joint3"


@dataclass(frozen=True)
class MjcfSettings:
    """Simulation settings written into the MJCF (the rigid path ignores all of them).

    Attributes
    ----------
    timestep : float
        ``<option timestep>``, seconds.
    closure_timeconst : float
        First ``solref`` value of the connect, seconds (MuJoCo clamps it to
        ``>= 2*timestep`` unless the ``refsafe`` flag is disabled).
    closure_impedance : float
        ``solimp`` dmin = dmax of the connect, in (0, 1); MuJoCo's ceiling is 0.9999.
    servo_kp : tuple[float, float]
        Position gains of the crank-angle (F·L/rad) and crank-axial (F/L) servos.
    servo_kv : tuple[float, float]
        Velocity gains of the same servos (F·L·s/rad, F·s/L).
    integrator : str
        ``"implicitfast"`` treats the servos' velocity gains implicitly.
    """

    timestep: float
    closure_timeconst: float
    closure_impedance: float
    servo_kp: tuple[float, float]
    servo_kv: tuple[float, float]
    integrator: str = "implicitfast"


def default_settings(case: Case, timestep: float = 1e-4, bandwidth_steps: float = 0.25) -> MjcfSettings:
    """Settings that keep a simulation of ``case`` stable at ``timestep``.

    The servos are critically damped with natural frequency
    :math:`\\omega_n = \\text{bandwidth\\_steps}/\\Delta t` for an effective inertia
    estimated from ``case.bodies`` (crank about its axis plus rod and slider
    masses at the crank pin, an upper bound of the loop's reflected inertia
    up to the transmission); ``kp = I\\,\\omega_n^2``, ``kv = 2 I \\omega_n``.
    The connect is as stiff as MuJoCo allows: time constant ``2*timestep``
    (critical damping) and impedance 0.9999.
    """
    if not (math.isfinite(timestep) and timestep > 0):
        raise ValueError(f"timestep: expected a positive number of seconds, got {timestep!r}")
    b = case.bodies
    a1 = case.geometry.crank_length
    pin_mass = b.rod.mass + b.slider.mass
    crank_izz = _about_axis_z(b.crank)
    inertia_angle = crank_izz + pin_mass * a1**2
    mass_axial = b.crank.mass + pin_mass
    wn = bandwidth_steps / timestep
    return MjcfSettings(
        timestep=timestep,
        closure_timeconst=2.0 * timestep,
        closure_impedance=0.9999,
        servo_kp=(inertia_angle * wn**2, mass_axial * wn**2),
        servo_kv=(2.0 * inertia_angle * wn, 2.0 * mass_axial * wn),
    )


def _about_axis_z(body: BodyInertia) -> float:
    """Moment of inertia about the body frame's z axis through its origin (parallel axes)."""
    c = body.com
    return float(body.inertia[2, 2] + body.mass * (c[0] ** 2 + c[1] ** 2))


def slider_axis(case: Case) -> np.ndarray:
    """``k4 = (0, sin alpha4, cos alpha4)``, shape (3,) (``docs/conventions.md``)."""
    alpha = case.geometry.slider_twist
    return np.array([0.0, math.sin(alpha), math.cos(alpha)])


def case_to_mjcf(case: Case, settings: MjcfSettings | None = None) -> str:
    """MJCF text of ``case``: bodies, joints, the loop-closing connect, servos, loads.

    Parameters
    ----------
    case : Case
        Geometry, bodies (mass properties in the body frames of
        ``docs/conventions.md``) and gravity.  The crank motion and the given
        load are not written: drivers set the actuator controls.
    settings : MjcfSettings, optional
        Time step, closure softness and servo gains; default
        :func:`default_settings`.

    Returns
    -------
    str
        A complete ``<mujoco>`` document (UTF-8 text, lengths in the case's unit).
    """
    s = default_settings(case) if settings is None else settings
    g = case.geometry
    a1, a2, a4 = g.crank_length, g.rod_length, g.slider_offset
    k4 = slider_axis(case)
    raw_bodies = case.raw.get("bodies", {})
    r_crank = float(raw_bodies.get("crank_radius", 0.05 * a1))
    r_rod = float(raw_bodies.get("rod_radius", 0.02 * a2))
    side = float(raw_bodies.get("slider_side", 0.1 * a2))

    root = ET.Element("mujoco", model=_xml_text(f"dualmech {case.name}"))
    ET.SubElement(root, "compiler", angle="radian", inertiafromgeom="false", autolimits="true")
    ET.SubElement(
        root, "option",
        timestep=_num(s.timestep), gravity=_vec(case.loads.gravity), integrator=s.integrator,
    )
    default = ET.SubElement(root, "default")
    ET.SubElement(default, "geom", contype="0", conaffinity="0", group="1")

    world = ET.SubElement(root, "worldbody")
    ground = ET.SubElement(world, "body", name="ground", pos="0 0 0")
    ET.SubElement(ground, "geom", name="crank_axis", type="cylinder", size=f"{_num(0.3 * r_crank)} {_num(0.5 * a1)}",
                  rgba="0.5 0.5 0.5 0.4")
    ET.SubElement(ground, "geom", name="slider_line", type="capsule", size=_num(0.2 * r_rod),
                  fromto=_vec(np.array([-a4, 0, 0]) + 0.6 * a2 * k4) + " " + _vec(np.array([-a4, 0, 0]) - 1.6 * a2 * k4),
                  rgba="0.5 0.5 0.5 0.4")

    crank = ET.SubElement(ground, "body", name="crank", pos="0 0 0")
    ET.SubElement(crank, "joint", name="crank_angle", type="hinge", pos="0 0 0", axis="0 0 1")
    ET.SubElement(crank, "joint", name="crank_axial", type="slide", pos="0 0 0", axis="0 0 1")
    _inertial(crank, case.bodies.crank)
    ET.SubElement(crank, "geom", name="crank", type="capsule", size=_num(r_crank),
                  fromto=f"0 0 0 {_num(a1)} 0 0", rgba="0.8 0.3 0.2 1")

    rod = ET.SubElement(crank, "body", name="rod", pos=f"{_num(a1)} 0 0")
    ET.SubElement(rod, "joint", name="rod_ball", type="ball", pos="0 0 0")
    _inertial(rod, case.bodies.rod)
    ET.SubElement(rod, "geom", name="rod", type="capsule", size=_num(r_rod),
                  fromto=f"0 0 0 {_num(a2)} 0 0", rgba="0.2 0.5 0.8 1")
    ET.SubElement(rod, "site", name="rod_end", pos=f"{_num(a2)} 0 0", size=_num(1.2 * r_rod))

    slider = ET.SubElement(ground, "body", name="slider", pos=f"{_num(-a4)} 0 0")
    ET.SubElement(slider, "joint", name="slider_stroke", type="slide", pos="0 0 0", axis=_vec(-k4))
    _inertial(slider, case.bodies.slider)
    ET.SubElement(slider, "geom", name="slider", type="box", size=_vec(np.full(3, 0.5 * side)),
                  rgba="0.3 0.7 0.3 1")
    ET.SubElement(slider, "site", name="slider_pin", pos="0 0 0", size=_num(1.2 * r_rod))

    equality = ET.SubElement(root, "equality")
    ET.SubElement(
        equality, "connect", name=CONNECT_NAME, site1="slider_pin", site2="rod_end",
        solref=f"{_num(s.closure_timeconst)} 1",
        solimp=f"{_num(s.closure_impedance)} {_num(s.closure_impedance)} 0.001 0.5 2",
    )

    actuator = ET.SubElement(root, "actuator")
    for name, joint, kp, kv in zip(ACTUATOR_NAMES[:2], JOINT_NAMES[:2], s.servo_kp, s.servo_kv):
        ET.SubElement(
            actuator, "general", name=name, joint=joint, gaintype="fixed", gainprm=_num(kp),
            biastype="affine", biasprm=f"0 {_num(-kp)} {_num(-kv)}",
        )
    ET.SubElement(actuator, "motor", name="slider_load", joint="slider_stroke", gear="-1")

    ET.indent(root)
    header = "<!-- generated by dualmech (models/mjcf.py); frames and signs: docs/conventions.md -->\n"
    return header + ET.tostring(root, encoding="unicode") + "\n"


def _inertial(parent: ET.Element, body: BodyInertia) -> None:
    """``<inertial>`` in the body frame: centre of mass and the full central inertia tensor."""
    i = body.inertia
    off = (i[0, 1], i[0, 2], i[1, 2])
    attrs = {"pos": _vec(body.com), "mass": _num(body.mass)}
    if any(v != 0.0 for v in off):
        # MuJoCo order: M11 M22 M33 M12 M13 M23; the compiler diagonalizes it.
        attrs["fullinertia"] = " ".join(_num(v) for v in (i[0, 0], i[1, 1], i[2, 2], *off))
    else:
        attrs["diaginertia"] = _vec(np.diag(i))
    ET.SubElement(parent, "inertial", attrs)


def _num(x: float) -> str:
    """Shortest text that reads back as the same double."""
    return repr(float(x))


def _vec(v: np.ndarray) -> str:
    return " ".join(_num(x) for x in np.asarray(v, dtype=float).reshape(-1))


_XML_INVALID = re.compile("[^\u0009\u000a\u000d\u0020-\ud7ff\ue000-\ufffd\U00010000-\U0010ffff]")


def _xml_text(text: str) -> str:
    """User text made storable in XML 1.0 (ElementTree escapes ``& < > "``; this drops control characters)."""
    return _XML_INVALID.sub("?", text)
