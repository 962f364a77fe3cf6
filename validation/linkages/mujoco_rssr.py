"""The RSSR's rigid MuJoCo answer at one input state, the simulated judge's initial state
(:func:`assemble`; :mod:`~dualmech.validation.linkages.mujoco_rssr_sim`): the MJCF of
:mod:`~dualmech.validation.linkages.mjcf_rssr`.  The ``mujoco`` engine of an RSSR case is the generated
judge of its joint table (:mod:`dualmech.validation.judges.presets`).

Newton on the connect's site gap (``mj_jacSite``, minimum-norm steps, ``mj_integratePos``); rates
from the gap Jacobian and the coupler's zero-spin row (``mj_jacBody``), accelerations with the
drift of ``mj_jacDot``; efforts and the connect force by least squares on
:math:`M\\ddot q + c = \\tau + J_c^T\\lambda` (``mj_rne``); joint wrenches from ``cfrc_int`` after
``mj_rnePostConstraint`` with :math:`\\lambda` in ``efc_force``.  MuJoCo's own constraint solver
(soft) is never used: this is the rigid judge.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from dualmech.models.linkages.rssr_case import RssrCase
from dualmech.validation.linkages.judges import (
    JUDGE_CLOSURE_TOL,
    JUDGE_MAX_ITER,
    JudgeAnswer,
    cfrc_about,
    coupler_start,
    judge_answer,
    loop_efforts,
    min_norm_step,
    motion_values,
    rssr_loop,
    transmissions,
    wrench_columns,
)
from dualmech.validation.linkages.mjcf_rssr import rssr_mjcf


@dataclass(frozen=True)
class MjRssr:
    """Compiled model and data with the ids: bodies ``crank, coupler, output``; sites ``pin`` (site1)
    and ``end`` (site2) of the connect."""

    model: mujoco.MjModel
    data: mujoco.MjData
    crank: int
    coupler: int
    output: int
    pin: int
    end: int


def build(case: RssrCase, xml: str | None = None) -> MjRssr:
    """Compile :func:`~dualmech.validation.linkages.mjcf_rssr.rssr_mjcf` of ``case`` (or the MJCF ``xml``)."""
    model = mujoco.MjModel.from_xml_string(rssr_mjcf(case) if xml is None else xml)
    return MjRssr(model, mujoco.MjData(model), model.body("input_crank").id, model.body("coupler").id,
                  model.body("output_crank").id, model.site("output_pin").id, model.site("coupler_end").id)


def _gap(mr: MjRssr) -> tuple[np.ndarray, np.ndarray]:
    """Gap ``x_pin - x_end`` (world) and its Jacobian ``(3, nv)`` at the current ``qpos``."""
    m, d = mr.model, mr.data
    mujoco.mj_kinematics(m, d)
    mujoco.mj_comPos(m, d)
    jp, je = np.empty((3, m.nv)), np.empty((3, m.nv))
    mujoco.mj_jacSite(m, d, jp, None, mr.pin)
    mujoco.mj_jacSite(m, d, je, None, mr.end)
    return d.site_xpos[mr.pin] - d.site_xpos[mr.end], jp - je


def _pins(mr: MjRssr, theta1: float, phi: float) -> tuple[np.ndarray, np.ndarray]:
    """``P2`` (the coupler's origin) and ``P3`` (the site "output_pin") at the input angle ``theta1`` and
    the output angle ``phi``, world (sets ``qpos``)."""
    mr.data.qpos[:] = np.array([theta1, 1.0, 0.0, 0.0, 0.0, phi])
    mujoco.mj_kinematics(mr.model, mr.data)
    return mr.data.xpos[mr.coupler].copy(), mr.data.site_xpos[mr.pin].copy()


def _start(mr: MjRssr, theta1: float, phi: float) -> None:
    """``qpos`` with the coupler pointed from ``P2`` at the output pin of angle ``phi``."""
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, coupler_start(theta1, *_pins(mr, theta1, phi)).reshape(9))
    mr.data.qpos[:] = np.concatenate([[theta1], quat, [phi]])


def _close(mr: MjRssr, a2: float) -> tuple[bool, float, int]:
    """Newton with minimum-norm steps on the coupler ball and the output hinge; returns converged, the gap
    and the iterations."""
    m, d = mr.model, mr.data
    for it in range(JUDGE_MAX_ITER):
        gap, jac = _gap(mr)
        if np.linalg.norm(gap) <= JUDGE_CLOSURE_TOL * a2:
            return True, float(np.linalg.norm(gap)), it
        step = np.zeros(m.nv)
        step[1:] = min_norm_step(jac[:, 1:], gap)
        mujoco.mj_integratePos(m, d.qpos, step, 1.0)
    gap, _ = _gap(mr)
    return False, float(np.linalg.norm(gap)), JUDGE_MAX_ITER


def _rows(mr: MjRssr, jac: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Gap Jacobian with the zero-spin row ``u · omega_coupler``, ``(4, nv)``, and ``u`` (world)."""
    jr = np.empty((3, mr.model.nv))
    mujoco.mj_jacBody(mr.model, mr.data, None, jr, mr.coupler)
    u = mr.data.xmat[mr.coupler].reshape(3, 3)[:, 0].copy()
    return np.vstack([jac, u @ jr]), u


def _drift(mr: MjRssr, u: np.ndarray) -> np.ndarray:
    """``[Jdot_gap qdot; u · Jdot_omega qdot]`` at the current ``qvel`` (``mj_jacDot``)."""
    m, d = mr.model, mr.data
    mujoco.mj_comVel(m, d)
    jp, je, jr = (np.empty((3, m.nv)) for _ in range(3))
    mujoco.mj_jacDot(m, d, jp, None, d.site_xpos[mr.pin], mr.output)
    mujoco.mj_jacDot(m, d, je, None, d.site_xpos[mr.end], mr.coupler)
    mujoco.mj_jacDot(m, d, None, jr, d.xpos[mr.coupler], mr.coupler)
    return np.concatenate([(jp - je) @ d.qvel, [u @ (jr @ d.qvel)]])


def _moved(mr: MjRssr, body: int, point: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``cfrc_int`` of ``body`` (force, moment about ``point``), world axes."""
    return cfrc_about(mr.data, body, mr.data.subtree_com[mr.model.body_rootid[body]], point)


def _position(mr: MjRssr, case: RssrCase, theta1: float, w: float, wd: float, phi: float) -> JudgeAnswer:
    g, m, d = case.geometry, mr.model, mr.data
    _start(mr, theta1, phi)
    ok, gap_norm, iterations = _close(mr, g.a2)
    _, jac = _gap(mr)
    rows, u = _rows(mr, jac)
    d.qvel[:] = 0.0
    d.qvel[0] = w
    d.qvel[1:] = -np.linalg.solve(rows[:, 1:], rows[:, 0] * w)
    qacc = np.zeros(m.nv)
    qacc[0] = wd
    qacc[1:] = -np.linalg.solve(rows[:, 1:], rows[:, 0] * wd + _drift(mr, u))
    mujoco.mj_forward(m, d)  # the connect's constraint rows (efc_*) at this pose
    d.qacc[:] = qacc
    bias = np.empty(m.nv)
    mujoco.mj_rne(m, d, 1, bias)
    lam, fit = loop_efforts(case, bias, jac)
    d.efc_force[:3] = lam  # force on site1's body: the coupler's on the output crank (joint 3)
    mujoco.mj_rnePostConstraint(m, d)
    p2, p3 = d.xpos[mr.coupler].copy(), d.site_xpos[mr.pin].copy()
    (f1, m1), (f4, m4) = _moved(mr, mr.crank, np.zeros(3)), _moved(mr, mr.output, g.foot)
    values = wrench_columns(f1, m1, d.cfrc_int[mr.coupler, 3:].copy(), lam, f4, m4, g.k4)
    values.update(motion_values(d.qpos[5], d.qvel[4], qacc[4], fit))
    t1, t4 = transmissions(p2, p3, case)
    return JudgeAnswer(ok, float(d.qpos[5]), t1, t4, gap_norm, values, float(d.qpos[5]), iterations)


def assemble(mr: MjRssr, case: RssrCase, theta1: float, w: float, wd: float) -> JudgeAnswer:
    """The rigid judge's answer at one input state from its own crude start (no continuation, nothing of the
    in-house solver), leaving ``qpos``, ``qvel`` assembled: e.g. a simulation's initial state."""
    loop = rssr_loop(case, lambda th, phi: _pins(mr, th, phi),
                     lambda th, th_dot, th_ddot, phi: _position(mr, case, th, th_dot, th_ddot, phi))
    return judge_answer(loop, (theta1, w, wd), None, case.branch, case.mode == "torque", case.geometry.a2)[0]

