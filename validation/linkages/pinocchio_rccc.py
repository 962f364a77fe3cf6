"""The RCCC judged by Pinocchio: the three cylinders as a tree from the ground, cut at the input revolute.

::

    universe ──[C4: RZ+PZ at X(-alpha41 - eps a41), q = (-theta4, -s4)]──> output link
               ──[C3: RZ+PZ at X(-alpha34 - eps a34), q = (-theta3, -s3)]──> coupler
               ──[C2: RZ+PZ at X(-alpha23 - eps a23), q = (-theta2, -s2)]──> input link
                    · frame "input" at X(-alpha12 - eps a12) = the input link's body frame

The loop's table read backwards (``docs/conventions.md``, "RCCC").  The input revolute, whose
angle is prescribed, is the cut: the frame "input" must sit at ``(0, 0, s1)`` with axes
``Rz(theta1)`` (6 equations, 6 coordinates).  Per position: Newton on that pose error (world
Jacobian), rates and accelerations from the same Jacobian with the drift of the frame's classical
acceleration, ``rnea``, the cut wrench from ``tau0 = S^T tau + J^T w`` (the cylinders carry no effort
but the output torque), and the joint wrenches from ``data.f`` less the cut wrench.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from dualmech.models.linkages.rccc_case import RcccCase
from dualmech.models.linkages.table import LinkageTable
from dualmech.validation.linkages.judges import (
    JUDGE_MAX_ITER,
    JudgeAnswer,
    cut_efforts,
    cut_tolerance,
    pose_error,
    rccc_judge_table,
    rccc_transmission,
    rccc_values,
)
from dualmech.validation.linkages.pinocchio_rssr import pin_inertia

LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


@dataclass(frozen=True)
class PinocchioRccc:
    """The model, its data, the joints (output, coupler, input side: C4, C3, C2), the frame "input" and
    the body placements of the output link and the coupler in their joints' frames."""

    model: pin.Model
    data: pin.Data
    joints: tuple[int, int, int]
    input_frame: int
    body_at: tuple[pin.SE3, pin.SE3]


def _x(alpha: float, a: float) -> pin.SE3:
    """``X(-alpha - eps a)``: rotation ``Rx(-alpha)``, translation ``(-a, 0, 0)``."""
    c, s = np.cos(alpha), np.sin(alpha)
    return pin.SE3(np.array([[1.0, 0.0, 0.0], [0.0, c, s], [0.0, -s, c]]), np.array([-a, 0.0, 0.0]))


def build_model(case: RcccCase) -> PinocchioRccc:
    """The Pinocchio model of ``case`` (module docstring)."""
    g = case.geometry
    model = pin.Model()
    model.name = "rccc"
    placements = [_x(g.alpha[3], g.a[3]), _x(g.alpha[2], g.a[2]), _x(g.alpha[1], g.a[1]),
                  _x(g.alpha[0], g.a[0])]
    parent, joints = 0, []
    for k, body in enumerate((case.bodies[2], case.bodies[1], case.bodies[0])):
        cylinder = pin.JointModelComposite(2)
        cylinder.addJoint(pin.JointModelRZ())
        cylinder.addJoint(pin.JointModelPZ())
        parent = model.addJoint(parent, cylinder, placements[k], f"joint{4 - k}_cylindrical")
        model.appendBodyToJoint(parent, pin_inertia(body), placements[k + 1])
        joints.append(parent)
    frame = model.addFrame(pin.Frame("input", parent, placements[3], pin.FrameType.OP_FRAME), False)
    model.gravity = pin.Motion(np.asarray(case.gravity, float), np.zeros(3))
    return PinocchioRccc(model, model.createData(), tuple(joints), frame, (placements[1], placements[2]))


def _error(pr: PinocchioRccc, q: np.ndarray, theta1: float, s1: float) -> tuple[np.ndarray, np.ndarray]:
    """Pose error of the frame "input" (world, :func:`~dualmech.validation.linkages.judges.pose_error`) and
    its world Jacobian ``(6, 6)``."""
    model, data = pr.model, pr.data
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    placement = data.oMf[pr.input_frame]
    jac = pin.getFrameJacobian(model, data, pr.input_frame, LWA)
    return pose_error(placement.rotation, placement.translation, theta1, s1), jac


def _axes(pr: PinocchioRccc, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The cylinders' axes ``z2, z3, z4`` and the frame "input"'s x axis at ``q``, world."""
    pin.framesForwardKinematics(pr.model, pr.data, q)
    c4, c3, c2 = pr.joints
    z2, z3, z4 = (pr.data.oMi[j].rotation[:, 2].copy() for j in (c2, c3, c4))
    return z2, z3, z4, pr.data.oMf[pr.input_frame].rotation[:, 0].copy()


def _wanted(pr: PinocchioRccc, theta1: float) -> np.ndarray:
    """The axis ``z2`` of the input cylinder when the frame "input" has the prescribed axes ``Rz(theta1)``."""
    c, s = np.cos(theta1), np.sin(theta1)
    at = pr.model.frames[pr.input_frame].placement.rotation  # the frame in its joint's (C2's) frame
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ at[2]


def _close(pr: PinocchioRccc, q: np.ndarray, theta1: float, case: RcccCase
           ) -> tuple[np.ndarray, bool, float, int]:
    """Newton on the cut's pose error; returns ``q``, converged, the gap and the iterations."""
    size = case.geometry.size
    for it in range(JUDGE_MAX_ITER + 1):
        err, jac = _error(pr, q, theta1, case.geometry.s1)
        gap = max(np.linalg.norm(err[:3]), size * np.linalg.norm(err[3:]))
        if gap <= cut_tolerance(size, q):
            return q, True, float(gap), it
        if it < JUDGE_MAX_ITER:
            q = pin.integrate(pr.model, q, np.linalg.solve(jac, err))
    return q, False, float(gap), JUDGE_MAX_ITER


def _position(pr: PinocchioRccc, case: RcccCase, theta1: float, w: float, wd: float,
              start: np.ndarray) -> JudgeAnswer:
    model, data = pr.model, pr.data
    q, ok, gap, iterations = _close(pr, np.array(start, dtype=float), theta1, case)
    _, jac = _error(pr, q, theta1, case.geometry.s1)
    v = np.linalg.solve(jac, np.array([0.0, 0.0, 0.0, 0.0, 0.0, w]))  # the input turns about z, origin fixed
    pin.forwardKinematics(model, data, q, v, np.zeros(model.nv))
    drift = pin.getFrameClassicalAcceleration(model, data, pr.input_frame, LWA).vector
    a = np.linalg.solve(jac, np.array([0.0, 0.0, 0.0, 0.0, 0.0, wd]) - drift)
    pin.forwardKinematics(model, data, q, v, a)
    tau0 = pin.rnea(model, data, q, v, a).copy()
    cut, fit = cut_efforts(case, tau0, jac)
    p1 = data.oMf[pr.input_frame].translation.copy()
    cut_o = np.concatenate([cut[:3], cut[3:] + np.cross(p1, cut[:3])])  # on the input link, about O
    f0 = [data.oMi[j].act(data.f[j]).vector.copy() - cut_o for j in pr.joints]  # parent on child subtree
    c4, c3, _ = pr.joints
    link3, link2 = ((data.oMi[j] * at).translation for j, at in ((c4, pr.body_at[0]), (c3, pr.body_at[1])))
    ground = np.array([-case.geometry.a[3], 0.0, 0.0])
    wrenches = {"j1_f": cut_o[:3], "j1_m": cut_o[3:], "j2_f": -f0[2][:3],
                "j2_m": -(f0[2][3:] - np.cross(link2, f0[2][:3])), "j3_f": -f0[1][:3],
                "j3_m": -(f0[1][3:] - np.cross(link3, f0[1][:3])), "j4_f": f0[0][:3],
                "j4_m": f0[0][3:] - np.cross(ground, f0[0][:3])}
    z2, z3, z4 = (data.oMi[j].rotation[:, 2] for j in (pr.joints[2], pr.joints[1], pr.joints[0]))
    t = rccc_transmission(z2, z3, z4, case)
    return JudgeAnswer(ok, float(-q[0]), np.nan, t, gap, rccc_values(q, v, a, fit, wrenches, z4), q.copy(),
                       iterations)


def solve_pinocchio_rccc(case: RcccCase) -> LinkageTable:
    """Every position of ``case`` judged by Pinocchio, as the common table (engine ``"pinocchio"``)."""
    pr = build_model(case)
    return rccc_judge_table(case, "pinocchio", lambda q: _axes(pr, q), lambda th: _wanted(pr, th),
                            lambda th, w, wd, start: _position(pr, case, th, w, wd, start))
