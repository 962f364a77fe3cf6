"""The MuJoCo model (MJCF) of a case: ball and cylindrical joints, the loop closed by a connect.

One case file builds the in-house model, the Pinocchio model and this MJCF, so
every mass property comes from ``case.bodies`` (``docs/conventions.md``,
"Body frames"); nothing is recomputed here.  The text is plain MJCF that
MuJoCo compiles and that Pinocchio's MJCF parser imports; this module does not
import MuJoCo (engines stay at the edge, ``validation/``).

Kinematic tree (one root body under ``<worldbody>``, as Pinocchio's parser wants)::

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
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np

from dualmech.core.inertia import BodyInertia
from dualmech.models.case import Case
from dualmech.models.units import unit_system

#: Names used in the MJCF; the MuJoCo engines look elements up by these.
BODY_NAMES = ("ground", "crank", "rod", "slider")
JOINT_NAMES = ("crank_angle", "crank_axial", "rod_ball", "slider_stroke")
SITE_NAMES = ("rod_end", "slider_pin")
ACTUATOR_NAMES = ("crank_angle_servo", "crank_axial_servo", "slider_load")
CONNECT_NAME = "joint3"


#: Default simulation time step: this many steps per degree of the fastest prescribed phase ...
STEPS_PER_DEGREE = 128
#: ... and never longer than this (seconds; also the step when the crank is at rest).
MAX_TIMESTEP = 1e-4
#: Servo natural frequency (for the crank's own inertia) times the time step.
SERVO_BANDWIDTH = 0.5
#: Damping ratio of the connect's solref (2: see validation/mujoco_sim.py on implicitfast).
CLOSURE_DAMPRATIO = 2.0


@dataclass(frozen=True)
class MjcfSettings:
    """Simulation settings written into the MJCF (the rigid path ignores all of them).

    Attributes
    ----------
    timestep : float
        ``<option timestep>``, seconds.
    closure_solref : tuple[float, float]
        ``solref`` of the connect: time constant (s; MuJoCo raises it to
        ``2*timestep`` unless the ``refsafe`` flag is disabled) and damping ratio.
    closure_solimp : tuple[float, float, float, float, float]
        ``solimp`` of the connect: dmin, dmax (in (0, 1); MuJoCo's ceiling is
        0.9999), width, midpoint, power.
    servo_kp : tuple[float, float]
        Position gains of the crank-angle (F·L/rad) and crank-axial (F/L) servos.
    servo_kv : tuple[float, float]
        Velocity gains of the same servos (F·L·s/rad, F·s/L).
    integrator : str
        ``"implicitfast"`` integrates the servos' velocity gains implicitly, so
        heavy damping never limits the step.
    """

    timestep: float
    closure_solref: tuple[float, float]
    closure_solimp: tuple[float, float, float, float, float]
    servo_kp: tuple[float, float]
    servo_kv: tuple[float, float]
    integrator: str = "implicitfast"


def default_timestep(case: Case, steps_per_degree: int = STEPS_PER_DEGREE) -> float:
    """Seconds per step: one degree of the fastest prescribed phase / ``steps_per_degree``.

    At most :data:`MAX_TIMESTEP`.

    The phases are the crank angle (speed :math:`|\\dot\\theta_1|`, or the time to
    turn one degree from rest under :math:`\\ddot\\theta_1`) and the axial motion
    :math:`\\alpha\\theta_1` of thesis eq. (27) (``axial_cycles`` times faster).
    """
    mo = case.motion
    one = math.radians(1.0)
    cycles = max(1.0, abs(mo.axial_cycles)) if mo.axial_amplitude != 0.0 else 1.0
    times = [MAX_TIMESTEP * steps_per_degree]
    if mo.speed != 0.0:
        times.append(one / (abs(mo.speed) * cycles))
    if mo.accel != 0.0:
        times.append(math.sqrt(2.0 * one / (abs(mo.accel) * cycles)))
    return min(times) / steps_per_degree


def default_settings(case: Case, timestep: float | None = None, bandwidth_steps: float = SERVO_BANDWIDTH,
                     inertia_high: tuple[float, float] | None = None) -> MjcfSettings:
    """Settings that keep a simulation of ``case`` stiff and stable at ``timestep``.

    Servo stiffness: ``kp = I_low ω_n²`` with :math:`\\omega_n = \\text{bandwidth\\_steps}/\\Delta t`
    and ``I_low`` the crank's own inertia about its axis (its mass, for the axial
    servo): a lower bound of what the servo sees, so the explicit stiffness stays
    stable (``ω Δt <= bandwidth_steps``) in every configuration; the tracking lag
    ``τ/kp`` shrinks like ``Δt²``.  Servo damping: ``kv = 2 sqrt(kp I_high)``,
    critical or more for any effective inertia up to ``inertia_high`` (angle,
    axial; default: crank plus rod and slider masses at the crank pin, times 2);
    ``implicitfast`` integrates it implicitly, so it never limits the step.  The
    connect is as stiff as MuJoCo allows: time constant ``2 Δt``, damping ratio
    :data:`CLOSURE_DAMPRATIO`, impedance 0.9999.  ``timestep`` defaults to
    :func:`default_timestep`.
    """
    dt = default_timestep(case) if timestep is None else timestep
    if not (math.isfinite(dt) and dt > 0):
        raise ValueError(f"timestep: expected a positive number of seconds, got {timestep!r}")
    if not (math.isfinite(bandwidth_steps) and bandwidth_steps > 0):
        raise ValueError(f"bandwidth_steps: expected a positive number, got {bandwidth_steps!r}")
    low = _inertia_low(case)
    if inertia_high is None:
        inertia_high = _inertia_high(case)
    high = tuple(max(h, lo) for h, lo in zip(inertia_high, low))
    wn = bandwidth_steps / dt
    kp = tuple(lo * wn**2 for lo in low)
    return MjcfSettings(
        timestep=dt,
        closure_solref=(2.0 * dt, CLOSURE_DAMPRATIO),
        closure_solimp=(0.9999, 0.9999, 0.001, 0.5, 2.0),
        servo_kp=kp,
        servo_kv=tuple(2.0 * math.sqrt(k * h) for k, h in zip(kp, high)),
    )


def _inertia_low(case: Case) -> tuple[float, float]:
    """What the crank joints move at the least: the crank's own inertia about z, its mass."""
    crank = case.bodies.crank
    return _about_axis_z(crank), crank.mass


def _inertia_high(case: Case) -> tuple[float, float]:
    """A generous bound of what the crank joints move: crank, rod and slider masses at the pin, times 2."""
    b = case.bodies
    low = _inertia_low(case)
    pin_mass = b.rod.mass + b.slider.mass
    return 2.0 * (low[0] + pin_mass * case.geometry.crank_length**2), 2.0 * (low[1] + pin_mass)


def _about_axis_z(body: BodyInertia) -> float:
    """Moment of inertia about the body frame's z axis through its origin (parallel axes)."""
    c = body.com
    return float(body.inertia[2, 2] + body.mass * (c[0] ** 2 + c[1] ** 2))


def slider_axis(case: Case) -> np.ndarray:
    """``k4 = (0, sin alpha4, cos alpha4)``, shape (3,) (``docs/conventions.md``)."""
    alpha = case.geometry.slider_twist
    return np.array([0.0, math.sin(alpha), math.cos(alpha)])


def case_to_mjcf(case: Case, settings: MjcfSettings | None = None) -> str:
    """MJCF text of ``case`` for the judges: bodies, joints, the loop-closing connect, servos, loads.

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
        A complete ``<mujoco>`` document (UTF-8 text, lengths in the case's
        unit).  At ``qpos = 0`` the body frames are those of the module
        docstring and the loop is open; :func:`runnable_mjcf` writes the model
        a user runs.
    """
    root = _document(case, default_settings(case) if settings is None else settings, None)
    header = "<!-- generated by dualmech (models/mjcf.py); frames and signs: docs/conventions.md -->\n"
    return header + ET.tostring(root, encoding="unicode") + "\n"


#: Time constant of the exported crank-speed servo, in time steps, for the bound of the crank's inertia
#: (``implicitfast`` integrates its damping implicitly, so it is stable at any gain).
SPEED_SERVO_STEPS = 1e-2
#: Name of the exported keyframe: the assembled state, turning at the case's speed.
KEY_NAME = "turning"
#: Actuators and sensors of the exported model (:func:`runnable_mjcf`).
EXPORT_ACTUATOR_NAMES = ("crank_speed", "crank_axial_servo", "slider_load")
EXPORT_SENSOR_NAMES = ("loop_gap", "theta1_dot")


@dataclass(frozen=True)
class MjcfStart:
    """An assembled, moving state for :func:`runnable_mjcf`, in the coordinates of :func:`case_to_mjcf`.

    Attributes
    ----------
    qpos : numpy.ndarray, shape (7,)
        ``[theta1 (rad), S1, quat_rod (w, x, y, z), S4]``, the loop closed
        (the rod quaternion turns the crank axes onto the rod's).
    qvel : numpy.ndarray, shape (6,)
        ``[theta1_dot (rad/s), S1_dot, omega_rod (3, rod axes, rad/s), S4_dot]``, the loop's rates closed.
    slider_load : float
        ``ctrl`` of the ``slider_load`` motor: the slider load of ``docs/conventions.md`` (force unit).
    """

    qpos: np.ndarray
    qvel: np.ndarray
    slider_load: float

    def __post_init__(self) -> None:
        for key, n in (("qpos", 7), ("qvel", 6)):
            v = np.asarray(getattr(self, key), dtype=float)
            if v.shape != (n,) or not np.all(np.isfinite(v)):
                raise ValueError(f"start.{key}: expected {n} finite numbers, got {getattr(self, key)!r}")
        if not math.isfinite(self.slider_load):
            raise ValueError(f"start.slider_load: expected a finite force, got {self.slider_load!r}")


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
    s = default_settings(case, timestep)
    root = _document(case, s, start)
    return _export_header(case, start, s, file_name, notes) + ET.tostring(root, encoding="unicode") + "\n"


def _export_header(case: Case, start: MjcfStart, s: MjcfSettings, file_name: str,
                   notes: tuple[str, ...]) -> str:
    """The comment block of :func:`runnable_mjcf` (no ``--`` inside: XML forbids it in comments)."""
    u = unit_system(case.units)
    units = (f'"{case.units}": length {u.length}, force {u.force}, time {u.time}, mass {u.mass}' if u.length
             else "unstated (one consistent system, as in the case file)")
    q, v = start.qpos, start.qvel
    rpm = case.motion.speed * 60.0 / (2.0 * math.pi)
    load = ("the case's slider load" if case.loads.mode == "force"
            else "0: the case gives the drive torque; the speed servo supplies the torque")
    lines = [
        f"dualmech MuJoCo model of the generalized slider crank, case {case.name!r}",
        "(written by dualmech mjcf, models/mjcf.py; frames and signs: dualmech docs/conventions.md).",
        f"Units: the case's, {units}; angles in rad. Nothing is converted.",
        "",
        "Run it:",
        f"  python -c \"import mujoco.viewer; mujoco.viewer.launch_from_path('{file_name}')\"",
        "  (what python -m mujoco.viewer with its mjcf option does),",
        "  then Simulation > Load key: the crank turns.",
        f"  m = mujoco.MjModel.from_xml_path('{file_name}'); d = mujoco.MjData(m)",
        f"  mujoco.mj_resetDataKeyframe(m, d, m.key('{KEY_NAME}').id); mujoco.mj_step(m, d, nstep=1000)",
        "",
        "Bodies and joints (kinematic tree under the fixed, massless body ground):",
        "  crank   hinge crank_angle (theta1, about +z) and slide crank_axial (S1, along +z), joint 1",
        "  rod     ball rod_ball at the crank pin P2 = (a1, 0, 0) of the crank, joint 2; its",
        "          quaternion is the rod's rotation from its orientation in the default pose",
        "  slider  slide slider_stroke (S4, along -k4, k4 = (0, sin alpha4, cos alpha4)), joint 4",
        "Equality: connect joint3 holds site rod_end (rod, a2 along its x) on site slider_pin",
        f"  (slider origin): joint 3, the loop cut; soft (solref {_vec(s.closure_solref)},",
        f"  solimp {_vec(s.closure_solimp)}).",
        "",
        f"Default pose (qpos0) and keyframe {KEY_NAME!r}: the loop closed at",
        f"  theta1 = {math.degrees(q[0]):.6g} deg, S1 = {q[1]:.6g}, S4 = {q[6]:.6g};",
        "  qpos0 at rest with ctrl 0",
        f"  (the speed servo holds the crank still), {KEY_NAME!r} with the loop's rates and the ctrl below.",
        "Actuators (ctrl in the keyframe):",
        "  crank_speed        velocity servo on crank_angle: ctrl = theta1_dot, rad/s",
        f"                     ({v[0]:.6g} = {rpm:.6g} rpm)",
        "  crank_axial_servo  position servo on crank_axial: ctrl = S1",
        f"                     ({q[1]:.6g}; held: an axial law of the case is not driven)",
        "  slider_load        motor on slider_stroke: ctrl = k4 . (force of the ground on the slider)",
        f"                     ({load})",
        "Sensors: loop_gap = rod_end - slider_pin in slider axes (the loop's opening); theta1_dot (rad/s).",
        f"Time step {s.timestep:.3g} s, integrator {s.integrator}.",
        *notes,
    ]
    body = "".join(f"  {line}\n".replace("--", "- -") if line else "\n" for line in lines)
    return "<!--\n" + body + "-->\n"


def _quat_z(angle: float) -> np.ndarray:
    """Unit quaternion (w, x, y, z) of a rotation by ``angle`` (rad) about +z."""
    return np.array([math.cos(0.5 * angle), 0.0, 0.0, math.sin(0.5 * angle)])


def _document(case: Case, s: MjcfSettings, start: MjcfStart | None) -> ET.Element:
    """The ``<mujoco>`` tree: :func:`case_to_mjcf` without ``start``, :func:`runnable_mjcf` with it."""
    g = case.geometry
    a1, a2, a4 = g.crank_length, g.rod_length, g.slider_offset
    k4 = slider_axis(case)
    raw_bodies = case.raw.get("bodies", {})
    r_crank = float(raw_bodies.get("crank_radius", 0.05 * a1))
    r_rod = float(raw_bodies.get("rod_radius", 0.02 * a2))
    side = float(raw_bodies.get("slider_side", 0.1 * a2))
    foot = np.array([-a4, 0.0, 0.0])
    # placements: the judges' model at qpos = 0; the export's at the start pose, joints referred to it
    crank_at, crank_ref, rod_at = {"pos": "0 0 0"}, ({}, {}), {}
    slider_at, slider_ref = {"pos": f"{_num(-a4)} 0 0"}, {}
    if start is not None:
        q = np.asarray(start.qpos, dtype=float)
        crank_at = {"pos": _vec([0.0, 0.0, q[1]]), "quat": _vec(_quat_z(q[0]))}
        crank_ref = ({"ref": _num(q[0])}, {"ref": _num(q[1])})
        rod_at = {"quat": _vec(q[2:6])}
        slider_at, slider_ref = {"pos": _vec(foot - q[6] * k4)}, {"ref": _num(q[6])}

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
    # massless, fixed; Pinocchio's parser wants an inertia on every body (inertiafromgeom is off)
    ET.SubElement(ground, "inertial", pos="0 0 0", mass="0", diaginertia="0 0 0")
    ET.SubElement(ground, "geom", name="crank_axis", type="cylinder",
                  size=f"{_num(0.3 * r_crank)} {_num(0.5 * a1)}", rgba="0.5 0.5 0.5 0.4")
    ET.SubElement(ground, "geom", name="slider_line", type="capsule", size=_num(0.2 * r_rod),
                  fromto=_vec(np.concatenate([foot + 0.6 * a2 * k4, foot - 1.6 * a2 * k4])),
                  rgba="0.5 0.5 0.5 0.4")

    crank = ET.SubElement(ground, "body", name="crank", **crank_at)
    ET.SubElement(crank, "joint", name="crank_angle", type="hinge", pos="0 0 0", axis="0 0 1", **crank_ref[0])
    ET.SubElement(crank, "joint", name="crank_axial", type="slide", pos="0 0 0", axis="0 0 1", **crank_ref[1])
    _inertial(crank, case.bodies.crank, "crank")
    ET.SubElement(crank, "geom", name="crank", type="capsule", size=_num(r_crank),
                  fromto=f"0 0 0 {_num(a1)} 0 0", rgba="0.8 0.3 0.2 1")

    rod = ET.SubElement(crank, "body", name="rod", pos=f"{_num(a1)} 0 0", **rod_at)
    ET.SubElement(rod, "joint", name="rod_ball", type="ball", pos="0 0 0")
    _inertial(rod, case.bodies.rod, "rod")
    ET.SubElement(rod, "geom", name="rod", type="capsule", size=_num(r_rod),
                  fromto=f"0 0 0 {_num(a2)} 0 0", rgba="0.2 0.5 0.8 1")
    ET.SubElement(rod, "site", name="rod_end", pos=f"{_num(a2)} 0 0", size=_num(1.2 * r_rod))

    slider = ET.SubElement(ground, "body", name="slider", **slider_at)
    ET.SubElement(slider, "joint", name="slider_stroke", type="slide", pos="0 0 0", axis=_vec(-k4),
                  **slider_ref)
    _inertial(slider, case.bodies.slider, "slider")
    ET.SubElement(slider, "geom", name="slider", type="box", size=_vec(np.full(3, 0.5 * side)),
                  rgba="0.3 0.7 0.3 1")
    ET.SubElement(slider, "site", name="slider_pin", pos="0 0 0", size=_num(1.2 * r_rod))

    equality = ET.SubElement(root, "equality")
    ET.SubElement(
        equality, "connect", name=CONNECT_NAME, site1="slider_pin", site2="rod_end",
        solref=_vec(s.closure_solref), solimp=_vec(s.closure_solimp),
    )
    _actuators(ET.SubElement(root, "actuator"), case, s, start)
    if start is not None:
        sensor = ET.SubElement(root, "sensor")
        ET.SubElement(sensor, "framepos", name="loop_gap", objtype="site", objname="rod_end",
                      reftype="site", refname="slider_pin")
        ET.SubElement(sensor, "jointvel", name="theta1_dot", joint="crank_angle")
        q = np.asarray(start.qpos, dtype=float)
        ET.SubElement(ET.SubElement(root, "keyframe"), "key", name=KEY_NAME,
                      qpos=_vec([q[0], q[1], 1.0, 0.0, 0.0, 0.0, q[6]]), qvel=_vec(start.qvel),
                      ctrl=_vec([start.qvel[0], q[1], start.slider_load]))
    ET.indent(root)
    return root


def _actuators(actuator: ET.Element, case: Case, s: MjcfSettings, start: MjcfStart | None) -> None:
    """Crank-angle (judges) or crank-speed (export) servo, crank-axial servo, slider-load motor."""
    servos = list(zip(ACTUATOR_NAMES[:2], JOINT_NAMES[:2], s.servo_kp, s.servo_kv))
    if start is not None:
        w = abs(float(start.qvel[0]))
        kv = _inertia_high(case)[0] / (SPEED_SERVO_STEPS * s.timestep)
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


#: MuJoCo's mjMINVAL: it refuses a moving body whose mass or a principal moment is below this.
MJ_MINVAL = 1e-15


def _inertial(parent: ET.Element, body: BodyInertia, name: str) -> None:
    """``<inertial>`` in the body frame: centre of mass and the full central inertia tensor.

    Raises
    ------
    ValueError
        A principal moment MuJoCo cannot take (point masses, thin rods: MuJoCo
        needs every principal moment of a moving body above ``MJ_MINVAL``).
    """
    i = body.inertia
    low = float(np.linalg.eigvalsh(i).min())
    if low < MJ_MINVAL:
        hint = (" (the rod's axial moment does not enter the dynamics under the zero-spin gauge:"
                " a tiny positive value such as 1e-9 * I_t is harmless)" if name == "rod" else "")
        raise ValueError(
            f"bodies.{name}.inertia: principal moments {np.linalg.eigvalsh(i).tolist()}; MuJoCo needs every "
            f"principal moment of a moving body > {MJ_MINVAL:g}{hint}"
        )
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
