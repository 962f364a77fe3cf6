"""Pinocchio judge, passes 2-4: rates, ``rnea`` and the closed loop's inverse dynamics
(thesis method, steps 2-4 of :mod:`~dualmech.validation.judges.pinocchio_slider_crank.engine`).

Rates solve :math:`[J_c; s^T] \\dot q = 0` and the same with the drift for :math:`\\ddot q`
(:func:`rates_and_rnea`); ``rnea`` gives :math:`\\tau_0 = M\\ddot q + b`; and
:math:`\\tau_0 = S^T\\tau + J_c^T\\lambda` is solved in the least-squares sense for the unknown
efforts and the closure force :math:`\\lambda` (:func:`closed_loop_inverse_dynamics`).

With a universal joint at P3, :math:`s^T` is the joint's row :math:`n^T J_\\omega` (``n = a_r x k4``,
the rate form of ``e·k4 = 0``, :mod:`~dualmech.validation.judges.pinocchio_slider_crank.model`), its drift
:math:`\\dot\\omega\\cdot n + \\omega\\cdot((\\omega\\times e)\\times k_4)` (the second derivative of
``e·k4``), and the inverse dynamics gains its multiplier :math:`\\mu`:
:math:`\\tau_0 = S^T\\tau + J_c^T\\lambda + (n^T J_\\omega)^T\\mu`, the moment :math:`\\mu n` of the slider
on the rod.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from dualmech.core.motion import CrankState
from dualmech.models.case import Case
from dualmech.validation.judges.pinocchio_slider_crank.closure import LWA, Closure
from dualmech.validation.judges.pinocchio_slider_crank.model import PinocchioSliderCrank


def rates_and_rnea(closure: Closure, case: Case, pos: dict[str, np.ndarray], state: CrankState,
              rows: np.ndarray) -> dict[str, np.ndarray]:
    """Passes 2-3 at the closed positions ``rows``: rates, rnea, joint forces without the closure.

    Velocities are ``K @ (theta1_dot, S1_dot)`` (batched).  Per position:
    ``forwardKinematics(q, v, a0)`` with ``a0`` = crank accelerations only gives the
    drift, ``a_free = -A^{-1} drift``, then ``rnea(q, v, a)`` gives ``tau0`` and
    ``data.f`` (mapped to world axes with the ``data.oMi`` of that same
    ``forwardKinematics``: ``rnea`` itself does not update ``data.oMi``).

    Returns v, a (m, nv), tau0 (m, nv), f0 (m, 3, 6) (crank, rod, slider; world axes, moment
    about O) and the placements p2, p3, u, crank_origin and the universal joint's moment axis
    n = a_r x k4 (a_r the rod's y axis; meaningful with a universal joint only), (m, 3) each.
    """
    model, data, pm = closure.model, closure.data, closure.pm
    fe, fp, rod, crank, slider = (
        pm.rod_end_frame,
        pm.slider_pin_frame,
        pm.rod_joint,
        pm.crank_joint,
        pm.slider_joint,
    )
    oMi, forces, spatial_acc = data.oMi, data.f, data.a
    classical = pin.getFrameClassicalAcceleration
    m, nv, nc = rows.size, model.nv, pm.nc
    q = pos["q"][rows]
    v = np.empty((m, nv))
    a = np.zeros((m, nv))
    v[:, :nc] = np.column_stack([state.theta_dot, state.s_dot])[rows, :nc]
    a[:, :nc] = np.column_stack([state.theta_ddot, state.s_ddot])[rows, :nc]
    v[:, nc:] = np.einsum("nij,nj->ni", pos["K"][rows], v[:, :nc])
    a_inv = np.linalg.inv(pos["AB"][rows, :, nc:])
    tau0 = np.empty((m, nv))
    f0 = np.empty((m, 3, 6))
    geometry = np.empty((m, 5, 3))  # P2, P3, u, crank origin, n
    drift = np.empty(4)
    for k in range(m):
        qk, vk, ak = q[k], v[k], a[k]
        pin.forwardKinematics(model, data, qk, vk, ak)  # ak holds only the crank accelerations here
        drift[:3] = classical(model, data, fe, LWA).linear - classical(model, data, fp, LWA).linear
        if pm.universal:
            drift[3] = _universal_drift(data.v[rod].angular, spatial_acc[rod].angular,
                                        oMi[rod].rotation.T @ pm.k4)
        else:
            drift[3] = spatial_acc[rod].angular[0]
        ak[nc:] = -(a_inv[k] @ drift)
        tau0[k] = pin.rnea(model, data, qk, vk, ak)
        for j, joint in enumerate((crank, rod, slider)):
            world = oMi[joint].act(forces[joint])  # keep the Force alive while its vector is read
            f0[k, j] = world.vector
        rod_placement = oMi[rod]
        geometry[k, 0] = rod_placement.translation
        geometry[k, 1] = oMi[slider].translation
        geometry[k, 2] = rod_placement.rotation[:, 0]
        geometry[k, 3] = oMi[crank].translation
        geometry[k, 4] = np.cross(rod_placement.rotation[:, 1], pm.k4)
    return {"v": v, "a": a, "tau0": tau0, "f0": f0, "p2": geometry[:, 0], "p3": geometry[:, 1],
            "u": geometry[:, 2], "crank_origin": geometry[:, 3], "n": geometry[:, 4]}


def _universal_drift(omega: np.ndarray, alpha: np.ndarray, k4: np.ndarray) -> float:
    """``d²(e·k4)/dt² = alpha·n + omega·((omega x e) x k4)`` with ``e`` the rod's y axis and
    ``n = e x k4``; every vector in rod axes, (3,) each (``omega``, ``alpha``: the rod's absolute angular
    velocity and acceleration)."""
    e = np.array([0.0, 1.0, 0.0])
    return float(alpha @ np.cross(e, k4) + omega @ np.cross(np.cross(omega, e), k4))


def _least_squares(lhs: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Batched least squares ``min |lhs x - rhs|`` by QR; lhs (m, nv, k) of full column rank, rhs (m, nv)."""
    if lhs.shape[0] == 0:
        return np.empty((0, lhs.shape[2]))
    Q, R = np.linalg.qr(lhs)
    qtb = np.einsum("nji,nj->ni", Q, rhs)
    try:
        return np.linalg.solve(R, qtb[..., None])[..., 0]
    except np.linalg.LinAlgError:  # an exactly singular row: solve one by one, NaN where singular
        out = np.full(qtb.shape, np.nan)
        for k in range(R.shape[0]):
            try:
                out[k] = np.linalg.solve(R[k], qtb[k])
            except np.linalg.LinAlgError:
                pass
        return out


def closed_loop_inverse_dynamics(case: Case, pm: PinocchioSliderCrank, tau0: np.ndarray,
                                  jc: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Least-squares solution of ``tau0 = S^T tau + J_c^T lambda (+ J_n^T mu)`` for the unknown efforts,
    lambda and (universal joint) mu.

    The rows of the angular coordinates (crank angle, rod rotations; F·L) are divided by
    ``a2`` so that every row is a force: the least squares then weighs the equations the
    same way in any length unit (a moment row and a force row are otherwise weighed by
    the unit: at micrometre scale the moment rows all but vanish from the fit).

    Parameters
    ----------
    tau0 : numpy.ndarray, shape (m, nv)
        ``M qddot + b`` from ``rnea`` (gravity included).
    jc : numpy.ndarray, shape (m, 3 or 4, nv)
        Closure Jacobian (rod end minus slider pin, world axes), and with a universal joint its
        row ``J_n = n^T J_omega``.

    Returns
    -------
    effort : (m, nv) all joint efforts; lam : (m, 3 or 4) force of the slider on the rod at P3, world
    axes (and mu, the slider's moment on the rod along n); ls_residual : (m,) ``|W (lhs x - rhs)| /
    |W rhs|`` with the row weights ``W``.
    """
    m, nv = tau0.shape
    known, unknown = _effort_split(case, pm)
    tau_known = np.zeros(nv)
    for index, value in known.items():
        tau_known[index] = value
    E = np.zeros((nv, len(unknown)))
    E[unknown, np.arange(len(unknown))] = 1.0
    w = np.ones(nv)
    w[[pm.v_crank.start, *range(pm.v_rod.start, pm.v_rod.stop)]] = 1.0 / pm.a2  # angular rows: F·L -> F
    # (m, nv, unknowns)
    lhs = np.concatenate([np.broadcast_to(E, (m, *E.shape)), np.swapaxes(jc, 1, 2)], axis=2) * w[:, None]
    rhs = (tau0 - tau_known) * w
    x = _least_squares(lhs, rhs)
    ls_res = np.linalg.norm(np.einsum("nij,nj->ni", lhs, x) - rhs, axis=1) / np.maximum(
        np.linalg.norm(rhs, axis=1), np.finfo(float).tiny)
    effort = np.broadcast_to(tau_known, (m, nv)).copy()
    effort[:, unknown] = x[:, : len(unknown)]
    return effort, x[:, len(unknown):], ls_res


def _effort_split(case: Case, pm: PinocchioSliderCrank) -> tuple[dict[int, float], list[int]]:
    """Known efforts {v index: value} and the unknown effort indices, by load mode.

    The rod's ball joint carries zero effort (known); the axial force (cylindrical crank) is always
    unknown.
    Torque mode: drive torque known, slider effort unknown; force mode the reverse.
    The prismatic effort along ``-k4`` is ``-k4·f = -slider_load``.
    """
    theta_i, axial = pm.v_crank.start, list(range(pm.v_crank.start + 1, pm.v_crank.stop))  # S1: cylindrical
    s4_i = pm.v_slider.start
    known = {j: 0.0 for j in range(pm.v_rod.start, pm.v_rod.stop)}
    if case.loads.mode == "torque":
        known[theta_i] = float(case.loads.drive_torque)
        return known, [*axial, s4_i]
    known[s4_i] = -float(case.loads.slider_force)
    return known, [theta_i, *axial]
