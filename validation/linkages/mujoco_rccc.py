"""The RCCC's rigid MuJoCo answer per position, the simulated judge's initial state
(:mod:`~dualmech.validation.linkages.mujoco_rccc_sim`): the MJCF of
:func:`~dualmech.validation.linkages.mjcf_rssr.rccc_mjcf`.  The ``mujoco`` engine of an RCCC case is the
generated judge of its joint table (:mod:`dualmech.validation.judges.presets`).

The loop cut at the input revolute: Newton on the pose error of the site "input" (``mj_jacSite``), rates
and accelerations from the same Jacobian with the drift of ``mj_jacDot``; ``mj_rne`` for
:math:`M\\ddot q + c`, the cut wrench from :math:`M\\ddot q + c = S^T\\tau + J^T w`; then ``w`` applied
to the input link (``xfrc_applied``) and the joint wrenches read from ``cfrc_int`` after
``mj_rnePostConstraint``.  MuJoCo has no revolute equality, and its constraint solver is soft: the rigid
judge uses neither.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from dualmech.models.linkages.rccc_case import RcccCase
from dualmech.validation.linkages.judges import (
    JUDGE_MAX_ITER,
    JudgeAnswer,
    cfrc_about,
    cut_efforts,
    cut_tolerance,
    pose_error,
    rccc_transmission,
    rccc_values,
)
from dualmech.validation.linkages.mjcf_rssr import rccc_mjcf


@dataclass(frozen=True)
class MjRccc:
    """Compiled model and data; bodies ``output, coupler, input`` (links 3, 2, 1) and the site."""

    model: mujoco.MjModel
    data: mujoco.MjData
    output: int
    coupler: int
    input: int
    site: int


def build(case: RcccCase) -> MjRccc:
    """Compile :func:`~dualmech.validation.linkages.mjcf_rssr.rccc_mjcf` of ``case``."""
    model = mujoco.MjModel.from_xml_string(rccc_mjcf(case))
    return MjRccc(model, mujoco.MjData(model), model.body("output_link").id, model.body("coupler").id,
                  model.body("input_link").id, model.site("input").id)


def _error(mr: MjRccc, theta1: float, s1: float) -> tuple[np.ndarray, np.ndarray]:
    """Pose error of the site (world) and its Jacobian ``(6, nv)`` (linear rows first), current ``qpos``."""
    m, d = mr.model, mr.data
    mujoco.mj_kinematics(m, d)
    mujoco.mj_comPos(m, d)
    jac = np.empty((6, m.nv))
    mujoco.mj_jacSite(m, d, jac[:3], jac[3:], mr.site)
    return pose_error(d.site_xmat[mr.site].reshape(3, 3), d.site_xpos[mr.site], theta1, s1), jac


def _axes(mr: MjRccc, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The cylinders' axes ``z2, z3, z4`` (the bodies' z) and the site's x axis at ``qpos = q``, world."""
    m, d = mr.model, mr.data
    d.qpos[:] = q
    mujoco.mj_kinematics(m, d)
    z2, z3, z4 = (d.xmat[b].reshape(3, 3)[:, 2].copy() for b in (mr.input, mr.coupler, mr.output))
    return z2, z3, z4, d.site_xmat[mr.site].reshape(3, 3)[:, 0].copy()


def _wanted(mr: MjRccc, theta1: float) -> np.ndarray:
    """The axis ``z2`` of the input cylinder when the site has the prescribed axes ``Rz(theta1)``."""
    at = np.empty(9)
    mujoco.mju_quat2Mat(at, mr.model.site_quat[mr.site])  # the site in its body's (the input link's) frame
    c, s = np.cos(theta1), np.sin(theta1)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ at.reshape(3, 3)[2]


def _close(mr: MjRccc, theta1: float, case: RcccCase) -> tuple[bool, float, int]:
    """Newton on the cut's pose error from ``qpos``; returns converged, the gap, the iterations."""
    size = case.geometry.size
    for it in range(JUDGE_MAX_ITER + 1):
        err, jac = _error(mr, theta1, case.geometry.s1)
        gap = max(np.linalg.norm(err[:3]), size * np.linalg.norm(err[3:]))
        if gap <= cut_tolerance(size, mr.data.qpos):
            return True, float(gap), it
        if it < JUDGE_MAX_ITER:
            mujoco.mj_integratePos(mr.model, mr.data.qpos, np.linalg.solve(jac, err), 1.0)
    return False, float(gap), JUDGE_MAX_ITER


def _point(mr: MjRccc, body: int, x: float) -> np.ndarray:
    """World position of ``(x, 0, 0)`` of ``body``'s frame before its own joints move it (the table's frame
    of the link below, on that link's first axis)."""
    d = mr.data
    return d.xpos[body] + d.xmat[body].reshape(3, 3) @ np.array([x, 0.0, 0.0])


def _moved(mr: MjRccc, body: int, point: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``cfrc_int`` of ``body`` (force, moment about ``point``), world axes."""
    return cfrc_about(mr.data, body, mr.data.subtree_com[mr.model.body_rootid[body]], point)


def _position(mr: MjRccc, case: RcccCase, theta1: float, w: float, wd: float, start: np.ndarray
              ) -> JudgeAnswer:
    g, m, d = case.geometry, mr.model, mr.data
    d.qpos[:] = start
    ok, gap, iterations = _close(mr, theta1, case)
    _, jac = _error(mr, theta1, g.s1)
    d.qvel[:] = np.linalg.solve(jac, np.array([0.0, 0.0, 0.0, 0.0, 0.0, w]))
    mujoco.mj_forward(m, d)
    jdot = np.empty((6, m.nv))
    mujoco.mj_jacDot(m, d, jdot[:3], jdot[3:], d.site_xpos[mr.site], mr.input)
    qacc = np.linalg.solve(jac, np.array([0.0, 0.0, 0.0, 0.0, 0.0, wd]) - jdot @ d.qvel)
    d.qacc[:] = qacc
    bias = np.empty(m.nv)
    mujoco.mj_rne(m, d, 1, bias)
    cut, fit = cut_efforts(case, bias, jac)
    site = d.site_xpos[mr.site].copy()
    about_com = cut[3:] + np.cross(site - d.xipos[mr.input], cut[:3])
    d.xfrc_applied[mr.input] = np.concatenate([cut[:3], about_com])
    mujoco.mj_rnePostConstraint(m, d)
    d.xfrc_applied[:] = 0.0
    (f4, m4), (f3, m3), (f2, m2) = (_moved(mr, b, p) for b, p in (
        (mr.output, np.array([-g.a[3], 0.0, 0.0])), (mr.coupler, _point(mr, mr.output, -g.a[2])),
        (mr.input, _point(mr, mr.coupler, -g.a[1]))))
    wrenches = {"j1_f": cut[:3], "j1_m": cut[3:] + np.cross(site, cut[:3]), "j2_f": -f2, "j2_m": -m2,
                "j3_f": -f3, "j3_m": -m3, "j4_f": f4, "j4_m": m4}
    z2, z3, z4 = (d.xmat[b].reshape(3, 3)[:, 2].copy() for b in (mr.input, mr.coupler, mr.output))
    values = rccc_values(d.qpos[:2], d.qvel[:2], qacc[:2], fit, wrenches, z4)
    return JudgeAnswer(ok, float(-d.qpos[0]), np.nan, rccc_transmission(z2, z3, z4, case), gap, values,
                       d.qpos.copy(), iterations)

