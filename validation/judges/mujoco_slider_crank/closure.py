"""The rigid MuJoCo judge's model and loop closure (step 1 of
:mod:`~dualmech.validation.judges.mujoco_slider_crank.engine`).

:func:`build` compiles the MJCF of a case into an :class:`MjLoop`; with ``theta1`` (and ``S1``) set, the
rod's joint coordinates and ``S4`` are found by Newton on the gap of the connect's two sites
:math:`r(q) = x_\\mathrm{site1} - x_\\mathrm{site2}`: with the default joints ``slider_pin - rod_end`` at
P3 (3 equations, 4 unknowns: rod quaternion and ``S4``), with a universal joint ``rod_start - crank_pin``
at P2 (3 equations, 3 unknowns: ``S4`` and the two hinges).  The step is the minimum-norm step of
``mj_jacSite``'s Jacobian, applied with ``mj_integratePos``, from a crude guess made of geometry alone
(:func:`crude_guess`) or from the previous position.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from dualmech.models.case import Case
from dualmech.models.mjcf import (
    MAX_TIMESTEP,
    UNIVERSAL_JOINT_NAMES,
    UNIVERSAL_SITE_NAMES,
    case_to_mjcf,
    default_settings,
    joint_names,
    slider_axis,
    universal_start_axes,
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
    site_pin: int  # slider_pin: P3 on the slider
    site_end: int  # rod_end: P3 on the rod
    site1: int  # the connect's sites: slider_pin, rod_end (ball at P3) or rod_start, crank_pin (universal)
    site2: int
    qadr: np.ndarray  # qpos address of crank_angle, crank_axial (-1: revolute), the rod's first joint, slider
    vadr: np.ndarray  # dof address of the same
    crank_dofs: np.ndarray  # the prescribed dofs: crank_angle (, crank_axial)
    rod_dofs: np.ndarray  # the rod's rotational dofs: rod_ball (3) or the universal joint's hinges (2)
    free: np.ndarray  # the dofs Newton moves: the rod's and slider_stroke
    universal: bool  # the rod meets the slider in a universal joint (the loop is then cut at P2)


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
    universal = case.joints.universal
    names = joint_names(case.joints)
    rod_joint = UNIVERSAL_JOINT_NAMES[0] if universal else "rod_ball"
    jid = [model.joint(n).id if n in names else -1
           for n in ("crank_angle", "crank_axial", rod_joint, "slider_stroke")]
    qadr = np.array([model.jnt_qposadr[j] if j >= 0 else -1 for j in jid])
    vadr = np.array([model.jnt_dofadr[j] if j >= 0 else -1 for j in jid])
    rod_dofs = vadr[2] + np.arange(2 if universal else 3)
    sites = UNIVERSAL_SITE_NAMES if universal else ("slider_pin", "rod_end")
    return MjLoop(
        model=model, data=mujoco.MjData(model),
        a1=case.geometry.crank_length, a2=case.geometry.rod_length, k4=slider_axis(case),
        rod=model.body("rod").id, crank=model.body("crank").id, slider=model.body("slider").id,
        site_pin=model.site("slider_pin").id, site_end=model.site("rod_end").id,
        site1=model.site(sites[0]).id, site2=model.site(sites[1]).id,
        qadr=qadr, vadr=vadr, crank_dofs=vadr[:2][vadr[:2] >= 0], rod_dofs=rod_dofs,
        free=np.append(rod_dofs, vadr[3]), universal=universal,
    )


def _positions(lp: MjLoop) -> None:
    """Kinematics and com-based frames for the current ``qpos`` (what ``mj_jac*`` needs)."""
    mujoco.mj_kinematics(lp.model, lp.data)
    mujoco.mj_comPos(lp.model, lp.data)


def gap_jacobian(lp: MjLoop) -> np.ndarray:
    """:math:`J_c = J_\\mathrm{site1} - J_\\mathrm{site2}` (default joints: ``slider_pin - rod_end``),
    shape (3, nv)."""
    jp = np.empty((3, lp.model.nv))
    je = np.empty((3, lp.model.nv))
    mujoco.mj_jacSite(lp.model, lp.data, jp, None, lp.site1)
    mujoco.mj_jacSite(lp.model, lp.data, je, None, lp.site2)
    return jp - je


def _gap(lp: MjLoop) -> np.ndarray:
    d = lp.data
    return d.site_xpos[lp.site1] - d.site_xpos[lp.site2]


def crank_pin(lp: MjLoop) -> np.ndarray:
    """P2, the crank pin, at the current pose (world, (3,)): the rod's origin when the rod hangs from the
    crank, the site ``crank_pin`` when it hangs from the slider (universal joint)."""
    return lp.data.site_xpos[lp.site2] if lp.universal else lp.data.xpos[lp.rod]


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
    d = crank_pin(lp) - foot
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
    d.qpos[qa[2]:qa[2] + lp.rod_dofs.size + (0 if lp.universal else 1)] = (
        (0.0, 0.0) if lp.universal else (1.0, 0.0, 0.0, 0.0))
    d.qpos[qa[3]] = 0.0
    mujoco.mj_kinematics(lp.model, lp.data)
    foot, axis = slider_line(lp)
    p2 = crank_pin(lp).copy()
    s4 = float((p2 - foot) @ axis) + lp.a2
    target = foot + s4 * axis
    if lp.universal:
        d.qpos[qa[2]:qa[2] + 2] = _universal_angles(lp.k4, (target - p2) / np.linalg.norm(target - p2))
    else:
        direction = d.xmat[lp.crank].reshape(3, 3).T @ (target - p2)  # crank-frame axes
        d.qpos[qa[2]:qa[2] + 4] = _quat_x_to(direction)
    d.qpos[qa[3]] = s4


def _universal_angles(k4: np.ndarray, u: np.ndarray) -> tuple[float, float]:
    """Hinge angles ``(q_k4, q_cross)`` that turn the rod's start direction ``u0`` onto the unit ``u``.

    The rod's axis is ``R(k4, q_k4) R(a_r0, q_cross) u0`` (``models/mjcf.py``: the hinges compose in
    order); turning about ``a_r0 = x x k4`` by ``q`` takes the angle ``psi`` of the rod from ``k4``
    (toward ``x``) to ``psi - q``, so ``q_cross = psi0 - arccos(u·k4)`` with ``psi0 = 3 pi/4`` of ``u0``;
    ``q_k4`` turns ``x`` onto ``u``'s part normal to ``k4`` about ``k4``.
    """
    x, (u0, _) = np.array([1.0, 0.0, 0.0]), universal_start_axes(k4)
    psi0 = math.atan2(float(u0 @ x), float(u0 @ k4))
    normal = u - (u @ k4) * k4
    q_k4 = math.atan2(float(k4 @ np.cross(x, normal)), float(x @ normal))
    return q_k4, psi0 - math.acos(max(-1.0, min(1.0, float(u @ k4))))


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
    """Set the crank's coordinates (``s`` is ignored for a revolute crank, whose ``S1`` is the model's)."""
    lp.data.qpos[lp.qadr[0]] = theta
    if lp.qadr[1] >= 0:
        lp.data.qpos[lp.qadr[1]] = s


def on_branch(lp: MjLoop) -> bool:
    """``(P3 - P2)·k4 < 0`` at the current pose: the assembly branch of ``docs/conventions.md``."""
    return bool((lp.data.site_xpos[lp.site_pin] - crank_pin(lp)) @ lp.k4 < 0.0)


def rod_axis(lp: MjLoop) -> np.ndarray:
    """u = (P3 - P2)/|P3 - P2|, world, shape (3,)."""
    u = lp.data.site_xpos[lp.site_pin] - crank_pin(lp)
    return u / np.linalg.norm(u)


def condition(lp: MjLoop) -> float:
    """The closure condition ``|u·k4|`` of the current pose (:mod:`dualmech.core.assembly`)."""
    return abs(float(rod_axis(lp) @ lp.k4))
