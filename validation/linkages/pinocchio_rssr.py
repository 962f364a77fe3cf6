"""The RSSR judged by Pinocchio: a tree cut at ball 3, closed by a 3D point constraint.

::

    universe ──[joint 1: RZ at (0, 0, s1)]──> input crank
        │                                      └──[joint 2: spherical at (a1, 0, 0)]──> coupler
        │                                                                 · coupler_end (a2, 0, 0)
        └──[joint 4: RZ placed at Q4 with axes G4 = Rx(-alpha4)]──> output crank   ┆ CONTACT_3D (ball 3)
                                                                    · output_pin (a3, 0, 0)

The joint frames are the body frames of ``docs/conventions.md`` ("RSSR"), so the case's mass
properties go in unchanged; ``q = (theta1, quat_xyzw(coupler), phi4)``, ``v = (theta1_dot,
omega_rel(coupler, its axes), phi4_dot)``.  Per position: Newton on the gap between the two
frames (minimum-norm steps, ``pin.integrate``), rates from the gap Jacobian and the zero-spin
gauge, ``rnea``, then ``tau0 = S^T tau + J_c^T lambda`` by least squares (Pinocchio has no
closed-loop inverse dynamics), and the joint wrenches from ``data.f`` with the loop force added.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from dualmech.core.inertia import BodyInertia
from dualmech.models.linkages.rssr_case import RssrCase
from dualmech.models.linkages.table import LinkageTable
from dualmech.validation.linkages.judges import (
    JUDGE_CLOSURE_TOL,
    JUDGE_MAX_ITER,
    JudgeAnswer,
    coupler_start,
    judge_table,
    loop_efforts,
    min_norm_step,
    motion_values,
    transmissions,
    wrench_columns,
)

LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


@dataclass(frozen=True)
class PinocchioRssr:
    """The model, its data, the constraint and the ids: joints ``crank, coupler, output``; frames
    ``end`` (coupler end) and ``pin`` (output pin)."""

    model: pin.Model
    data: pin.Data
    constraint: pin.RigidConstraintModel
    crank: int
    coupler: int
    output: int
    end: int
    pin: int


def pin_inertia(body: BodyInertia) -> pin.Inertia:
    """A case body (mass, com and inertia about it in the body frame) as a ``pin.Inertia``."""
    return pin.Inertia(float(body.mass), np.asarray(body.com, float), np.asarray(body.inertia, float))


def build_model(case: RssrCase) -> PinocchioRssr:
    """The Pinocchio model of ``case`` (module docstring)."""
    g = case.geometry
    model = pin.Model()
    model.name = "rssr"
    crank = model.addJoint(0, pin.JointModelRZ(), pin.SE3(np.eye(3), np.array([0.0, 0.0, g.s1])), "joint1")
    model.appendBodyToJoint(crank, pin_inertia(case.bodies[0]), pin.SE3.Identity())
    at_pin = pin.SE3(np.eye(3), np.array([g.a1, 0.0, 0.0]))
    coupler = model.addJoint(crank, pin.JointModelSpherical(), at_pin, "joint2_ball")
    model.appendBodyToJoint(coupler, pin_inertia(case.bodies[1]), pin.SE3.Identity())
    output = model.addJoint(0, pin.JointModelRZ(), pin.SE3(g.ground_rotation(), g.foot), "joint4")
    model.appendBodyToJoint(output, pin_inertia(case.bodies[2]), pin.SE3.Identity())
    end_at, pin_at = (pin.SE3(np.eye(3), np.array([x, 0.0, 0.0])) for x in (g.a2, g.a3))
    end = model.addFrame(pin.Frame("coupler_end", coupler, end_at, pin.FrameType.OP_FRAME), False)
    pin_frame = model.addFrame(pin.Frame("output_pin", output, pin_at, pin.FrameType.OP_FRAME), False)
    model.gravity = pin.Motion(np.asarray(case.gravity, float), np.zeros(3))
    constraint = pin.RigidConstraintModel(pin.ContactType.CONTACT_3D, model, coupler, end_at, output, pin_at,
                                          pin.ReferenceFrame.LOCAL)
    constraint.name = "joint3_ball"
    return PinocchioRssr(model, model.createData(), constraint, crank, coupler, output, end, pin_frame)


def _pins(pr: PinocchioRssr, theta1: float, phi: float) -> tuple[np.ndarray, np.ndarray]:
    """``P2`` (the coupler's joint) and ``P3`` (the frame "output_pin") at the input angle ``theta1`` and the
    output angle ``phi``, world."""
    q = pin.neutral(pr.model)
    q[0], q[5] = theta1, phi
    pin.framesForwardKinematics(pr.model, pr.data, q)
    return pr.data.oMi[pr.coupler].translation.copy(), pr.data.oMf[pr.pin].translation.copy()


def _start(pr: PinocchioRssr, theta1: float, phi: float) -> np.ndarray:
    """``q`` with the coupler pointed from ``P2`` at the output pin of angle ``phi``."""
    quat = pin.Quaternion(coupler_start(theta1, *_pins(pr, theta1, phi))).coeffs()
    return np.concatenate([[theta1], quat, [phi]])


def _kinematics(pr: PinocchioRssr, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Gap (coupler end minus output pin, world) and its Jacobian ``(3, 5)`` at ``q``."""
    model, data = pr.model, pr.data
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    gap = data.oMf[pr.end].translation - data.oMf[pr.pin].translation
    jac = (pin.getFrameJacobian(model, data, pr.end, LWA)[:3]
           - pin.getFrameJacobian(model, data, pr.pin, LWA)[:3])
    return gap, jac


def _close(pr: PinocchioRssr, q: np.ndarray, a2: float) -> tuple[np.ndarray, bool, float, int]:
    """Newton with minimum-norm steps on the free coordinates (coupler, phi4); returns ``q``, converged,
    the gap and the iterations."""
    for it in range(JUDGE_MAX_ITER):
        gap, jac = _kinematics(pr, q)
        if np.linalg.norm(gap) <= JUDGE_CLOSURE_TOL * a2:
            return q, True, float(np.linalg.norm(gap)), it
        step = np.zeros(pr.model.nv)
        step[1:] = min_norm_step(jac[:, 1:], gap)
        q = pin.integrate(pr.model, q, step)
    gap, _ = _kinematics(pr, q)
    return q, False, float(np.linalg.norm(gap)), JUDGE_MAX_ITER


def _rate_rows(pr: PinocchioRssr, jac: np.ndarray) -> np.ndarray:
    """Gap Jacobian and the zero-spin row (coupler's angular velocity along its x axis = u), ``(4, 5)``."""
    spin = pin.getJointJacobian(pr.model, pr.data, pr.coupler, pin.ReferenceFrame.LOCAL)[3]
    return np.vstack([jac, spin])


def _position(pr: PinocchioRssr, case: RssrCase, theta1: float, w: float, wd: float,
              phi: float) -> JudgeAnswer:
    g, model, data = case.geometry, pr.model, pr.data
    q, ok, gap_norm, iterations = _close(pr, _start(pr, theta1, phi), g.a2)
    _, jac = _kinematics(pr, q)
    rows = _rate_rows(pr, jac)
    v = np.zeros(model.nv)
    v[0] = w
    v[1:] = -np.linalg.solve(rows[:, 1:], rows[:, 0] * w)
    a = np.zeros(model.nv)
    a[0] = wd
    pin.forwardKinematics(model, data, q, v, a)
    classical = pin.getFrameClassicalAcceleration
    gap_drift = classical(model, data, pr.end, LWA).linear - classical(model, data, pr.pin, LWA).linear
    drift = np.concatenate([gap_drift, [data.a[pr.coupler].angular[0]]])
    a[1:] = -np.linalg.solve(rows[:, 1:], drift)  # the drift holds the crank acceleration term already
    pin.forwardKinematics(model, data, q, v, a)
    tau0 = pin.rnea(model, data, q, v, a).copy()
    f0 = {j: data.oMi[j].act(data.f[j]).vector.copy() for j in (pr.crank, pr.coupler, pr.output)}
    lam, fit = loop_efforts(case, tau0, jac)  # lambda: force on the coupler at its end (J_c = J_end - J_pin)
    p2, p3 = data.oMi[pr.coupler].translation.copy(), data.oMf[pr.end].translation.copy()
    loop = np.concatenate([lam, np.cross(p3, lam)])  # lambda at P3 as a wrench about O
    w1, w2, w4 = f0[pr.crank] - loop, f0[pr.coupler] - loop, f0[pr.output] + loop
    t1, t4 = transmissions(p2, p3, case)
    values = wrench_columns(w1[:3], w1[3:], w2[:3], -lam, w4[:3], w4[3:] - np.cross(g.foot, w4[:3]), g.k4)
    values.update(motion_values(q[5], v[4], a[4], fit))
    return JudgeAnswer(ok, float(q[5]), t1, t4, gap_norm, values, float(q[5]), iterations)


def solve_pinocchio(case: RssrCase) -> LinkageTable:
    """Every position of ``case`` judged by Pinocchio, as the common table (engine ``"pinocchio"``)."""
    pr = build_model(case)
    return judge_table(case, "pinocchio", lambda th, phi: _pins(pr, th, phi),
                       lambda th, w, wd, phi: _position(pr, case, th, w, wd, phi))
