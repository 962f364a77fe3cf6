"""The rigid MuJoCo judge's model and loop closure (step 1 of :mod:`~dualmech.validation.mujoco_engine`).

:func:`build` compiles the MJCF of a case into an :class:`MjLoop`; with ``theta1, S1`` set, the rod
quaternion and ``S4`` are found by Newton on the site gap
:math:`r(q) = x_\\mathrm{slider\\_pin} - x_\\mathrm{rod\\_end}` (3 equations, 4 unknowns: the
minimum-norm step of ``mj_jacSite``'s Jacobian, applied with ``mj_integratePos``), from a crude guess
made of geometry alone (:func:`crude_guess`) or from the previous position.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from dualmech.models.case import Case
from dualmech.models.mjcf import (
    MAX_TIMESTEP,
    case_to_mjcf,
    default_settings,
    slider_axis,
)

#: Newton on the site gap: stop below this gap (relative to a2) ...
_CLOSURE_TOL = 1e-15
#: ... or after this many iterations, or when the gap stops shrinking.
_MAX_ITER = 60


@dataclass
class MjLoop:
    """A compiled model of one case and the ids the solvers need (mutable scratch inside)."""

    model: mujoco.MjModel
    data: mujoco.MjData
    a1: float
    a2: float
    k4: np.ndarray  # (3,)
    rod: int  # body ids
    crank: int
    slider: int
    site_pin: int  # slider_pin (site1 of the connect)
    site_end: int  # rod_end (site2)
    qadr: np.ndarray  # qpos address of crank_angle, crank_axial, rod_ball (4), slider_stroke
    vadr: np.ndarray  # dof address of the same (rod_ball: 3 dofs)
    free: np.ndarray  # the 4 dofs Newton moves: rod_ball (3), slider_stroke


def build(case: Case, xml: str | None = None) -> MjLoop:
    """Compile the MJCF of ``case`` (or the given text) and collect the ids.

    The rigid path never steps in time, so its default model carries the settings of
    the ``MAX_TIMESTEP`` step (the time step and servo gains are read by nothing it
    calls): a case whose own simulation step would overflow (``crank_rpm = 1e308``)
    still builds, and its rows are judged ``not_finite`` one by one.
    """
    if xml is None:
        xml = case_to_mjcf(case, default_settings(case, MAX_TIMESTEP))
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    names = ("crank_angle", "crank_axial", "rod_ball", "slider_stroke")
    jid = [model.joint(n).id for n in names]
    qadr = np.array([model.jnt_qposadr[j] for j in jid])
    vadr = np.array([model.jnt_dofadr[j] for j in jid])
    free = np.array([vadr[2], vadr[2] + 1, vadr[2] + 2, vadr[3]])
    return MjLoop(
        model=model, data=data,
        a1=case.geometry.crank_length, a2=case.geometry.rod_length, k4=slider_axis(case),
        rod=model.body("rod").id, crank=model.body("crank").id, slider=model.body("slider").id,
        site_pin=model.site("slider_pin").id, site_end=model.site("rod_end").id,
        qadr=qadr, vadr=vadr, free=free,
    )


def _positions(lp: MjLoop) -> None:
    """Kinematics and com-based frames for the current ``qpos`` (what ``mj_jac*`` needs)."""
    mujoco.mj_kinematics(lp.model, lp.data)
    mujoco.mj_comPos(lp.model, lp.data)


def gap_jacobian(lp: MjLoop) -> np.ndarray:
    """:math:`J_c = J_\\mathrm{slider\\_pin} - J_\\mathrm{rod\\_end}`, shape (3, nv)."""
    jp = np.empty((3, lp.model.nv))
    je = np.empty((3, lp.model.nv))
    mujoco.mj_jacSite(lp.model, lp.data, jp, None, lp.site_pin)
    mujoco.mj_jacSite(lp.model, lp.data, je, None, lp.site_end)
    return jp - je


def _gap(lp: MjLoop) -> np.ndarray:
    d = lp.data
    return d.site_xpos[lp.site_pin] - d.site_xpos[lp.site_end]


def slider_line(lp: MjLoop) -> tuple[np.ndarray, np.ndarray]:
    """Point F and unit direction ``-k4`` of the slider line, read from the model (world)."""
    m = lp.model
    jid = m.dof_jntid[lp.vadr[3]]
    # the slider body hangs from the fixed ground body at the world origin, world-aligned
    foot = m.body_pos[lp.slider] + m.body_pos[m.body_parentid[lp.slider]]
    return foot.copy(), m.jnt_axis[jid].copy()


def reach(lp: MjLoop) -> float:
    """Distance from the crank pin to the slider line minus ``a2`` (> 0: no assembly), current ``qpos``."""
    foot, axis = slider_line(lp)
    d = lp.data.xpos[lp.rod] - foot
    dist2 = max(float(d @ d - (d @ axis) ** 2), 0.0)
    return math.sqrt(dist2) - lp.a2


def crude_guess(lp: MjLoop) -> None:
    """Set rod quaternion and ``S4`` to a rough pose on the dualmech branch (crank joints already set).

    The slider goes one rod length beyond the foot of the perpendicular from the crank
    pin P2 onto the slider line (along ``-k4``, the side where ``(P3 - P2)·k4 < 0``), and
    the rod points from P2 at it.  This guess is from geometry alone, never from a
    closure solution.
    """
    d, qa = lp.data, lp.qadr
    d.qpos[qa[2]:qa[2] + 4] = (1.0, 0.0, 0.0, 0.0)
    d.qpos[qa[3]] = 0.0
    mujoco.mj_kinematics(lp.model, lp.data)
    foot, axis = slider_line(lp)
    p2 = d.xpos[lp.rod].copy()
    s4 = float((p2 - foot) @ axis) + lp.a2
    target = foot + s4 * axis
    direction = d.xmat[lp.crank].reshape(3, 3).T @ (target - p2)  # crank-frame axes
    d.qpos[qa[2]:qa[2] + 4] = _quat_x_to(direction)
    d.qpos[qa[3]] = s4


def _quat_x_to(v: np.ndarray) -> np.ndarray:
    """Unit quaternion (w, x, y, z) turning +x onto the direction of ``v`` (shortest arc)."""
    v = v / np.linalg.norm(v)
    w = 1.0 + v[0]
    if w < 1e-12:  # v = -x: half turn about z
        return np.array([0.0, 0.0, 0.0, 1.0])
    q = np.array([w, 0.0, -v[2], v[1]])
    return q / np.linalg.norm(q)


def close_loop(lp: MjLoop) -> tuple[bool, int, float]:
    """Newton on the site gap from the current ``qpos``; crank joints held.

    Returns
    -------
    converged, iterations, gap
        ``gap`` is :math:`|r|/a_2` at the returned pose.
    """
    m, d = lp.model, lp.data
    dq = np.zeros(m.nv)
    _positions(lp)
    r = _gap(lp)
    gap = float(np.linalg.norm(r)) / lp.a2
    for it in range(1, _MAX_ITER + 1):
        if gap <= _CLOSURE_TOL:
            return True, it - 1, gap
        j = gap_jacobian(lp)[:, lp.free]
        step = -j.T @ np.linalg.solve(j @ j.T, r)  # minimum-norm step of the 3 x 4 system
        dq[:] = 0.0
        dq[lp.free] = step
        mujoco.mj_integratePos(m, d.qpos, dq, 1.0)
        _positions(lp)
        r = _gap(lp)
        new_gap = float(np.linalg.norm(r)) / lp.a2
        if new_gap >= gap and gap < 1e-12:  # at the floor of rounding: stop
            return True, it, min(gap, new_gap)
        gap = new_gap
    return gap < 1e-12, _MAX_ITER, gap


def set_crank(lp: MjLoop, theta: float, s: float) -> None:
    lp.data.qpos[lp.qadr[0]] = theta
    lp.data.qpos[lp.qadr[1]] = s


def on_branch(lp: MjLoop) -> bool:
    """``(P3 - P2)·k4 < 0`` at the current pose: the assembly branch of ``docs/conventions.md``."""
    return bool((lp.data.site_xpos[lp.site_pin] - lp.data.xpos[lp.rod]) @ lp.k4 < 0.0)


def rod_axis(lp: MjLoop) -> np.ndarray:
    """u = (P3 - P2)/|P3 - P2|, world, shape (3,)."""
    u = lp.data.site_xpos[lp.site_pin] - lp.data.xpos[lp.rod]
    return u / np.linalg.norm(u)


def condition(lp: MjLoop) -> float:
    """The closure condition ``|u·k4|`` of the current pose (:mod:`dualmech.core.assembly`)."""
    return abs(float(rod_axis(lp) @ lp.k4))
