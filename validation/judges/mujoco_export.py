"""The MuJoCo model a user runs (``dualmech mjcf``): assembled by MuJoCo, time step measured in MuJoCo.

:func:`dualmech.models.mjcf.runnable_mjcf` writes the text; this module finds
what the text needs and only MuJoCo can give without the in-house solver
(independence, as in the judges):

* **the start state**: the loop closed at the case's first crank angle by the
  rigid path's own Newton from a crude guess
  (:func:`dualmech.validation.judges.mujoco_slider_crank.engine.assembled_state`), with the loop's
  rates for the case's crank speed (``S1`` held: ``S1_dot = 0``);
* **the time step**: the soft connect opens by about
  :math:`16\\,\\Delta t^2\\,|\\dot J\\dot q|` (``validation/judges/mujoco_slider_crank/sim.py``), so the
  step is *measured*: the exported model is stepped from its keyframe for one
  revolution (at most :data:`CHECK_STEPS` steps), and the step shrinks by
  :math:`0.9\\sqrt{\\text{target}/\\text{gap}}` until the largest loop gap stays
  within :data:`CHECK_MARGIN` of
  :data:`~dualmech.validation.tolerances.MJCF_EXPORT_LOOP_GAP` (relative to
  ``a2``) and the crank speed within :data:`CHECK_MARGIN` of
  :data:`~dualmech.validation.tolerances.MJCF_EXPORT_CRANK_SPEED`.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from dualmech.core.status import Status
from dualmech.models.case import Case
from dualmech.models.kinds import SLIDER_CRANK, kind_of
from dualmech.models.loop.description import LoopMechanism
from dualmech.models.loop.presets import loop_table_of
from dualmech.models.mjcf import KEY_NAME, MjcfStart, check_exportable, runnable_mjcf
from dualmech.models.mjcf_export import SPEED_SERVO_STEPS, comment_text
from dualmech.validation.judges.mujoco_loop.closure import build as build_loop
from dualmech.validation.judges.mujoco_loop.mjcf import CUT_SITES, joint_name
from dualmech.validation.judges.mujoco_loop.sim_mjcf import HALF_SITE, SimSettings, loop_sim_mjcf
from dualmech.validation.judges.mujoco_loop.sim_plan import Survey, length, plan, survey
from dualmech.validation.judges.mujoco_loop.sim_plan import settings as sim_settings
from dualmech.validation.judges.mujoco_loop.simulation import reference, run_start
from dualmech.validation.judges.mujoco_slider_crank.engine import assembled_state, build
from dualmech.validation.tolerances import MJCF_EXPORT_CRANK_SPEED, MJCF_EXPORT_LOOP_GAP

#: The first step tried: one degree of the crank per step, never longer than this (s; MuJoCo's default: 2e-3).
MAX_EXPORT_TIMESTEP = 1e-3
#: Most steps of the check run (one revolution, or this many steps of it).
CHECK_STEPS = 20_000
#: Most time steps tried before giving up.
TIMESTEP_TRIALS = 10
#: The check run must stay within this fraction of each limit (a margin for later turns and other platforms).
CHECK_MARGIN = 0.5


@dataclass(frozen=True)
class ExportCheck:
    """What the exported model did when stepped from its keyframe.

    Attributes
    ----------
    timestep : float
        Seconds.
    steps : int
        Steps simulated.
    assembled_gap : float
        Loop gap / a2 of the keyframe pose (before the first step).
    loop_gap : float
        Largest loop gap / a2 over the run (``inf`` if MuJoCo found the state unstable).
    speed_error : float
        Largest :math:`|\\dot\\theta_1/\\omega - 1|` over the run (in rad/s when the case's speed is 0).
    """

    timestep: float
    steps: int
    assembled_gap: float
    loop_gap: float
    speed_error: float

    @property
    def passed(self) -> bool:
        """Loop gap and crank speed within :data:`CHECK_MARGIN` of their ``MJCF_EXPORT_*`` tolerances."""
        return max(self.loop_gap / MJCF_EXPORT_LOOP_GAP.value,
                   self.speed_error / MJCF_EXPORT_CRANK_SPEED.value) <= CHECK_MARGIN


def start_state(case: Case) -> MjcfStart:
    """The loop closed at the case's first crank angle, moving at its crank speed (``S1`` held).

    Raises
    ------
    ValueError
        The mechanism does not assemble (or sits at an edge of assembly) there, or its joints are not the
        default ones (:func:`~dualmech.models.mjcf.check_exportable`).
    """
    check_exportable(case)
    lp = build(case)
    st = case.own_crank_states()
    theta, s1 = float(st.theta[0]), float(st.s[0])
    status, *_ = assembled_state(lp, (theta, s1, case.motion.speed, 0.0), warm=False)
    if status != Status.OK:
        raise ValueError(f"motion.angles_deg.start: the loop does not close at theta1 = "
                         f"{math.degrees(theta):g} deg ({status}); start the case where it assembles")
    load = case.loads.slider_force if case.loads.mode == "force" else 0.0
    return MjcfStart(lp.data.qpos.copy(), lp.data.qvel.copy(), float(load))


def check_export(xml: str, case: Case, steps: int) -> ExportCheck:
    """Step the exported ``xml`` ``steps`` times from its keyframe; loop gap and crank speed at every step."""
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key(KEY_NAME).id)
    mujoco.mj_forward(m, d)
    a2, w = case.geometry.rod_length, case.motion.speed
    gap_adr, speed_adr = m.sensor("loop_gap").adr[0], m.sensor("theta1_dot").adr[0]
    assembled = float(np.linalg.norm(d.sensordata[gap_adr:gap_adr + 3])) / a2
    gaps, speeds = np.empty(steps), np.empty(steps)
    for i in range(steps):  # time steps of one trajectory: sequential by nature
        mujoco.mj_step(m, d)
        gaps[i] = np.linalg.norm(d.sensordata[gap_adr:gap_adr + 3])
        speeds[i] = d.sensordata[speed_adr]
    unstable = d.warning[mujoco.mjtWarning.mjWARN_BADQACC].number > 0  # MuJoCo then resets the state
    loop_gap = math.inf if unstable or not np.all(np.isfinite(gaps)) else float(gaps.max()) / a2
    speed_error = float(np.abs(speeds / w - 1.0).max() if w != 0.0 else np.abs(speeds).max())
    return ExportCheck(m.opt.timestep, steps, assembled, loop_gap, speed_error if not unstable else math.inf)


def shrink(check: ExportCheck) -> float:
    """The factor of the next time step to try after a failed ``check``: the loop gap shrinks like
    :math:`\\Delta t^2`, the speed servo's lag like :math:`\\Delta t` (its gain ~ 1/dt); 0.25 where the run
    blew up."""
    factor = min(0.9 * math.sqrt(CHECK_MARGIN * MJCF_EXPORT_LOOP_GAP.value / check.loop_gap),
                 0.9 * CHECK_MARGIN * MJCF_EXPORT_CRANK_SPEED.value / max(check.speed_error, 1e-300), 0.9)
    return factor if factor > 0.0 else 0.25


def export_mjcf(case: Case, file_name: str = "model.xml") -> tuple[str, ExportCheck]:
    """The MJCF text of :func:`~dualmech.models.mjcf.runnable_mjcf` with a measured time step, and its check.

    Raises
    ------
    ValueError
        No assembly at the first crank angle, or none of :data:`TIMESTEP_TRIALS`
        time steps keeps the loop closed and the speed (e.g. a mechanism that
        does not assemble over a whole revolution).
    """
    start = start_state(case)
    w = abs(case.motion.speed)
    dt = min(MAX_EXPORT_TIMESTEP, math.radians(1.0) / w) if w > 0.0 else MAX_EXPORT_TIMESTEP
    for _ in range(TIMESTEP_TRIALS):
        steps = min(CHECK_STEPS, math.ceil(2.0 * math.pi / (w * dt))) if w > 0.0 else CHECK_STEPS
        check = check_export(runnable_mjcf(case, start, dt, file_name), case, steps)
        if check.passed:
            first = (f"Checked when written: {check.steps} steps from the keyframe; the loop gap stayed "
                     f"within {check.loop_gap:.2g} of a2 (limit {MJCF_EXPORT_LOOP_GAP.value:g}),")
            second = (f"  the crank speed within {check.speed_error:.2g} of the case's "
                      f"(limit {MJCF_EXPORT_CRANK_SPEED.value:g}).")
            return runnable_mjcf(case, start, dt, file_name, (first, second)), check
        dt *= shrink(check)
    raise ValueError(f"case: the exported model does not keep its loop closed (gap "
                     f"{check.loop_gap:.3g} of a2 at dt = {check.timestep:.3g} s over {check.steps} steps; "
                     "does it assemble at every crank angle?)")


# ----------------------------------------------------------------------------- a loop table's model

#: Name of the exported loop model's drive-speed actuator (the judge's position servo made a velocity one).
LOOP_DRIVE_ACTUATOR = "drive_speed"


@dataclass(frozen=True)
class LoopStart:
    """The exported loop model's keyframe: ``qpos``, ``qvel`` of the simulation MJCF (joints 1 .. n-1, then
    joint n's on the ground half), the loop closed at the first drive position by the MuJoCo judge and
    moving at the drive's speed; ``ctrl`` the drive's speed, a C drive's slide, then the loads' efforts;
    ``drive_inertia`` the largest effective inertia about the drive the judge's survey measured (the
    velocity servo's gain is it over :data:`~dualmech.models.mjcf_export.SPEED_SERVO_STEPS` time steps, as
    the slider crank's ``crank_speed``; ``implicitfast`` integrates it implicitly)."""

    qpos: np.ndarray
    qvel: np.ndarray
    ctrl: np.ndarray
    drive_inertia: float


def loop_start(mechanism: LoopMechanism) -> tuple[LoopStart, Survey]:
    """The keyframe of ``mechanism`` and the simulated judge's survey of it
    (:mod:`dualmech.validation.judges.mujoco_loop.sim_plan`).

    Raises
    ------
    ValueError
        The table is driven at its last joint (the simulation model hangs the ground's half from it), or
        the loop does not close at the first drive position.
    """
    n = len(mechanism.joints)
    if mechanism.drive.joint == n - 1:
        raise ValueError(f"drive.joint: {mechanism.name!r} is driven at its last joint ({n}); the exported "
                         "model cuts the loop inside the ground, whose half hangs from that joint: number "
                         "the joints so that another is the last")
    sv = survey(mechanism)
    if sv.status[0] != Status.OK.value:
        raise ValueError(f"drive.positions: {mechanism.name!r} does not close at its first drive position "
                         f"({sv.status[0]}); start the case where it assembles")
    values, rates = reference(mechanism, 0, np.array([0.0]))
    qpos, qvel = run_start(build_loop(mechanism), sv, 0, values[0], rates[0])
    loads = [0.0 if load.value is None else load.value for load in mechanism.loads]
    return LoopStart(qpos, qvel, np.array([rates[0, 0], *values[0, 1:], *loads]), sv.inertia_high[0]), sv


def loop_export_xml(mechanism: LoopMechanism, start: LoopStart, s: SimSettings, file_name: str,
                    notes: tuple[str, ...] = ()) -> str:
    """The simulated judge's MJCF (:func:`~dualmech.validation.judges.mujoco_loop.sim_mjcf.loop_sim_mjcf`)
    with the drive's servo on its coordinate made a velocity servo (``ctrl`` = its rate, as the slider
    crank's ``crank_speed``), the keyframe :data:`~dualmech.models.mjcf_export.KEY_NAME` and a header."""
    root = ET.fromstring(loop_sim_mjcf(mechanism, s))
    actuators = root.find("actuator")
    servo = actuators[0]
    speed = ET.Element("velocity", name=LOOP_DRIVE_ACTUATOR, joint=servo.get("joint"),
                       kv=repr(start.drive_inertia / (SPEED_SERVO_STEPS * s.timestep)))
    actuators.remove(servo)
    actuators.insert(0, speed)
    ET.SubElement(ET.SubElement(root, "keyframe"), "key", name=KEY_NAME, qpos=_text(start.qpos),
                  qvel=_text(start.qvel), ctrl=_text(start.ctrl))
    ET.indent(root)
    body = ET.tostring(root, encoding="unicode") + "\n"
    return loop_header(mechanism, start, s, file_name, [a.get("name") for a in actuators], notes) + body


def _text(values: np.ndarray) -> str:
    return " ".join(repr(float(v)) for v in np.ravel(values))


def loop_header(mechanism: LoopMechanism, start: LoopStart, s: SimSettings, file_name: str,
                actuators: list[str], notes: tuple[str, ...]) -> str:
    """The comment block of :func:`loop_export_xml` (as :func:`~dualmech.models.mjcf_export.export_header`:
    every line through :func:`~dualmech.models.mjcf_export.comment_text`)."""
    d = mechanism.drive
    n = len(mechanism.joints)
    first = f"{math.degrees(d.positions[0]):.6g} deg" if d.coordinate == "theta" else f"{d.positions[0]:.6g}"
    rate = "rad/s" if d.coordinate == "theta" else "length/s"
    lines = [
        f"dualmech MuJoCo model of the loop table, case {mechanism.name!r}: joints "
        + " ".join(j.type for j in mechanism.joints) + f", driven at joint {d.joint + 1} ({d.coordinate})",
        "(written by dualmech mjcf with the MuJoCo judge's own builder, validation/judges/mujoco_loop/;",
        "frames and signs: dualmech docs/conventions.md, \"Loop tables\"). Units: the case file's; angles in",
        "rad.",
        "",
        "Run it:",
        f"  python -c \"import mujoco.viewer; mujoco.viewer.launch_from_path({file_name!r})\"",
        "  then Simulation > Load key: the drive turns.",
        f"  m = mujoco.MjModel.from_xml_path({file_name!r}); d = mujoco.MjData(m)",
        f"  mujoco.mj_resetDataKeyframe(m, d, m.key('{KEY_NAME}').id); mujoco.mj_step(m, d, nstep=1000)",
        "",
        f"Bodies: link1 .. link{n - 1}, each carrying its joint's MuJoCo joints joint<i>_<coordinate> (body",
        "  frame = the table's link frame); ground_half carries joint n's, and the equality weld 'cut' holds",
        "  it on the world's site cut_ground (the loop cut inside the ground; soft:",
        f"  solref {_text(s.weld_solref)}, solimp {_text(s.weld_solimp)}). ground_half's mass is the judge's",
        "  (sim_mjcf.py).",
        f"Keyframe {KEY_NAME!r}: the loop closed at the first drive position ({first}) by the MuJoCo judge,",
        f"  moving at the drive's speed {d.speed:.6g} {rate}.",
        "Actuators (ctrl in the keyframe): " + ", ".join(actuators) + ";",
        f"  {LOOP_DRIVE_ACTUATOR}: velocity servo on the drive (ctrl = its rate); a C drive's slide:",
        "  position servo (ctrl = the slide, held); load_<joint>: motor, ctrl = the effort on the joint's",
        "  link from the previous one (the case's given loads; 0 for the one it solves).",
        f"Time step {s.timestep:.3g} s, integrator implicitfast.",
        *notes,
    ]
    text = "".join(f"  {comment_text(line)}\n" if line else "\n" for line in lines)
    return "<!--\n" + text + "-->\n"


def check_loop_export(xml: str, mechanism: LoopMechanism, steps: int) -> ExportCheck:
    """Step the exported loop model ``steps`` times from its keyframe: the cut's gap over the table's length
    and the drive's rate against its speed, as :func:`check_export`."""
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key(KEY_NAME).id)
    mujoco.mj_forward(m, d)
    size = length(mechanism)
    half, ground = m.site(HALF_SITE).id, m.site(CUT_SITES[1]).id
    dof = m.jnt_dofadr[m.joint(joint_name(mechanism.drive.joint, mechanism.drive.coordinate)).id]
    assembled = float(np.linalg.norm(d.site_xpos[half] - d.site_xpos[ground])) / size
    gaps, rates = np.empty(steps), np.empty(steps)
    for i in range(steps):  # time steps of one trajectory: sequential by nature
        mujoco.mj_step(m, d)
        gaps[i] = np.linalg.norm(d.site_xpos[half] - d.site_xpos[ground])
        rates[i] = d.qvel[dof]
    unstable = d.warning[mujoco.mjtWarning.mjWARN_BADQACC].number > 0
    loop_gap = math.inf if unstable or not np.all(np.isfinite(gaps)) else float(gaps.max()) / size
    w = mechanism.drive.speed
    error = float(np.abs(rates / w - 1.0).max() if w != 0.0 else np.abs(rates).max())
    return ExportCheck(m.opt.timestep, steps, assembled, loop_gap, error if not unstable else math.inf)


def _checked(check: ExportCheck) -> tuple[str, str]:
    """The header's lines on a passed check of a loop model."""
    return (f"Checked when written: {check.steps} steps from the keyframe; the cut's gap stayed within "
            f"{check.loop_gap:.2g} of the table's length (limit {MJCF_EXPORT_LOOP_GAP.value:g}),",
            f"  the drive's rate within {check.speed_error:.2g} of its speed "
            f"(limit {MJCF_EXPORT_CRANK_SPEED.value:g}).")


def export_loop_mjcf(case: Any, file_name: str = "model.xml") -> tuple[str, ExportCheck]:
    """The MJCF of a linkage case's loop table (:func:`loop_table_of`) that runs as written, and its check:
    stepped from its keyframe over the drive's range of positions (at most :data:`CHECK_STEPS` steps), the
    judge's time step shrunk (:func:`shrink`, at most :data:`TIMESTEP_TRIALS` trials) until it passes.

    Raises
    ------
    ValueError
        One line: :func:`loop_start`'s, or the check run does not keep the loop closed and the speed.
    """
    mechanism = loop_table_of(case)
    start, sv = loop_start(mechanism)
    s = plan(mechanism, sv)[0]
    d = mechanism.drive
    least = math.radians(1.0) if d.coordinate == "theta" else length(mechanism)
    span = max(float(np.ptp(d.positions)), least)
    for _ in range(TIMESTEP_TRIALS):
        steps = min(CHECK_STEPS, math.ceil(span / (abs(d.speed) * s.timestep))) if d.speed else CHECK_STEPS
        check = check_loop_export(loop_export_xml(mechanism, start, s, file_name), mechanism, steps)
        if check.passed:
            return loop_export_xml(mechanism, start, s, file_name, _checked(check)), check
        s = sim_settings(mechanism, s.timestep * shrink(check), sv)
    raise ValueError(f"case: the exported model does not keep its loop closed and its speed (gap "
                     f"{check.loop_gap:.3g} of the table's length, speed error {check.speed_error:.3g} "
                     f"at dt = {check.timestep:.3g} s over {check.steps} steps)")


def export_case(case: Any, file_name: str = "model.xml") -> tuple[str, str]:
    """The MJCF of a checked case of any kind that runs as written (:func:`export_mjcf` for a slider crank,
    :func:`export_loop_mjcf` for every other kind: its loop table's model), and what ``dualmech mjcf``
    says about it: where the loop closed, the time step, the check run (one line; a second one where the
    model leaves part of the case's motion out)."""
    if kind_of(case) != SLIDER_CRANK:
        xml, check = export_loop_mjcf(case, file_name)
        return xml, (f"loop table closed at the first drive position (cut gap {check.assembled_gap:.2g} of "
                     f"its length); time step {check.timestep:.3g} s; {check.steps} steps from key "
                     f"{KEY_NAME!r}: cut gap <= {check.loop_gap:.2g}, drive rate within "
                     f"{check.speed_error:.2g} of its speed")
    xml, check = export_mjcf(case, file_name)
    w = case.motion.speed
    text = (f"loop closed at theta1 = {case.motion.angles_deg[0]:g} deg (gap {check.assembled_gap:.2g} of "
            f"a2); time step {check.timestep:.3g} s; {check.steps} steps from key {KEY_NAME!r}: loop gap <= "
            f"{check.loop_gap:.2g} of a2, crank speed within {check.speed_error:.2g} of {w:.6g} rad/s "
            f"({w * 30.0 / np.pi:.6g} rpm)")
    if case.motion.accel != 0.0 or case.motion.axial_amplitude != 0.0:
        text += ("\nnote: the model turns the crank at a constant speed with S1 held; the case's crank_accel "
                 "and axial S1 law need a controller that sets ctrl over time")
    return xml, text
