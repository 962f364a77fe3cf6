"""The MuJoCo model (MJCF) of a case: its joints as ``case.joints`` says, the loop closed by a connect.

One case file builds the in-house model, the Pinocchio model and this MJCF, so
every mass property comes from ``case.bodies`` (``docs/conventions.md``,
"Body frames"); nothing is recomputed here.  The text is plain MJCF that
MuJoCo compiles and that Pinocchio's MJCF parser imports; this module does not
import MuJoCo (engines stay at the edge, ``validation/``).

Kinematic tree of the default joints (one root body under ``<worldbody>``, as Pinocchio's parser wants)::

    world
     └─ ground            fixed (no joint), massless: the single root of both branches
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

**Joint variants** (``case.joints``, issue 15):

* ``crank = "revolute"``: the crank body sits at ``(0, 0, S1)`` (``crank_axial_shift``) with the hinge
  only; no slide, no axial servo.  ``qpos = [theta1, ...]``.
* ``rod_slider = "universal"``: a universal joint is two hinges in one body, so the rod hangs from the
  slider and the loop is cut at the ball P2 instead::

        ├─ crank      hinge(s) as above; site "crank_pin" at (a1, 0, 0)
        └─ slider     slide "slider_stroke"; site "slider_pin"
            └─ rod    hinge "rod_k4" (axis k4, the slider side) then hinge "rod_cross" (rod y axis, the
                      rod side a_r), both at P3 = (a2, 0, 0) of the rod frame; sites "rod_end" (P3),
                      "rod_start" (P2, the rod origin)
        equality: connect "joint2" site1="rod_start" site2="crank_pin"   (joint 2, the loop cut)

  The rod frame is the conventions' (origin P2, x = u) with y = a_r = u x k4 / |u x k4|: MuJoCo applies a
  body's joints in order, so the second hinge's axis turns with the first and stays normal to k4.  At
  ``qpos = 0`` the rod points along ``u0 = (x - k4)/sqrt 2`` (:func:`universal_start_axes`).
  ``qpos = [theta1, (S1,) S4, q_k4, q_cross]``.

Actuators, connect softness and time step serve simulation (:class:`MjcfSettings`);
the rigid path ignores them:

* ``crank_angle_servo``, ``crank_axial_servo``: ``<general>`` servos with
  ``biastype="affine"`` (MuJoCo ignores ``biasprm`` otherwise), force
  :math:`k_p\\,\\mathrm{ctrl} - k_p q - k_v \\dot q`.  With
  :math:`\\mathrm{ctrl} = q_\\mathrm{ref} + (k_v/k_p)\\dot q_\\mathrm{ref}` this is
  the PD law :math:`k_p (q_\\mathrm{ref} - q) + k_v(\\dot q_\\mathrm{ref} - \\dot q)`.
* ``slider_load``: a motor on ``slider_stroke`` with ``gear = -1``; the joint
  axis is ``-k4``, so ``ctrl`` is the slider load ``k4 · (force of the ground on
  the slider)`` of the conventions.

Settings are :mod:`dualmech.models.mjcf_settings`, the export's extras :mod:`dualmech.models.mjcf_export`
(both re-exported here).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np

from dualmech.models.case import Case
from dualmech.models.mechanism import Joints
from dualmech.models.mjcf_export import (  # noqa: F401  (re-exported: the export's names live with the model)
    EXPORT_ACTUATOR_NAMES,
    EXPORT_SENSOR_NAMES,
    KEY_NAME,
    SPEED_SERVO_STEPS,
    MjcfStart,
    export_header,
    xml_text,
)
from dualmech.models.mjcf_settings import (  # noqa: F401  (re-exported: engines read the settings here)
    CLOSURE_DAMPRATIO,
    MAX_TIMESTEP,
    SERVO_BANDWIDTH,
    STEPS_PER_DEGREE,
    MjcfSettings,
    default_settings,
    default_timestep,
    inertia_bound,
    inertial,
    simulation_steps,
)
from dualmech.models.mjcf_settings import num as _num
from dualmech.models.mjcf_settings import vec as _vec

#: Names used in the MJCF of the default joints; the MuJoCo engines look elements up by these.
BODY_NAMES = ("ground", "crank", "rod", "slider")
JOINT_NAMES = ("crank_angle", "crank_axial", "rod_ball", "slider_stroke")
SITE_NAMES = ("rod_end", "slider_pin")
ACTUATOR_NAMES = ("crank_angle_servo", "crank_axial_servo", "slider_load")
CONNECT_NAME = "joint3"
#: The universal joint's two hinges (slider side first), its extra sites and the connect at the ball P2.
UNIVERSAL_JOINT_NAMES = ("rod_k4", "rod_cross")
UNIVERSAL_SITE_NAMES = ("rod_start", "crank_pin")
UNIVERSAL_CONNECT_NAME = "joint2"


def slider_axis(case: Case) -> np.ndarray:
    """``k4 = (0, sin alpha4, cos alpha4)``, shape (3,) (``docs/conventions.md``)."""
    alpha = case.geometry.slider_twist
    return np.array([0.0, math.sin(alpha), math.cos(alpha)])


def universal_start_axes(k4: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The rod's x and y axes (world, (3,) each) at ``qpos = 0`` of the universal-joint model.

    ``u0 = (x - k4)/sqrt 2`` (45 degrees from the slider axis, on the conventions' branch side
    ``u0·k4 < 0``, toward the crank axis) and ``a_r0 = u0 x k4 / |u0 x k4| = x x k4`` (``x`` is normal
    to ``k4`` for every twist).
    """
    x = np.array([1.0, 0.0, 0.0])
    return (x - k4) / math.sqrt(2.0), np.cross(x, k4)


def joint_names(joints: Joints) -> tuple[str, ...]:
    """The MJCF's joint names in ``qpos`` order for ``joints``."""
    crank = JOINT_NAMES[:2] if joints.crank == "cylindrical" else JOINT_NAMES[:1]
    if joints.universal:
        return (*crank, JOINT_NAMES[3], *UNIVERSAL_JOINT_NAMES)
    return (*crank, *JOINT_NAMES[2:])


def case_to_mjcf(case: Case, settings: MjcfSettings | None = None) -> str:
    """MJCF text of ``case`` for the judges: bodies, joints, the loop-closing connect, servos, loads.

    Parameters
    ----------
    case : Case
        Geometry, joints, bodies (mass properties in the body frames of
        ``docs/conventions.md``) and gravity.  The crank motion and the given
        load are not written: drivers set the actuator controls.
    settings : MjcfSettings, optional
        Time step, closure softness and servo gains; default
        :func:`default_settings`.

    Returns
    -------
    str
        A complete ``<mujoco>`` document (UTF-8 text, lengths in the case's
        unit).  At ``qpos = 0`` the body frames are those of the module
        docstring and the loop is open; :func:`runnable_mjcf` writes the model
        a user runs.
    """
    root = _document(case, default_settings(case) if settings is None else settings, None)
    header = "<!-- generated by dualmech (models/mjcf.py); frames and signs: docs/conventions.md -->\n"
    return header + ET.tostring(root, encoding="unicode") + "\n"


def runnable_mjcf(case: Case, start: MjcfStart, timestep: float, file_name: str = "model.xml",
                  notes: tuple[str, ...] = ()) -> str:
    """The MJCF a user runs as written: assembled, the crank turning at the case's speed, documented.

    The bodies, joints, connect and mass properties are those of :func:`case_to_mjcf`; what differs:

    * **Default pose assembled.** The body frames are written at ``start.qpos``
      and the hinge and slides carry ``ref`` = their start value, so
      ``qpos0 = [theta1, S1, 1, 0, 0, 0, S4]``: ``theta1``, ``S1`` and ``S4``
      read as in :func:`case_to_mjcf`, the rod's ball quaternion is its
      rotation from its start orientation.
    * **Keyframe** :data:`KEY_NAME`: ``qpos0``, ``qvel = start.qvel`` and
      ``ctrl = [theta1_dot, S1, slider_load]``.
    * **Crank-speed servo** ``crank_speed`` (``<velocity>``, ``ctrl`` in
      rad/s) instead of the crank-angle servo, with
      :math:`k_v = I_\\mathrm{high} / (\\text{SPEED\\_SERVO\\_STEPS}\\,\\Delta t)`;
      the axial servo holds ``S1`` at ``ctrl`` (an axial law of thesis
      eq. (27) and ``crank_accel`` need a controller: not driven).
    * **Sensors** ``loop_gap`` (``rod_end`` in ``slider_pin``'s axes: the
      connect's violation, length) and ``theta1_dot`` (rad/s).
    * A comment block saying what the file is, its units and how to run it.

    Only the default joints are exported (a variant's model is the judges' :func:`case_to_mjcf`).

    Parameters
    ----------
    case : Case
        The case.
    start : MjcfStart
        The assembled state (found by the caller: this module does not close the loop).
    timestep : float
        ``<option timestep>``, seconds (the caller chooses it for the loop gap it accepts).
    file_name : str
        The name the comment block uses in its commands.
    notes : tuple[str, ...]
        Lines added to the comment block (e.g. what the caller measured).

    Returns
    -------
    str
        A complete ``<mujoco>`` document.
    """
    check_exportable(case)
    s = default_settings(case, timestep)
    root = _document(case, s, start)
    return export_header(case, start, s, file_name, notes) + ET.tostring(root, encoding="unicode") + "\n"


def check_exportable(case: Case) -> None:
    """A one-line ``ValueError`` unless :func:`runnable_mjcf` can write ``case`` (default joints only)."""
    if not case.joints.is_default:
        j = case.joints
        raise ValueError(f"joints: crank = {j.crank!r}, rod_slider = {j.rod_slider!r} cannot be exported yet "
                         "(valid: the default cylindrical crank and ball-ball rod)")


def _quat_z(angle: float) -> np.ndarray:
    """Unit quaternion (w, x, y, z) of a rotation by ``angle`` (rad) about +z."""
    return np.array([math.cos(0.5 * angle), 0.0, 0.0, math.sin(0.5 * angle)])


def _placements(case: Case, start: MjcfStart | None) -> dict[str, dict[str, str]]:
    """Body placements and joint ``ref`` attributes: the judges' model at ``qpos = 0``, or the export's at
    ``start`` (joints referred to it)."""
    g = case.geometry
    foot = np.array([-g.slider_offset, 0.0, 0.0])
    at = {"crank": {"pos": "0 0 0"}, "crank_angle": {}, "crank_axial": {}, "rod": {},
          "slider": {"pos": f"{_num(-g.slider_offset)} 0 0"}, "slider_stroke": {}}
    if case.joints.crank == "revolute":
        at["crank"] = {"pos": _vec([0.0, 0.0, g.crank_axial_shift])}
    if start is not None:
        q = np.asarray(start.qpos, dtype=float)
        at["crank"] = {"pos": _vec([0.0, 0.0, q[1]]), "quat": _vec(_quat_z(q[0]))}
        at["crank_angle"], at["crank_axial"] = {"ref": _num(q[0])}, {"ref": _num(q[1])}
        at["rod"] = {"quat": _vec(q[2:6])}
        at["slider"] = {"pos": _vec(foot - q[6] * slider_axis(case))}
        at["slider_stroke"] = {"ref": _num(q[6])}
    return at


def _document(case: Case, s: MjcfSettings, start: MjcfStart | None) -> ET.Element:
    """The ``<mujoco>`` tree: :func:`case_to_mjcf` without ``start``, :func:`runnable_mjcf` with it."""
    at = _placements(case, start)
    root = ET.Element("mujoco", model=xml_text(f"dualmech {case.name}"))
    ET.SubElement(root, "compiler", angle="radian", inertiafromgeom="false", autolimits="true")
    ET.SubElement(
        root, "option",
        timestep=_num(s.timestep), gravity=_vec(case.loads.gravity), integrator=s.integrator,
    )
    default = ET.SubElement(root, "default")
    ET.SubElement(default, "geom", contype="0", conaffinity="0", group="1")
    ground = _ground(ET.SubElement(root, "worldbody"), case)
    crank = _crank(ground, case, at)
    slider = _slider(ground, case, at)
    if case.joints.universal:
        _universal_rod(slider, crank, case)
    else:
        _rod(ET.SubElement(crank, "body", name="rod", pos=f"{_num(case.geometry.crank_length)} 0 0",
                           **at["rod"]), case)
    _equality(ET.SubElement(root, "equality"), case, s)
    _actuators(ET.SubElement(root, "actuator"), case, s, start)
    if start is not None:
        _export_extras(root, start)
    ET.indent(root)
    return root


def _sizes(case: Case) -> tuple[float, float, float]:
    """Drawing sizes: the crank and rod radii and the slider's side (``[bodies]``, or fractions of a1, a2)."""
    g, raw = case.geometry, case.raw.get("bodies", {})
    return (float(raw.get("crank_radius", 0.05 * g.crank_length)),
            float(raw.get("rod_radius", 0.02 * g.rod_length)),
            float(raw.get("slider_side", 0.1 * g.rod_length)))


def _ground(world: ET.Element, case: Case) -> ET.Element:
    """The fixed, massless root body ``ground`` with the drawn crank axis and slider line."""
    g = case.geometry
    r_crank, r_rod, _ = _sizes(case)
    foot, k4 = np.array([-g.slider_offset, 0.0, 0.0]), slider_axis(case)
    ground = ET.SubElement(world, "body", name="ground", pos="0 0 0")
    # massless, fixed; Pinocchio's parser wants an inertia on every body (inertiafromgeom is off)
    ET.SubElement(ground, "inertial", pos="0 0 0", mass="0", diaginertia="0 0 0")
    ET.SubElement(ground, "geom", name="crank_axis", type="cylinder",
                  size=f"{_num(0.3 * r_crank)} {_num(0.5 * g.crank_length)}", rgba="0.5 0.5 0.5 0.4")
    ET.SubElement(ground, "geom", name="slider_line", type="capsule", size=_num(0.2 * r_rod),
                  fromto=_vec(np.concatenate([foot + 0.6 * g.rod_length * k4,
                                              foot - 1.6 * g.rod_length * k4])),
                  rgba="0.5 0.5 0.5 0.4")
    return ground


def _crank(ground: ET.Element, case: Case, at: dict[str, dict[str, str]]) -> ET.Element:
    """The crank: hinge ``crank_angle`` (+ slide ``crank_axial`` unless revolute), its mass, its drawing."""
    a1 = case.geometry.crank_length
    crank = ET.SubElement(ground, "body", name="crank", **at["crank"])
    ET.SubElement(crank, "joint", name="crank_angle", type="hinge", pos="0 0 0", axis="0 0 1",
                  **at["crank_angle"])
    if case.joints.crank == "cylindrical":
        ET.SubElement(crank, "joint", name="crank_axial", type="slide", pos="0 0 0", axis="0 0 1",
                      **at["crank_axial"])
    inertial(crank, case.bodies.crank, "crank")
    ET.SubElement(crank, "geom", name="crank", type="capsule", size=_num(_sizes(case)[0]),
                  fromto=f"0 0 0 {_num(a1)} 0 0", rgba="0.8 0.3 0.2 1")
    return crank


def _rod(rod: ET.Element, case: Case, hinges: tuple[ET.Element, ...] = ()) -> None:
    """Fill the rod body: its joint (a ball at its origin P2 unless ``hinges`` are given), mass, drawing,
    the site ``rod_end`` at P3 = (a2, 0, 0)."""
    a2, r_rod = case.geometry.rod_length, _sizes(case)[1]
    if not hinges:
        ET.SubElement(rod, "joint", name="rod_ball", type="ball", pos="0 0 0")
    rod.extend(hinges)
    inertial(rod, case.bodies.rod, "rod")
    ET.SubElement(rod, "geom", name="rod", type="capsule", size=_num(r_rod),
                  fromto=f"0 0 0 {_num(a2)} 0 0", rgba="0.2 0.5 0.8 1")
    ET.SubElement(rod, "site", name="rod_end", pos=f"{_num(a2)} 0 0", size=_num(1.2 * r_rod))


def _universal_rod(slider: ET.Element, crank: ET.Element, case: Case) -> None:
    """The rod hanging from the slider by a universal joint (two hinges at P3), and the sites of the
    connect at P2 (``rod_start`` on the rod, ``crank_pin`` on the crank)."""
    a1, a2, r_rod = case.geometry.crank_length, case.geometry.rod_length, _sizes(case)[1]
    k4 = slider_axis(case)
    u0, ar0 = universal_start_axes(k4)
    frame = np.column_stack([u0, ar0, np.cross(u0, ar0)])  # rod axes in slider (= world) axes at qpos = 0
    end = f"{_num(a2)} 0 0"
    hinges = (ET.Element("joint", name=UNIVERSAL_JOINT_NAMES[0], type="hinge", pos=end,
                         axis=_vec(frame.T @ k4)),
              ET.Element("joint", name=UNIVERSAL_JOINT_NAMES[1], type="hinge", pos=end, axis="0 1 0"))
    rod = ET.SubElement(slider, "body", name="rod", pos=_vec(-a2 * u0), xyaxes=_vec([u0, ar0]))
    _rod(rod, case, hinges)
    ET.SubElement(rod, "site", name="rod_start", pos="0 0 0", size=_num(1.2 * r_rod))
    ET.SubElement(crank, "site", name="crank_pin", pos=f"{_num(a1)} 0 0", size=_num(1.2 * r_rod))


def _slider(ground: ET.Element, case: Case, at: dict[str, dict[str, str]]) -> ET.Element:
    """The slider: slide ``slider_stroke`` along ``-k4`` (qpos = S4), its mass, the site ``slider_pin``
    at P3."""
    k4, (_, r_rod, side) = slider_axis(case), _sizes(case)
    slider = ET.SubElement(ground, "body", name="slider", **at["slider"])
    ET.SubElement(slider, "joint", name="slider_stroke", type="slide", pos="0 0 0", axis=_vec(-k4),
                  **at["slider_stroke"])
    inertial(slider, case.bodies.slider, "slider")
    ET.SubElement(slider, "geom", name="slider", type="box", size=_vec(np.full(3, 0.5 * side)),
                  rgba="0.3 0.7 0.3 1")
    ET.SubElement(slider, "site", name="slider_pin", pos="0 0 0", size=_num(1.2 * r_rod))
    return slider


def _equality(equality: ET.Element, case: Case, s: MjcfSettings) -> None:
    """The loop cut: a connect at P3 (ball) or, with a universal joint, at the ball P2."""
    if case.joints.universal:
        name, sites = UNIVERSAL_CONNECT_NAME, UNIVERSAL_SITE_NAMES
    else:
        name, sites = CONNECT_NAME, ("slider_pin", "rod_end")
    ET.SubElement(equality, "connect", name=name, site1=sites[0], site2=sites[1],
                  solref=_vec(s.closure_solref), solimp=_vec(s.closure_solimp))


def _export_extras(root: ET.Element, start: MjcfStart) -> None:
    """The exported model's sensors and keyframe (:func:`runnable_mjcf`)."""
    sensor = ET.SubElement(root, "sensor")
    ET.SubElement(sensor, "framepos", name="loop_gap", objtype="site", objname="rod_end",
                  reftype="site", refname="slider_pin")
    ET.SubElement(sensor, "jointvel", name="theta1_dot", joint="crank_angle")
    q = np.asarray(start.qpos, dtype=float)
    ET.SubElement(ET.SubElement(root, "keyframe"), "key", name=KEY_NAME,
                  qpos=_vec([q[0], q[1], 1.0, 0.0, 0.0, 0.0, q[6]]), qvel=_vec(start.qvel),
                  ctrl=_vec([start.qvel[0], q[1], start.slider_load]))


def _actuators(actuator: ET.Element, case: Case, s: MjcfSettings, start: MjcfStart | None) -> None:
    """Crank-angle (judges) or crank-speed (export) servo, crank-axial servo (cylindrical crank),
    slider-load motor."""
    crank_joints = 2 if case.joints.crank == "cylindrical" else 1
    servos = list(zip(ACTUATOR_NAMES[:crank_joints], JOINT_NAMES[:crank_joints], s.servo_kp, s.servo_kv))
    if start is not None:
        w = abs(float(start.qvel[0]))
        kv = inertia_bound(case)[0] / (SPEED_SERVO_STEPS * s.timestep)
        limits = {"ctrlrange": _vec([-2.0 * w, 2.0 * w])} if w > 0.0 else {}
        ET.SubElement(actuator, "velocity", name=EXPORT_ACTUATOR_NAMES[0], joint=JOINT_NAMES[0], kv=_num(kv),
                      **limits)
        servos = servos[1:]
    for name, joint, kp, kv in servos:
        ET.SubElement(
            actuator, "general", name=name, joint=joint, gaintype="fixed", gainprm=_num(kp),
            biastype="affine", biasprm=f"0 {_num(-kp)} {_num(-kv)}",
        )
    ET.SubElement(actuator, "motor", name="slider_load", joint="slider_stroke", gear="-1")
