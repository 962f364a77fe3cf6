"""Today's mechanisms as loop tables: the slider crank of a :class:`~dualmech.models.case.Case`, the RSSR
and the RCCC of ``models/linkages/``.

The slider crank's table (thesis Table 1; ``docs/conventions.md``, "Mechanism"): joint 1 cylindrical (its
angle driven, its slide by the axial law; a revolute crank: R with the constant offset ``S1``), joints 2 and 3
balls (joint 3 with ``alpha = pi/2``), joint 4 prismatic with ``alpha4``, ``a4`` closing onto the ground.  The
slider's mass properties, given in world axes at ``P3``, are turned into its link frame (the frame after
joint 3, ``Rx(-(alpha3 + alpha4))`` in world axes: a constant, the slider only translates).  A universal
joint 3 is a U row with ``alpha = -pi/2``: its first axis, fixed in the rod, is the rod-side axis
``a = u x k4 / |u x k4|`` and its second, turned by ``-pi/2`` about x, is the slider axis ``k4 = z4``; the
rod's link frame is then ``(u, a x u, a)``, the conventions' rod frame ``(u, a, u x a)`` turned about x.

The RSSR (``docs/conventions.md``, "RSSR") is R, S, S, R with the output axis's ``alpha4``, ``a4`` and offset
``-h`` in the last row; its output crank's body frame (origin ``Q4``, x toward ``P3``) is the link frame of
ball 3 (origin ``P3``, x toward ``Q4``) turned by pi about z and moved by ``a3``.  The RCCC (``"RCCC"``) is
its own table, R, C, C, C, with the link frames as body frames.  Each output torque (the ground's moment on
the output link about the last axis ``z4``) is minus joint 4's effort (on the ground, from the output link).
The RSSR's and RCCC's tables keep their mechanisms' status rules (their transmissions, applied to every
engine's table by ``models/linkages/readback.py``), not the loop table's closure condition: ``limits``
false.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from dualmech.core.inertia import BodyInertia
from dualmech.core.loop import LoopState
from dualmech.core.motion import CrankMotion
from dualmech.models.case import Case
from dualmech.models.linkages import rccc, rssr
from dualmech.models.linkages.rccc_case import RcccCase
from dualmech.models.linkages.rssr_case import RssrCase
from dualmech.models.loop.columns import COORDINATES
from dualmech.models.loop.description import Drive, Joint, Load, LoopMechanism
from dualmech.models.loop.translate import to_loop

#: The RSSR's output crank frame in its ball-3 link frame: turned by pi about z (x toward P3).
FLIP = np.diag([-1.0, -1.0, 1.0])


def _rx(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


#: The conventions' rod frame ``(u, a, u x a)`` in the rod's link frame ``(u, a x u, a)`` with a universal
#: joint 3 (module docstring): columns are the conventions' axes in link-frame coordinates.
ROD_UNIVERSAL = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


def _twist3(case: Case) -> float:
    """Joint 3's twist: pi/2 for a ball (thesis Table 1), -pi/2 for a universal joint (module docstring)."""
    return -math.pi / 2 if case.joints.rod_slider == "universal" else math.pi / 2


def _turned(body: BodyInertia, rotation: np.ndarray) -> BodyInertia:
    """``body`` given in a frame whose axes are ``rotation``'s columns (in the new frame's coordinates)."""
    return BodyInertia(body.mass, rotation @ body.com, rotation @ body.inertia @ rotation.T)


def slider_frame(case: Case) -> np.ndarray:
    """Rotation ``(3, 3)`` of the slider's link frame in world axes (module docstring)."""
    return _rx(-(_twist3(case) + case.geometry.slider_twist))


def slider_crank_table(case: Case) -> LoopMechanism:
    """The slider crank ``case`` as a :class:`LoopMechanism` (every joint variant of ``[joints]``).

    Loads: the drive torque is joint 1's effort; the slider load ``k4 · f`` (``f`` the ground's force on the
    slider) is joint 4's effort along its axis ``z4``: with :math:`z_4 = -k_4` (the table's P3 = F - S4 k4)
    the effort on the ground from the slider is :math:`-z_4\\cdot f = k_4 \\cdot f`.
    """
    g, m = case.geometry, case.motion
    universal = case.joints.rod_slider == "universal"
    cylindrical = case.joints.crank == "cylindrical"
    joints = (
        Joint("C" if cylindrical else "R", a=g.crank_length, s=0.0 if cylindrical else g.crank_axial_shift),
        Joint("S", a=g.rod_length),
        Joint("U" if universal else "S", alpha=_twist3(case)),
        Joint("P", alpha=g.slider_twist, a=g.slider_offset),
    )
    drive = Drive(0, "theta", np.radians(m.angles_deg), m.speed, m.accel,
                  g.crank_axial_shift if cylindrical else 0.0, m.axial_amplitude, m.axial_cycles,
                  case.loads.drive_torque)
    rod = _turned(case.bodies.rod, ROD_UNIVERSAL) if universal else case.bodies.rod
    bodies = (case.bodies.crank, rod, _turned(case.bodies.slider, slider_frame(case).T))
    force = case.loads.slider_force
    load = Load(3, "s", None if force is None else -force)
    return LoopMechanism(case.name, joints, drive, bodies, (load,), case.loads.gravity)


def slider_crank_start(case: Case, s4: float, at: int = 0) -> LoopState:
    """An assembled pose at the case's crank angle number ``at`` (0-based) from its slider coordinate ``s4``
    there (e.g. the thesis's closed form): the rod frame pointed from ``P2`` at ``P3 = F - S4 k4`` (with a
    universal joint 3, its z along the rod-side axis ``a``, and the joint's two angles from the rod and
    slider frames)."""
    g = case.geometry
    crank = case.own_crank_states(case.motion.angles_deg[at:at + 1])
    theta, s1 = crank.theta[0], crank.s[0]
    p2 = np.array([g.crank_length * math.cos(theta), g.crank_length * math.sin(theta), s1])
    p3 = g.foot - s4 * g.k4
    u = (p3 - p2) / np.linalg.norm(p3 - p2)
    universal = case.joints.rod_slider == "universal"
    if universal:  # the rod frame's z is the joint's rod-side axis a = u x k4 / |u x k4|: y = a x u
        a = np.cross(u, g.k4)
        v = np.cross(a / np.linalg.norm(a), u)
    else:
        ref = np.array([1.0, 0.0, 0.0]) if abs(u[2]) > 0.9 else np.array([0.0, 0.0, 1.0])
        v = np.cross(ref, u)
        v /= np.linalg.norm(v)
    rod = np.stack([u, v, np.cross(u, v)], axis=1)
    crank_rot = np.array([[math.cos(theta), -math.sin(theta), 0.0], [math.sin(theta), math.cos(theta), 0.0],
                          [0.0, 0.0, 1.0]])
    ball2 = crank_rot.T @ rod
    joint3 = rod.T @ slider_frame(case)
    if universal:  # joint3 = Rz(theta3) Ry(eta3)
        angles = [math.atan2(-joint3[0, 1], joint3[1, 1]), math.atan2(-joint3[2, 0], joint3[2, 2])]
        return LoopState(np.array([[*angles, s4]]), ball2[None, None])
    return LoopState(np.array([[s4]]), np.stack([ball2, joint3])[None])


def _crank_drive(motion: CrankMotion, effort: float | None) -> Drive:
    """Joint 1 driven by its angle at the case's crank angles, speed and acceleration."""
    return Drive(0, "theta", np.radians(motion.angles_deg), motion.speed, motion.accel, effort=effort)


def _output_load(torque: float | None) -> Load:
    """Joint 4's effort about ``z4`` from a given output torque (``None``: solved)."""
    return Load(3, "theta", None if torque is None else -torque)


def rssr_table(case: RssrCase) -> LoopMechanism:
    """The RSSR ``case`` as a :class:`LoopMechanism` (module docstring)."""
    g = case.geometry
    joints = (Joint("R", a=g.a1, s=g.s1), Joint("S", a=g.a2), Joint("S", a=g.a3),
              Joint("R", alpha=g.alpha4, a=g.a4, s=-g.h))
    crank, coupler, out = case.bodies
    output = BodyInertia(out.mass, FLIP @ out.com + np.array([g.a3, 0.0, 0.0]), FLIP @ out.inertia @ FLIP)
    return LoopMechanism(case.name, joints, _crank_drive(case.motion, case.drive_torque),
                         (crank, coupler, output), (_output_load(case.output_torque),), case.gravity,
                         limits=False)


def rssr_start(case: RssrCase, at: int = 0) -> LoopState:
    """The RSSR's closed-form pose at its crank angle number ``at`` (0-based), on its branch
    (:func:`dualmech.models.linkages.rssr.closed_form_phi`)."""
    theta = np.radians(case.motion.angles_deg[at:at + 1])
    return rssr.estimate(case.geometry, theta, rssr.closed_form_phi(case.geometry, theta, case.branch)[0])


def rccc_table(case: RcccCase) -> LoopMechanism:
    """The RCCC ``case`` as a :class:`LoopMechanism` (module docstring); the drive torque is solved."""
    g = case.geometry
    joints = tuple(Joint("R" if i == 0 else "C", alpha=g.alpha[i], a=g.a[i], s=g.s1 if i == 0 else 0.0)
                   for i in range(4))
    return LoopMechanism(case.name, joints, _crank_drive(case.motion, None), case.bodies,
                         (_output_load(case.output_torque),), case.gravity, limits=False)


def rccc_start(case: RcccCase, at: int = 0) -> LoopState:
    """The RCCC's spherical estimate at its crank angle number ``at`` (0-based), on its branch
    (:func:`dualmech.models.linkages.rccc.spherical_estimate`)."""
    theta = np.radians(case.motion.angles_deg[at:at + 1])
    return rccc.estimate(case.geometry, theta, rccc.spherical_estimate(case.geometry, theta, case.branch)[0])


def loop_table_of(case: Any) -> LoopMechanism:
    """The loop table of any linkage case: a loop table as is; an RSSR or RCCC by its preset
    (:mod:`dualmech.models.loop.presets`), every joint's ``start`` its own estimate at the first crank angle
    on the case's branch (the RSSR's closed form, the RCCC's spherical estimate)."""
    if isinstance(case, LoopMechanism):
        return case
    table, start = {RssrCase: (rssr_table, rssr_start), RcccCase: (rccc_table, rccc_start)}[type(case)]
    return started(table(case), start(case))


def rows(mechanism: LoopMechanism, k: int, stop: int | None = None) -> LoopMechanism:
    """``mechanism`` driven at its positions ``k`` to ``stop`` (0-based, ``stop`` exclusive; ``None``: to the
    last): a run of an RSSR's or RCCC's engine from row ``k`` (:mod:`dualmech.models.linkages.restarts`)."""
    return replace(mechanism, drive=replace(mechanism.drive, positions=mechanism.drive.positions[k:stop]))


def started(mechanism: LoopMechanism, state: LoopState) -> LoopMechanism:
    """``mechanism`` with every joint's ``start`` the pose ``state`` (one position: its scalars in the
    loop's unknowns' order, its rotations the S joints', each a rotation vector)."""
    values = dict(zip(to_loop(mechanism).unknowns, state.scalars[0]))
    rotations = list(state.rotations[0])
    joints = []
    for i, joint in enumerate(mechanism.joints):
        if joint.type == "S":
            start_values = tuple(Rotation.from_matrix(rotations.pop(0)).as_rotvec().tolist())
        else:
            # a prescribed coordinate's start is not read (the drive gives it): 0
            start_values = tuple(float(values.get(f"{c}{i + 1}", 0.0)) for c in COORDINATES[joint.type])
        joints.append(replace(joint, start=start_values))
    return replace(mechanism, joints=tuple(joints))
