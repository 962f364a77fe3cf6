"""The MJCF of the RCCC for MuJoCo's simulation: the rigid judge's tree, a driven rotor, a closing weld.

::

    world
     ├─ input_drive   at (0, 0, s1): hinge "joint1" about z (the servo's rotor); site "drive" at its origin
     └─ output_link   the rigid judge's tree (:func:`~dualmech.validation.linkages.mjcf_rssr.rccc_mjcf`):
         └─ coupler       each cylinder a hinge "joint<k>" and a slide "joint<k>_slide" about the same z
             └─ input_link   (the case's input link); site "input": its frame {1}

    equality: weld "joint1" site1="input" site2="drive"
    actuator: "input_servo" on joint1

MuJoCo has no revolute equality, so the input revolute is the weld of the input link's frame to the
rotor, which turns about ``z1`` on its own hinge: the weld carries the whole joint-1 wrench, the drive
torque included.  The rotor's centre is on its axis and its inertia is axisymmetric
(:func:`rotor_inertia` about every axis): its weight goes to its hinge and its inertia only into the
servo's torque, so the weld's wrench on the input link is the rigid joint 1's (``docs/conventions.md``,
"Linkages: engines, bundled cases, the simulated judge").  ``qpos = (theta1, -theta4, -s4, -theta3,
-s3, -theta2, -s2)``.  No MuJoCo import here: the text is plain MJCF, edited as XML.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

from dualmech.models.linkages.rccc_case import RcccCase
from dualmech.validation.linkages.mjcf_rssr import rccc_mjcf

#: The loop's softness: time constant in time steps, damping ratio, ``solimp`` (as stiff as MuJoCo allows:
#: the settings of the RSSR's connect, :func:`~dualmech.validation.linkages.mjcf_rssr.rssr_mjcf`).
SOFT_TIME_STEPS = 2.0
SOFT_DAMPING_RATIO = 2.0
SOFT_IMPEDANCE = "0.9999 0.9999 0.001 0.5 2"


def rotor_inertia(case: RcccCase) -> float:
    """The rotor's moment of inertia (F·L·s², about each of its axes): the input link's own about ``z1``,
    ``I_zz + m (c_x^2 + c_y^2)`` (its body frame has ``z = z1``)."""
    link = case.bodies[0]
    return float(link.inertia[2, 2] + link.mass * (link.com[0] ** 2 + link.com[1] ** 2))


def rccc_sim_mjcf(case: RcccCase, timestep: float, servo: tuple[float, float]) -> str:
    """The MJCF text of ``case`` for simulation (module docstring) at ``timestep`` (s).

    ``servo = (kp, kv)``: the input-angle servo ``input_servo`` (``<general>``, affine bias: force ``kp ctrl
    - kp theta1 - kv theta1_dot``) on the rotor's hinge; the weld as soft as :data:`SOFT_TIME_STEPS`,
    :data:`SOFT_DAMPING_RATIO`, :data:`SOFT_IMPEDANCE` say; the ``implicitfast`` integrator.  The rotor's
    mass is the input link's (immaterial: it stays on the axis).
    """
    root = ET.fromstring(rccc_mjcf(case, timestep))
    root.find("option").set("integrator", "implicitfast")
    inertia = repr(rotor_inertia(case))
    rotor = ET.Element("body", name="input_drive", pos=f"0 0 {case.geometry.s1!r}")
    ET.SubElement(rotor, "joint", name="joint1", type="hinge", axis="0 0 1")
    ET.SubElement(rotor, "inertial", pos="0 0 0", mass=repr(float(case.bodies[0].mass)),
                  diaginertia=f"{inertia} {inertia} {inertia}")
    ET.SubElement(rotor, "site", name="drive")
    root.find("worldbody").insert(0, rotor)  # first: joint1 is dof 0
    ET.SubElement(ET.SubElement(root, "equality"), "weld", name="joint1", site1="input", site2="drive",
                  solref=f"{SOFT_TIME_STEPS * timestep!r} {SOFT_DAMPING_RATIO!r}", solimp=SOFT_IMPEDANCE)
    kp, kv = float(servo[0]), float(servo[1])
    ET.SubElement(ET.SubElement(root, "actuator"), "general", name="input_servo", joint="joint1",
                  gainprm=repr(kp), biastype="affine", biasprm=f"0 {-kp!r} {-kv!r}")
    ET.indent(root)
    return ET.tostring(root, encoding="unicode") + "\n"
