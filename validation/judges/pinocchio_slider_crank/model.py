"""The generalized slider crank as a Pinocchio model, built in code from a
:class:`~dualmech.models.case.Case`.

Pinocchio is imported only under ``validation/``.  The tree is cut at joint 3
(the rod–slider ball joint), which becomes a loop-closure constraint::

    universe ──[joint 1: RZ∘PZ composite, q = (theta1, S1)]──> crank   (frame: origin (0,0,S1), axes
    Rz(theta1))
        │                                                        │
        │                              [joint 2: spherical, at (a1,0,0) of the crank frame]
        │                                                        ▼
        │                                                       rod    (frame: origin P2, x = u)
        │                                                        ┆ rod end (a2,0,0)   joint 3: CONTACT_3D
        └──[joint 4: prismatic along -k4, placed at F, q = S4]──> slider (frame: origin P3, world axes)

Each joint frame *is* the body frame of ``docs/conventions.md`` ("Body
frames"), so ``case.bodies`` goes into Pinocchio unchanged:

* crank: the composite joint applies ``Rz(theta1)`` then a translation ``S1``
  along the (unchanged) z axis, giving origin ``(0, 0, S1)`` and axes
  ``Rz(theta1)``;
* rod: the spherical joint sits at the pin ``(a1, 0, 0)`` of the crank frame;
  once the loop is closed the rod end ``(a2, 0, 0)`` of the rod frame is at
  ``P3``, so the rod frame's x axis is ``u`` (its y, z are whatever the
  quaternion makes them; the rod is axisymmetric, conventions "Rod spin");
* slider: the prismatic joint frame is placed at ``F`` with world axes and
  slides along ``-k4``, so its origin is ``P3 = F - S4*k4`` (conventions
  "Points and the loop") and its axes are the world axes.

The configuration is ``q = (theta1, S1, quat_xyzw(rod, 4), S4)`` (``nq = 7``)
and the velocity ``v = (theta1_dot, S1_dot, omega_rel(rod, 3, rod axes), S4_dot)``
(``nv = 6``).

**Joint variants** (``case.joints``, issue 15), on the same tree:

* ``crank = "revolute"``: joint 1 is ``RZ`` alone, placed at ``(0, 0, S1)`` (``crank_axial_shift``):
  ``q = (theta1, quat, S4)``, ``v = (theta1_dot, omega, S4_dot)``.
* ``rod_slider = "universal"``: the cut at P3 carries, besides the point constraint, the universal
  joint's own condition: the rod-side axis ``e`` (the rod frame's y axis) stays normal to the slider's
  axis ``k4``, ``e·k4 = 0`` (holonomic, one equation; its rate form is ``omega_rod·n = 0`` with
  ``n = e x k4``, so its multiplier is a moment along ``n``: the joint's constraint moment).  The rod
  frame is then x = ``u``, y = ``a_r = u x k4 / |u x k4|``
  (:mod:`~dualmech.validation.judges.pinocchio_slider_crank.closure`
  turns the rod about ``u`` onto it).  MuJoCo's judge builds the same joint the other way (two hinges in
  the tree, the loop cut at P2), so the two judges share no step of the universal joint.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from dualmech.models.case import Case


@dataclass(frozen=True)
class PinocchioSliderCrank:
    """A Pinocchio model of one case, its loop constraint and the indices engines need.

    Attributes
    ----------
    model : pinocchio.Model
        Three joints (crank, rod, slider), gravity from ``case.loads.gravity``.
    constraint : pinocchio.RigidConstraintModel
        ``CONTACT_3D`` between the rod end ``(a2, 0, 0)`` (rod frame) and the
        slider pin (slider frame origin), ``LOCAL`` reference frame.
    crank_joint, rod_joint, slider_joint : int
        Joint indices in ``model``.
    rod_end_frame, slider_pin_frame : int
        Frame indices of the two points the constraint joins.
    v_crank, v_rod, v_slider : slice
        Their velocity indices: ``v_crank`` = (theta1, S1), ``v_rod`` = rod
        angular velocity relative to the crank in rod axes, ``v_slider`` = S4.
    q_crank, q_rod, q_slider : slice
        Their configuration indices (``q_rod`` is a quaternion x, y, z, w).
    a1, a2 : float
        Crank and rod lengths.
    nc : int
        Crank coordinates: 2 (cylindrical: theta1, S1) or 1 (revolute: theta1).
    universal : bool
        The rod meets the slider in a universal joint (the closure adds ``e·k4 = 0``).
    k4, F : numpy.ndarray, shape (3,)
        Slider direction and the foot ``F = (-a4, 0, 0)`` of the common normal, world axes.
    """

    model: pin.Model
    constraint: pin.RigidConstraintModel
    crank_joint: int
    rod_joint: int
    slider_joint: int
    rod_end_frame: int
    slider_pin_frame: int
    q_crank: slice
    q_rod: slice
    q_slider: slice
    v_crank: slice
    v_rod: slice
    v_slider: slice
    a1: float
    a2: float
    k4: np.ndarray
    F: np.ndarray
    nc: int = 2
    universal: bool = False


def slider_axis(case: Case) -> tuple[np.ndarray, np.ndarray]:
    """``k4 = (0, sin alpha4, cos alpha4)`` and ``F = (-a4, 0, 0)`` (conventions "Points and the loop")."""
    alpha = case.geometry.slider_twist
    k4 = np.array([0.0, np.sin(alpha), np.cos(alpha)])
    F = np.array([-case.geometry.slider_offset, 0.0, 0.0])
    return k4, F


def _inertia(body) -> pin.Inertia:
    """``case.bodies.*`` (mass, com in the body frame, inertia about the com in body axes) as a
    pin.Inertia."""
    return pin.Inertia(float(body.mass), np.asarray(body.com, float), np.asarray(body.inertia, float))


def build_model(case: Case) -> PinocchioSliderCrank:
    """Build the Pinocchio model of ``case`` (see the module docstring for the tree and frames).

    Parameters
    ----------
    case : Case
        Geometry, bodies and gravity are read from it; motion and loads are not.

    Returns
    -------
    PinocchioSliderCrank
    """
    g = case.geometry
    a1, a2 = float(g.crank_length), float(g.rod_length)
    k4, F = slider_axis(case)
    model = pin.Model()
    model.name = "slider_crank"

    crank = _crank_joint(model, case)
    model.appendBodyToJoint(crank, _inertia(case.bodies.crank), pin.SE3.Identity())

    pin_in_crank = pin.SE3(np.eye(3), np.array([a1, 0.0, 0.0]))
    rod = model.addJoint(crank, pin.JointModelSpherical(), pin_in_crank, "joint2_ball")
    model.appendBodyToJoint(rod, _inertia(case.bodies.rod), pin.SE3.Identity())

    slider_origin = pin.SE3(np.eye(3), F)
    slider = model.addJoint(0, pin.JointModelPrismaticUnaligned(-k4), slider_origin, "joint4_prismatic")
    model.appendBodyToJoint(slider, _inertia(case.bodies.slider), pin.SE3.Identity())

    rod_end = pin.SE3(np.eye(3), np.array([a2, 0.0, 0.0]))
    rod_end_frame = model.addFrame(pin.Frame("rod_end", rod, rod_end, pin.FrameType.OP_FRAME), False)
    slider_pin_frame = model.addFrame(
        pin.Frame("slider_pin", slider, pin.SE3.Identity(), pin.FrameType.OP_FRAME), False
    )
    model.gravity = pin.Motion(np.asarray(case.loads.gravity, float), np.zeros(3))

    constraint = pin.RigidConstraintModel(
        pin.ContactType.CONTACT_3D, model, rod, rod_end, slider, pin.SE3.Identity(), pin.ReferenceFrame.LOCAL
    )
    constraint.name = "joint3_ball"

    (q_crank, v_crank), (q_rod, v_rod), (q_slider, v_slider) = (
        _coordinates(model, j) for j in (crank, rod, slider))
    return PinocchioSliderCrank(
        model=model, constraint=constraint, crank_joint=crank, rod_joint=rod, slider_joint=slider,
        rod_end_frame=rod_end_frame, slider_pin_frame=slider_pin_frame,
        q_crank=q_crank, q_rod=q_rod, q_slider=q_slider, v_crank=v_crank, v_rod=v_rod, v_slider=v_slider,
        a1=a1, a2=a2, k4=k4, F=F, nc=model.nvs[crank], universal=case.joints.universal,
    )


def _crank_joint(model: pin.Model, case: Case) -> int:
    """Joint 1: ``RZ`` then ``PZ`` (cylindrical; the crank frame at ``(0, 0, S1)``, axes ``Rz(theta1)``), or
    ``RZ`` alone placed at ``(0, 0, S1)`` (revolute, ``S1 = crank_axial_shift``)."""
    if case.joints.crank == "revolute":
        at = pin.SE3(np.eye(3), np.array([0.0, 0.0, float(case.geometry.crank_axial_shift)]))
        return model.addJoint(0, pin.JointModelRZ(), at, "joint1_revolute")
    cylindrical = pin.JointModelComposite(2)
    cylindrical.addJoint(pin.JointModelRZ())
    cylindrical.addJoint(pin.JointModelPZ())
    return model.addJoint(0, cylindrical, pin.SE3.Identity(), "joint1_cylindrical")


def _coordinates(model: pin.Model, joint: int) -> tuple[slice, slice]:
    """The slices of joint ``joint``'s coordinates in ``q`` and in ``v``."""
    q0, v0 = model.idx_qs[joint], model.idx_vs[joint]
    return slice(q0, q0 + model.nqs[joint]), slice(v0, v0 + model.nvs[joint])
