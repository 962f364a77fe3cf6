"""What the exported MJCF (``dualmech mjcf``, :func:`dualmech.models.mjcf.runnable_mjcf`) adds to the judges'
model: its start state, names of its extra actuators, sensors and keyframe, and its comment block.

Split from :mod:`dualmech.models.mjcf` (issue 16); the body tree itself is written there, once.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from dualmech.models.case import Case
from dualmech.models.mjcf_settings import MjcfSettings, vec
from dualmech.models.units import unit_system

#: Time constant of the exported crank-speed servo, in time steps, for the bound of the crank's inertia
#: (``implicitfast`` integrates its damping implicitly, so it is stable at any gain).
SPEED_SERVO_STEPS = 1e-2
#: Name of the exported keyframe: the assembled state, turning at the case's speed.
KEY_NAME = "turning"
#: Actuators and sensors of the exported model (:func:`dualmech.models.mjcf.runnable_mjcf`).
EXPORT_ACTUATOR_NAMES = ("crank_speed", "crank_axial_servo", "slider_load")
EXPORT_SENSOR_NAMES = ("loop_gap", "theta1_dot")


@dataclass(frozen=True)
class MjcfStart:
    """An assembled, moving state for :func:`~dualmech.models.mjcf.runnable_mjcf`, in the coordinates of
    :func:`~dualmech.models.mjcf.case_to_mjcf` (default joints).

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


def export_header(case: Case, start: MjcfStart, s: MjcfSettings, file_name: str,
                  notes: tuple[str, ...]) -> str:
    """The comment block of :func:`~dualmech.models.mjcf.runnable_mjcf`: every line through
    :func:`comment_text` (no ``--`` inside: XML forbids it in comments); the case name and ``file_name``
    quoted by ``repr``, so they read back exactly."""
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
        f"  python -c \"import mujoco.viewer; mujoco.viewer.launch_from_path({file_name!r})\"",
        "  (what python -m mujoco.viewer with its mjcf option does),",
        "  then Simulation > Load key: the crank turns.",
        f"  m = mujoco.MjModel.from_xml_path({file_name!r}); d = mujoco.MjData(m)",
        f"  mujoco.mj_resetDataKeyframe(m, d, m.key('{KEY_NAME}').id); mujoco.mj_step(m, d, nstep=1000)",
        "",
        "Bodies and joints (kinematic tree under the fixed, massless body ground):",
        "  crank   hinge crank_angle (theta1, about +z) and slide crank_axial (S1, along +z), joint 1",
        "  rod     ball rod_ball at the crank pin P2 = (a1, 0, 0) of the crank, joint 2; its",
        "          quaternion is the rod's rotation from its orientation in the default pose",
        "  slider  slide slider_stroke (S4, along -k4, k4 = (0, sin alpha4, cos alpha4)), joint 4",
        "Equality: connect joint3 holds site rod_end (rod, a2 along its x) on site slider_pin",
        f"  (slider origin): joint 3, the loop cut; soft (solref {vec(s.closure_solref)},",
        f"  solimp {vec(s.closure_solimp)}).",
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
    body = "".join(f"  {comment_text(line)}\n" if line else "\n" for line in lines)
    return "<!--\n" + body + "-->\n"


#: Characters XML 1.0 does not allow in a document.
XML_INVALID = re.compile("[^\u0009\u000a\u000d\u0020-\ud7ff\ue000-\ufffd\U00010000-\U0010ffff]")


def xml_text(text: str) -> str:
    """User text made storable in XML 1.0 (ElementTree escapes ``& < > "``; this drops control characters)."""
    return XML_INVALID.sub("?", text)


def comment_text(text: str) -> str:
    """``text`` made safe inside an XML comment, which may hold neither ``--`` nor end in ``-``.

    Every dash that a dash follows is written ``\\x2d``: no ``--`` is left (so no ``-->`` either),
    whatever the run of dashes, and inside a Python string literal (the header quotes the case name and
    file name with ``repr``) ``\\x2d`` is the escape of ``-``, so ``ast.literal_eval`` reads the name
    back unchanged.  Characters XML forbids become ``?`` (:func:`xml_text`; ``repr`` escapes them
    already).  Proven on adversarial names by ``tests/models/test_mjcf_names.py``.
    """
    return xml_text(re.sub("-(?=-)", r"\\x2d", text))
