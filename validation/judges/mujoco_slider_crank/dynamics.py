"""The rigid MuJoCo judge's rates, efforts and joint wrenches (steps 2-4 of
:mod:`~dualmech.validation.judges.mujoco_slider_crank.engine`).

Rates from the closure and, with a ball at P3, the rod's zero-spin gauge (drift from ``mj_jacDot``; a
universal joint's hinges determine the spin: no gauge); efforts by least squares on
:math:`M\\ddot q + c = \\tau + J_c^T \\lambda` (``mj_rne``); joint wrenches from
``mj_rnePostConstraint`` with :math:`\\lambda` in ``efc_force``.
"""

from __future__ import annotations

import mujoco
import numpy as np

from dualmech.validation.judges.mujoco_slider_crank.closure import MjLoop, gap_jacobian, rod_axis


def rate_rows(lp: MjLoop) -> tuple[np.ndarray, np.ndarray]:
    """Rows of the rate equations, (4, nv) (closure, spin gauge) or (3, nv) (universal joint: closure),
    and the rod's ``J_omega`` (3, nv)."""
    jr = np.empty((3, lp.model.nv))
    mujoco.mj_jacBody(lp.model, lp.data, None, jr, lp.rod)
    if lp.universal:
        return gap_jacobian(lp), jr
    rows = np.vstack([gap_jacobian(lp), rod_axis(lp) @ jr])
    return rows, jr


def solve_rates(lp: MjLoop, rows: np.ndarray, known: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Rates ``x`` (nv,) with ``x[crank dofs] = known`` and ``rows @ x = rhs``."""
    x = np.zeros(lp.model.nv)
    x[lp.crank_dofs] = known
    x[lp.free] = np.linalg.solve(rows[:, lp.free], rhs - rows @ x)
    return x


def drift(lp: MjLoop) -> np.ndarray:
    """:math:`[\\dot J_c \\dot q;\\ u^T \\dot J_\\omega \\dot q]`, shape (4,), at the current ``qvel``
    (mj_jacDot); :math:`\\dot J_c \\dot q` (3,) alone with a universal joint."""
    m, d = lp.model, lp.data
    nv = m.nv
    jp, je, jr = np.empty((3, nv)), np.empty((3, nv)), np.empty((3, nv))
    mujoco.mj_jacDot(m, d, jp, None, d.site_xpos[lp.site1], m.site_bodyid[lp.site1])
    mujoco.mj_jacDot(m, d, je, None, d.site_xpos[lp.site2], m.site_bodyid[lp.site2])
    v = d.qvel
    if lp.universal:
        return (jp - je) @ v
    mujoco.mj_jacDot(m, d, None, jr, d.xpos[lp.rod], lp.rod)
    return np.concatenate([(jp - je) @ v, [rod_axis(lp) @ (jr @ v)]])


def efforts(lp: MjLoop, mode: str, given: float) -> np.ndarray:
    """Connect force by least squares on :math:`M\\ddot q + c = \\tau + J_c^T\\lambda`.

    Unknown besides :math:`\\lambda`: the crank's axial force (cylindrical crank) and the slider effort
    (torque mode) or the drive torque (force mode); the rod's joints carry no effort.  The rows of the
    angular dofs (crank angle, the rod's ball or hinges; F·L) are divided by ``a2``, so that every row is a
    force and the fit weighs them alike in any length unit.  Returns ``lam`` (3,), the force on the connect's
    site1 body (world axes); uses ``qacc``/``qvel`` of ``data`` (``mj_rne`` reads ``qacc``: nothing may
    overwrite it in between).
    """
    m, d = lp.model, lp.data
    nv = m.nv
    lhs = np.empty(nv)
    mujoco.mj_rne(m, d, 1, lhs)
    jc = gap_jacobian(lp)
    va = lp.vadr
    e_angle, e_stroke = np.zeros(nv), np.zeros(nv)
    e_angle[va[0]], e_stroke[va[3]] = 1.0, -1.0  # slide axis is -k4
    axial = [np.eye(nv)[va[1]]] if va[1] >= 0 else []  # an effort of the cylindrical crank only
    w = np.ones(nv)
    w[[va[0], *lp.rod_dofs]] = 1.0 / lp.a2  # angular rows: F·L -> F
    unknown, known = ([*axial, e_stroke], e_angle) if mode == "torque" else ([e_angle, *axial], e_stroke)
    a = np.column_stack([jc.T, *unknown])
    x = np.linalg.lstsq(a * w[:, None], (lhs - given * known) * w, rcond=None)[0]
    return x[:3]


def joint_wrenches(lp: MjLoop) -> dict[str, float]:
    """Joint wrenches in the project's convention from MuJoCo's current ``efc_force`` and ``cfrc_int``.

    Call after ``mj_rnePostConstraint``.  ``cfrc_int[b]`` is [torque; force] exerted on
    body ``b`` by its parent, world axes, moment about ``subtree_com[body_rootid[b]]``
    (here the ``ground`` body's subtree: the mechanism's centre of mass); moments are
    moved to O (joint 1) and P3 (joints 3 and 4) with :math:`m_P = m_c + (c - P)\\times f`.
    ``efc_force`` of the connect's 3 rows is the force on site1's body.  Ball at P3: the connect is
    joint 3 (site1 = the slider's pin: the force of the rod on the slider), the rod's parent the crank
    (joint 2), ``j3_m = 0``.  Universal joint: the connect is joint 2 (site1 = the rod's start: the force
    of the crank on the rod), the rod's parent the slider, so joint 3 (force and the hinges' constraint
    moment about P3) is minus the rod's ``cfrc_int``.
    """
    m, d = lp.model, lp.data
    ref = d.subtree_com[m.body_rootid[lp.crank]]
    p3 = d.site_xpos[lp.site_pin]

    def moved(body: int, point: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        torque, force = d.cfrc_int[body, :3], d.cfrc_int[body, 3:]
        return force.copy(), torque + _cross(ref - point, force)

    f1, m1 = moved(lp.crank, np.zeros(3))
    if lp.universal:
        on_rod, at_p3 = moved(lp.rod, p3)  # the slider's action on the rod through the two hinges
        f2, f3, m3 = d.efc_force[:3].copy(), -on_rod, -at_p3
    else:
        f2 = d.cfrc_int[lp.rod, 3:].copy()
        f3 = d.efc_force[:3].copy()  # the connect's rows are the only constraint rows
        m3 = np.zeros(3)
    f4, m4 = moved(lp.slider, p3)
    out = {}
    for name, vec in (("j1_f", f1), ("j1_m", m1), ("j2_f", f2), ("j3_f", f3), ("j3_m", m3), ("j4_f", f4),
                      ("j4_m", m4)):
        for axis, value in zip("xyz", vec):
            out[name + axis] = float(value)
    out["slider_load"] = float(lp.k4 @ f4)
    out["drive_torque"] = out["j1_mz"]
    return out


def wrenches(lp: MjLoop, lam: np.ndarray) -> dict[str, float]:
    """Rigid joint wrenches: the connect force ``lam`` into ``efc_force``, then ``mj_rnePostConstraint``."""
    lp.data.efc_force[:3] = lam
    mujoco.mj_rnePostConstraint(lp.model, lp.data)
    return joint_wrenches(lp)


def transmission(lp: MjLoop) -> float:
    """:math:`t = z\\cdot((P_2 - (0,0,S_1))\\times u)/a_1` at the current pose."""
    arm = lp.data.xpos[lp.rod] - lp.data.xpos[lp.crank]
    u = rod_axis(lp)
    return float((arm[0] * u[1] - arm[1] * u[0]) / lp.a1)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a x b`` for two 3-vectors (numpy.cross costs ~10 us a call)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])
