"""Rates and constrained inverse dynamics of the judge's closed pose, with every joint's reaction wrench.

**Rates.**  With the prescribed coordinates' rates set, the free ones solve the square system of the cut's
rows and the idle spins' gauge rows (:func:`~.closure.rate_matrix`); the accelerations solve the same matrix
against the rows' drift, read from Pinocchio's forward kinematics with the free accelerations at zero: a
linear row's :math:`b_k\\cdot a_{A'}` (the frame's classical acceleration), an angular row's
:math:`b_k\\cdot(\\alpha\\times u + \\omega\\times(\\omega\\times u))`, a gauge row's local angular
acceleration along the link's x axis, a rotation row's :math:`\\alpha` along its moment (exact at the
closed pose, where the logarithm's Jacobian is the identity).

**Inverse dynamics.**  ``pin.rnea`` gives the tree's generalized forces :math:`\\tau` and the wrench
``data.f`` each joint passes to its subtree.  The loop adds the cut's constraint wrench on link n-1,
:math:`J_c^T\\lambda` (each row's multiplier is the size of its unit wrench, :func:`~.closure.cut_rows`: a
linear row's a force along ``b_k``, an angular row's a moment about :math:`u\\times b_k`), and joint n's
effort (on the ground from link n-1, so minus it on link n-1):

.. math:: \\tau = \\tau_{given} + E\\,x + J_c^T\\lambda + g_{cut}\\,e_{cut}

solved by least squares for :math:`\\lambda` and the solved efforts :math:`x` (the drive's or a load's, a C
drive's axial force); an idle spin's equation is ``0 = 0`` (the link is axisymmetric), so the system has one
row per idle spin more than unknowns and its solution is exact.  The solved effort other than a C drive's
axial force is the *transmission effort*: where its column lies in the span of the others (distance over
the longest column below ``DEAD_CENTRE_TRANSMISSION``, :func:`_transmission`; not over its own length, as
the in-house engine's Newton-Euler column, because a generalized force can vanish: the slider crank's
slider force at its dead centre) the loads cannot be balanced, a dead centre.

Joint ``k``'s wrench on link ``k`` from link ``k-1`` is then ``data.f`` in world axes minus the loop's
wrench on link n-1 (which every subtree holds), joint n's is minus the loop's wrench (it acts on the
ground): the conventions of ``docs/conventions.md``, "Loop tables" (world axes, moments about each joint's
point).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from dualmech.validation.judges.pinocchio_loop.closure import LWA, cut_rows, cut_values, rate_matrix
from dualmech.validation.judges.pinocchio_loop.model import LoopModel


def effort_name(joint: int, coordinate: str) -> str:
    """The column name of joint ``joint``'s (0-based) coordinate, e.g. ``theta1`` (joints from 1)."""
    return f"{coordinate}{joint + 1}"


@dataclass(frozen=True)
class PoseDynamics:
    """Everything the judge says at one closed pose.

    Attributes
    ----------
    coordinates : dict of name -> (value, rate, acceleration)
        Every scalar joint coordinate, the cut joint's included.
    rotations : dict of name -> numpy.ndarray, shape (3, 3)
        Each S joint's rotation (``rotation2`` ...), in the axes of its frame {k} (``docs/conventions.md``,
        "Loop tables"); an idle spin's share is the judge's own (its gauge fixes rates only).
    efforts : dict of name -> float
        Every scalar coordinate's effort on its link from the previous one (given, solved, 0 if passive).
    force, moment, point : numpy.ndarray, shape (n_joints, 3)
        Each joint's wrench on link ``k`` from link ``k-1`` (world axes, moment about its point), the point.
    residual : float
        Relative least-squares residual of the inverse dynamics.
    transmission : float
        The transmission effort's column's distance from the span of the others, over the longest
        column (0: a dead centre, the given loads cannot be balanced).
    """

    coordinates: dict[str, tuple[float, float, float]]
    rotations: dict[str, np.ndarray]
    efforts: dict[str, float]
    force: np.ndarray
    moment: np.ndarray
    point: np.ndarray
    residual: float
    transmission: float


def _drift(lm: LoopModel, wrenches: np.ndarray) -> np.ndarray:
    """The rows' second derivative at the forward kinematics' current ``(q, v, a)`` (module docstring)."""
    model, data = lm.model, lm.data
    pin.updateFramePlacements(model, data)
    acc = pin.getFrameClassicalAcceleration(model, data, lm.cut, LWA)
    omega = pin.getFrameVelocity(model, data, lm.cut, LWA).angular
    rot = data.oMf[lm.cut].rotation
    out = []
    for (kind, i, k), wrench in zip(lm.rows, wrenches):
        axis = lm.ground.rotation[:, k]
        if kind == "lin":
            out.append(axis @ acc.linear)
        elif kind == "ang":
            u = rot[:, i]
            out.append(axis @ (np.cross(acc.angular, u) + np.cross(omega, np.cross(omega, u))))
        else:  # at the closed pose, where Jlog3 = I: the moment's direction is fixed to first order
            out.append(wrench[3:] @ acc.angular)
    out += [data.a[j].angular[0] for j in lm.spins]
    return np.array(out)


def motion(lm: LoopModel, q: np.ndarray, rates: np.ndarray,
           accels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``v`` and ``a`` at the closed pose ``q`` with the prescribed coordinates' ``rates`` and ``accels``
    (order of ``lm.prescribed``): module docstring."""
    _, jac, wrenches = cut_rows(lm, q)
    rows = rate_matrix(lm, jac)
    pres, free = list(lm.prescribed), list(lm.free)
    square = rows[:, free]
    v, a = np.zeros(lm.model.nv), np.zeros(lm.model.nv)
    v[pres], a[pres] = rates, accels
    v[free] = -np.linalg.solve(square, rows[:, pres] @ rates)
    pin.forwardKinematics(lm.model, lm.data, q, v, a)
    a[free] = -np.linalg.solve(square, _drift(lm, wrenches))
    return v, a


def _cut_coordinates(lm: LoopModel) -> dict[str, tuple[float, float, float]]:
    """The cut joint's coordinates from ``A'^-1 B`` and their rates (after the full forward kinematics)."""
    model, data = lm.model, lm.data
    values = cut_values(lm)
    vel = pin.getFrameVelocity(model, data, lm.cut, LWA)
    acc = pin.getFrameClassicalAcceleration(model, data, lm.cut, LWA)
    z = lm.ground.rotation[:, 2]
    n = len(lm.mechanism.joints) - 1
    kind = lm.mechanism.joints[n].type
    out = {}
    if kind in ("R", "C"):
        out["theta"] = (-z @ vel.angular, -z @ acc.angular)
    if kind in ("P", "C"):
        out["s"] = (-z @ vel.linear, -z @ acc.linear)
    if kind == "U":
        z, y, w = data.oMf[lm.cut].rotation[:, 2], lm.ground.rotation[:, 1], vel.angular
        theta_dot = -w @ z
        out["theta"] = (theta_dot, -acc.angular @ z)
        out["eta"] = (-w @ y, -acc.angular @ y - theta_dot * np.cross(w, z) @ y)
    return {effort_name(n, name): (values[effort_name(n, name)], *(float(x) for x in rates))
            for name, rates in out.items()}


def _rotations(lm: LoopModel, q: np.ndarray) -> dict[str, np.ndarray]:
    """Each S joint's rotation (:class:`PoseDynamics`), after the frame placements at ``q``."""
    out = {}
    for k, joint in enumerate(lm.mechanism.joints):
        if joint.type != "S":
            continue
        if k < len(lm.link_joints):
            iq = lm.model.joints[lm.link_joints[k]].idx_q
            out[f"rotation{k + 1}"] = pin.Quaternion(q[iq:iq + 4]).matrix()
        else:
            out[f"rotation{k + 1}"] = lm.data.oMf[lm.cut].actInv(lm.ground).rotation
    return out


def _given_efforts(lm: LoopModel) -> dict[tuple[int, str], float | None]:
    """Every loaded coordinate's effort (``None``: solved): a C drive's slide (a reaction), the drive's, the
    loads; the solved one of the last two (the transmission effort) comes last."""
    mech = lm.mechanism
    d = mech.drive
    given: dict[tuple[int, str], float | None] = {(d.joint, "s"): None} if len(lm.prescribed) == 2 else {}
    given.update({(load.joint, load.coordinate): load.value for load in mech.loads})
    given[(d.joint, d.coordinate)] = d.effort
    return dict(sorted(given.items(), key=lambda item: item[1] is None and item[0] != (d.joint, "s")))


def _transmission(matrix: np.ndarray) -> float:
    """The last column's distance from the others' span over the longest column (QR, module docstring)."""
    r = np.linalg.qr(matrix, mode="r")
    return float(abs(r[-1, -1]) / max(np.linalg.norm(matrix, axis=0).max(), np.finfo(float).tiny))


def _cut_unit(lm: LoopModel, coordinate: str, jac: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Joint n's unit effort on link n-1 (minus a couple about, or a force along ``z_B``): its generalized
    force ``(nv,)`` and its wrench ``(6,)`` (force, moment about ``A'``), world."""
    z = lm.ground.rotation[:, 2]
    if coordinate == "s":
        return -z @ jac[:3], np.r_[-z, np.zeros(3)]
    return -z @ jac[3:], np.r_[np.zeros(3), -z]


def _efforts(lm: LoopModel, tau: np.ndarray, jac_c: np.ndarray, row_wrenches: np.ndarray,
             jac: np.ndarray) -> tuple[dict[str, float], np.ndarray, float, float]:
    """Solve the module docstring's system: every effort by name, the loop's wrench on link n-1 (force,
    moment about ``A'``; world), the relative residual and the transmission."""
    n = len(lm.mechanism.joints) - 1
    columns, known, solved, efforts = [*jac_c], np.zeros(6), [], {}
    tau = tau.copy()
    for (k, name), value in _given_efforts(lm).items():
        if k == n:
            general, wrench = _cut_unit(lm, name, jac)
        else:
            general, wrench = np.zeros(lm.model.nv), np.zeros(6)
            general[lm.coordinates[(k, name)][1]] = 1.0
        if value is None:
            columns.append(general)
            solved.append((effort_name(k, name), wrench))
        else:
            tau -= general * value
            known += wrench * value
            efforts[effort_name(k, name)] = float(value)
    matrix = np.array(columns).T
    x = np.linalg.lstsq(matrix, tau, rcond=None)[0]
    residual = float(np.linalg.norm(matrix @ x - tau) / max(np.linalg.norm(tau), np.finfo(float).tiny))
    m = len(lm.rows)
    loop = known + x[:m] @ row_wrenches
    for value, (name, wrench) in zip(x[m:], solved):
        loop += wrench * value
        efforts[name] = float(value)
    return efforts, loop, residual, _transmission(matrix)


def inverse_dynamics(lm: LoopModel, q: np.ndarray, v: np.ndarray, a: np.ndarray) -> PoseDynamics:
    """Efforts and every joint's wrench at a closed pose and its rates (module docstring)."""
    model, data = lm.model, lm.data
    _, jac_c, row_wrenches = cut_rows(lm, q)
    jac = pin.getFrameJacobian(model, data, lm.cut, LWA)
    pin.forwardKinematics(model, data, q, v, a)
    coordinates = _cut_coordinates(lm)
    tau = pin.rnea(model, data, q, v, a)
    efforts, loop, residual, transmission = _efforts(lm, tau, jac_c, row_wrenches, jac)
    loop[3:] += np.cross(data.oMf[lm.cut].translation, loop[:3])  # about O
    wrenches = np.array([data.oMi[j].act(data.f[j]).vector - loop for j in lm.link_joints] + [-loop])
    point = np.array([data.oMf[f].translation for f in lm.points])
    moment = wrenches[:, 3:] - np.cross(point, wrenches[:, :3])
    for (k, name), (iq, iv) in lm.coordinates.items():
        coordinates[effort_name(k, name)] = (float(q[iq]), float(v[iv]), float(a[iv]))
    for name in coordinates:
        efforts.setdefault(name, 0.0)
    return PoseDynamics(coordinates, _rotations(lm, q), efforts, wrenches[:, :3], moment, point, residual,
                        transmission)


__all__ = ["PoseDynamics", "effort_name", "motion", "inverse_dynamics"]
