"""Pinocchio judge: the result table of a case computed by Pinocchio alone.

The model is :func:`~dualmech.validation.pinocchio_model.build_model` (a tree
cut at joint 3, closed by a 3-D point constraint).  Nothing here imports or is
seeded by the in-house solver (``dualmech.models.slider_crank`` / ``dualmech.core``
solvers); only the case record, the crank motion and the table format are shared.

Method, per crank position (``docs/conventions.md`` for every symbol):

1. **Closure** (position).  The residual is the gap between the rod end and the
   slider pin, both Pinocchio frames, in world axes,

   .. math:: r(q) = p_{end}(q) - p_{pin}(q), \\qquad
             J_c = J^{LWA}_{end,lin} - J^{LWA}_{pin,lin}  \\in R^{3\\times 6},

   and Gauss–Newton moves the free coordinates (rod quaternion, ``S4``) by the
   minimum-norm step :math:`\\delta = -J_f^T (J_f J_f^T + \\mu I)^{-1} r`
   (:math:`J_f` = the free columns; :math:`\\mu` tiny, only to bound the step at
   the edge of assembly), integrated on the configuration manifold with
   ``pin.integrate``.  The first position starts from a crude guess (rod aimed at
   the point of the slider line a distance ``a2`` beyond the foot of the
   perpendicular from ``P2``, on the conventions' branch side); later positions
   continue from the previous one with a first-order predictor and at most
   :data:`MAX_STEP_DEG` per step, refining the steps when Newton fails or
   lands on the other branch ``(P3 - P2)·k4 > 0``.
2. **Rates** (velocity, acceleration).  The rod's spin about ``u`` is fixed by
   the zero-spin gauge (conventions "Rod spin"): with :math:`s^T` the rod
   body Jacobian's angular row along the rod x axis (``= u``),

   .. math::
       \\begin{bmatrix} J_c \\\\ s^T \\end{bmatrix} \\dot q = 0, \\qquad
       \\begin{bmatrix} J_c \\\\ s^T \\end{bmatrix} \\ddot q
         + \\begin{bmatrix} a^{cl}_{end} - a^{cl}_{pin} \\\\ \\dot\\omega_{rod,x} \\end{bmatrix}_{\\ddot q_{free}=0} = 0,

   solved for the free rates with the crank rates prescribed; the drift is the
   *classical* acceleration of the two points (``getFrameClassicalAcceleration``)
   and the rod's angular acceleration (``data.a``) with zero free accelerations.
3. **Inverse dynamics with the loop closed**.  ``rnea`` gives
   :math:`\\tau_0 = M\\ddot q + b(q, \\dot q)` (gravity included), and

   .. math:: \\tau_0 = S^T\\tau + J_c^T\\lambda

   is solved in the least-squares sense for the unknown efforts (axial force
   always; the slider effort in torque mode, the drive torque in force mode)
   and :math:`\\lambda`, the force of the slider on the rod at ``P3`` (world
   axes).  The rod's three ball-joint rows carry zero effort; its spin row is
   ``0 = 0`` for the axisymmetric rod.
4. **Joint wrenches**.  ``data.f[i]`` after that ``rnea`` is the wrench of the
   parent on joint i's subtree without the closure force; the closure force
   enters by superposition (checked against ``rnea`` with ``fext`` in the
   tests):

   .. math:: W_1 = f_{crank} - (\\lambda, P_3\\times\\lambda),\\;
             W_2 = f_{rod} - (\\lambda, P_3\\times\\lambda),\\;
             W_4 = f_{slider} + (\\lambda, P_3\\times\\lambda),

   all in world axes about the world origin O; then moved to the documented
   reference points (joint 4 about ``P3``).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
import pinocchio as pin
from scipy.linalg import lapack

from dualmech.core.assembly import edge_status, foot_s4, reach
from dualmech.core.motion import CrankState
from dualmech.core.status import Status, settle
from dualmech.core.table import REACTION_COLUMNS, STATUSES, ResultTable
from dualmech.models.case import Case
from dualmech.validation import tolerances
from dualmech.validation.pinocchio_model import PinocchioSliderCrank, build_model, slider_axis

ENGINE = "pinocchio"

#: Closure tolerance on |r|, relative to the mechanism's length scale a1 + a2 + |a4| + max|S1|:
#: ~50 ulp of the largest coordinate, far below the 1e-10 agreement asked of S4; Newton's quadratic
#: convergence gets there.
CLOSURE_TOLERANCE = 1e-14
#: Gauss-Newton iterations per closure before falling back to Levenberg-Marquardt.
MAX_NEWTON_ITERATIONS = 15
#: Levenberg-Marquardt iterations allowed after that, to converge or find the least-squares minimum.
LM_ITERATIONS = 200
#: Largest continuation step in crank angle; larger gaps between tabulated angles are subdivided.
MAX_STEP_DEG = 5.0
#: When Newton fails or changes branch, the step is split by 4, at most this many times.
STEP_REFINEMENTS = 3
#: Damping mu of the Gauss-Newton step, relative to a2^2: bounds the step at the edge of assembly only.
STEP_DAMPING = 1e-24
#: |J_i·r| <= this * |J_i| |r| for every free column J_i at a non-zero residual: a least-squares minimum,
#: the rod cannot reach the slider line.
STATIONARY_GRADIENT = 1e-6

_LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
_LOCAL = pin.ReferenceFrame.LOCAL

# internal status codes: indices into STATUSES (core/table.py)
_STATUS_WORDS = np.array(STATUSES, dtype=object)
_OK, _DEAD, _LIMIT, _BRANCH, _NOT_CONVERGED, _NO_ASSEMBLY = (STATUSES.index(w) for w in (
    Status.OK, Status.DEAD_CENTRE, Status.ASSEMBLY_LIMIT, Status.BRANCH_JUMP, Status.NOT_CONVERGED, Status.NO_ASSEMBLY))
# coordinate layout of build_model (checked in _Closure): q = (theta1, S1, quat(4), S4), v = (theta1, S1, w(3), S4)
_Q_S4, _V_S4 = 6, 5


@dataclass(frozen=True)
class PinocchioSolution:
    """Everything the Pinocchio path computed for one case, in Pinocchio's coordinates.

    Attributes
    ----------
    q : numpy.ndarray, shape (n, 7)
        Configurations ``(theta1, S1, rod quaternion x y z w, S4)``; the final Newton iterate where failed.
    v, a : numpy.ndarray, shape (n, 6)
        Velocities and accelerations ``(theta1, S1, rod omega rel. crank in rod axes (3), S4)``; NaN where
        the closure failed.
    effort : numpy.ndarray, shape (n, 6)
        Joint efforts ``S^T tau``: drive torque, axial force, 0, 0, 0, prismatic effort (= -slider_load).
    closure_force : numpy.ndarray, shape (n, 3)
        lambda, the force of the slider on the rod at ``P3``, world axes.
    wrench1, wrench2, wrench4 : numpy.ndarray, shape (n, 6)
        Ground on crank, crank on rod, ground on slider: (force, moment about the world origin O), world axes.
    p2, p3, u, crank_origin : numpy.ndarray, shape (n, 3)
        ``P2``, ``P3``, the rod axis and ``(0, 0, S1)``, world axes, from Pinocchio's placements.
    status : numpy.ndarray of int, shape (n,)
        Indices into ``dualmech.core.table.STATUSES``.
    iterations : numpy.ndarray of int, shape (n,)
        Newton iterations of the final attempt at each tabulated position.
    residual : numpy.ndarray, shape (n,)
        ``|p_end - p_pin|`` at the final iterate, length units.
    ls_residual : numpy.ndarray, shape (n,)
        ``|[E, J_c^T] x - b| / |b|`` of the inverse-dynamics least squares.
    condition : numpy.ndarray, shape (n,)
        The closure condition ``|u·k4|`` (``dualmech.core.assembly``), NaN where ``no_assembly``.
    """

    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    effort: np.ndarray
    closure_force: np.ndarray
    wrench1: np.ndarray
    wrench2: np.ndarray
    wrench4: np.ndarray
    p2: np.ndarray
    p3: np.ndarray
    u: np.ndarray
    crank_origin: np.ndarray
    status: np.ndarray
    iterations: np.ndarray
    residual: np.ndarray
    ls_residual: np.ndarray
    condition: np.ndarray


# ----------------------------------------------------------------------------- closure

def _min_norm_step(jc: np.ndarray, r: tuple[float, float, float], mu: float) -> list[float]:
    """Damped minimum-norm Newton step ``x = -J^T (J J^T + mu I)^{-1} r`` on the free columns of ``jc``.

    ``jc`` is the 3x6 closure Jacobian; ``J`` its free columns 2..5 (rod, S4).
    The 3x3 solve is written out (adjugate of the symmetric ``G = J J^T + mu I``)
    because the per-call overhead of ``numpy.linalg.solve`` dominates a 3x3 problem.
    """
    (_, _, a, b, c, d), (_, _, e, f, g, h), (_, _, i, j, k, l) = jc.tolist()
    r0, r1, r2 = r
    s00 = a * a + b * b + c * c + d * d + mu
    s01 = a * e + b * f + c * g + d * h
    s02 = a * i + b * j + c * k + d * l
    s11 = e * e + f * f + g * g + h * h + mu
    s12 = e * i + f * j + g * k + h * l
    s22 = i * i + j * j + k * k + l * l + mu
    c00 = s11 * s22 - s12 * s12
    c01 = s02 * s12 - s01 * s22
    c02 = s01 * s12 - s02 * s11
    c11 = s00 * s22 - s02 * s02
    c12 = s01 * s02 - s00 * s12
    c22 = s00 * s11 - s01 * s01
    det = -(s00 * c00 + s01 * c01 + s02 * c02)  # the minus sign makes x = -J^T G^{-1} r
    if det == 0.0:
        return [math.nan] * 4
    y0 = (c00 * r0 + c01 * r1 + c02 * r2) / det
    y1 = (c01 * r0 + c11 * r1 + c12 * r2) / det
    y2 = (c02 * r0 + c12 * r1 + c22 * r2) / det
    return [a * y0 + e * y1 + i * y2, b * y0 + f * y1 + j * y2, c * y0 + g * y1 + k * y2, d * y0 + h * y1 + l * y2]


class _Closure:
    """Gauss–Newton loop closure on one model/data pair, reused for every position of a case.

    After a converged :meth:`close`, ``self.AB`` (4x6) holds the rate equations
    ``AB qdot = 0`` at the solution (rows: J_c, zero spin); its columns 2..5 are
    ``A`` (free coordinates) and 0..1 are ``B`` (crank coordinates).
    """

    def __init__(self, pm: PinocchioSliderCrank, length_scale: float) -> None:
        self.pm = pm
        self.model = pm.model
        self.data = pm.model.createData()
        self.oMf = self.data.oMf  # a view on data's frame placements, updated in place
        self.tol2 = (CLOSURE_TOLERANCE * length_scale) ** 2
        self.mu = STEP_DAMPING * pm.a2**2
        self.dv = np.zeros(pm.model.nv)
        self.AB = np.empty((4, 6))
        self.condition = math.nan  # |u·k4| at the last converged solution
        layout = (pm.q_crank, pm.q_rod, pm.q_slider, pm.v_crank, pm.v_rod, pm.v_slider)
        if layout != (slice(0, 2), slice(2, 6), slice(6, 7), slice(0, 2), slice(2, 5), slice(5, 6)):
            raise ValueError(f"pinocchio model: unexpected coordinate layout {layout}")

    def _evaluate(self, q: np.ndarray) -> tuple[np.ndarray, tuple[float, float, float], float]:
        """Closure Jacobian (3x6), residual ``p_end - p_pin`` and its squared norm at ``q``."""
        model, data, oMf = self.model, self.data, self.oMf
        fe, fp = self.pm.rod_end_frame, self.pm.slider_pin_frame
        pin.computeJointJacobians(model, data, q)  # also places every joint (data.oMi)
        jc = pin.getFrameJacobian(model, data, fe, _LWA)[:3] - pin.getFrameJacobian(model, data, fp, _LWA)[:3]
        r = (oMf[fe].translation - oMf[fp].translation).tolist()
        return jc, r, r[0] * r[0] + r[1] * r[1] + r[2] * r[2]

    def close(self, q: np.ndarray) -> tuple[np.ndarray, int, int, float]:
        """Newton from ``q`` (its crank coordinates are kept). Returns (q, status code, iterations, |r|).

        Gauss–Newton with the tiny fixed damping; if it has not converged after
        ``MAX_NEWTON_ITERATIONS`` (or the gap grew a hundredfold: no assembly nearby),
        :meth:`_minimize` continues from the best iterate and decides between a
        least-squares minimum with a gap (``no_assembly``) and plain failure (``not_converged``).
        """
        model, dv, tol2, mu = self.model, self.dv, self.tol2, self.mu
        best_q, best_rr = q, math.inf
        for it in range(MAX_NEWTON_ITERATIONS + 1):
            jc, r, rr = self._evaluate(q)
            if rr <= tol2:
                return q, self._converged(jc), it, math.sqrt(rr)
            if rr < best_rr:
                best_q, best_rr = q, rr
            if it == MAX_NEWTON_ITERATIONS or not rr <= 1e4 * best_rr:  # also catches NaN
                break
            dv[2:] = _min_norm_step(jc, r, mu)
            q = pin.integrate(model, q, dv)
        return self._minimize(best_q, it)

    def _minimize(self, q: np.ndarray, it: int) -> tuple[np.ndarray, int, int, float]:
        """Levenberg–Marquardt on |r|^2 from ``q``: converge, or stop at a least-squares minimum.

        Marquardt's scaled damping ``(J_f^T J_f + lm diag(J_f^T J_f)) delta = -J_f^T r``
        (the rod's rotations move the gap by ~a2 per radian, S4 by 1 per length:
        isotropic damping would freeze S4 where the gap's curvature needs a large lm),
        lm x1/3 on success, x4 on failure.  The iterates descend to a stationary point
        of |r|^2; one with ``|r|`` above tolerance and the gap orthogonal to every free
        column (``|J_i·r| <= STATIONARY_GRADIENT |J_i| |r|``) means the rod cannot reach
        the slider line: ``no_assembly``.
        """
        model, dv, tol2 = self.model, self.dv, self.tol2
        jc, r, rr = self._evaluate(q)
        lm = 1e-3
        for extra in range(LM_ITERATIONS + 1):
            if not math.isfinite(rr):
                break
            if rr <= tol2:
                return q, self._converged(jc), it + extra, math.sqrt(rr)
            jf = jc[:, 2:]
            gram = jf.T @ jf
            col2 = np.diag(gram) + 1e-20 * np.max(np.diag(gram))  # floor: the rod's spin column is ~0
            gradient = jf.T @ np.asarray(r)
            if np.all(np.abs(gradient) <= STATIONARY_GRADIENT * np.sqrt(col2 * rr)):
                return q, _NO_ASSEMBLY, it + extra, math.sqrt(rr)
            if extra == LM_ITERATIONS:
                break
            damping = lm * (col2 + 1e-12 * col2.max())
            dv[2:] = -np.linalg.solve(gram + np.diag(damping), gradient)
            trial = pin.integrate(model, q, dv)
            jc_t, r_t, rr_t = self._evaluate(trial)
            if rr_t < rr:
                q, jc, r, rr, lm = trial, jc_t, r_t, rr_t, lm / 3.0
            else:
                lm *= 4.0
                self._evaluate(q)  # restore data to the current iterate
        return q, _NOT_CONVERGED, it + extra, math.sqrt(rr)

    def _converged(self, jc: np.ndarray) -> int:
        """Store the rate equations at the solution; classify the branch."""
        model, data, pm = self.model, self.data, self.pm
        AB = self.AB
        AB[:3] = jc
        AB[3] = pin.getJointJacobian(model, data, pm.rod_joint, _LOCAL)[3]  # rod angular velocity along its x = u
        along = float(data.oMi[pm.rod_joint].rotation[:, 0] @ pm.k4)  # u·k4, u = the rod frame's x axis
        self.condition = abs(along)
        return _OK if along < 0.0 else _BRANCH

    def tangent(self) -> np.ndarray:
        """``d q_free / d (theta1, S1) = -A^{-1} B`` at the last converged solution, shape (4, 2)."""
        _, _, x, info = lapack.dgesv(self.AB[:, 2:], self.AB[:, :2])
        return -x if info == 0 else np.full((4, 2), np.nan)

    def crude_guess(self, theta: float, s1: float, side: float = 1.0) -> np.ndarray:
        """A rough assembly: ``S4`` a rod length beyond the foot of the perpendicular from ``P2``, rod aimed there.

        Uses Pinocchio's placement of the crank pin.  With ``side = +1`` the guess is on
        the conventions' branch side (``(P3 - P2)·k4 = -a2 < 0``), at a distance
        ``>= a2`` from ``P2``; ``side = -1`` mirrors it (tests use that to provoke a branch jump).
        """
        pm, model, data = self.pm, self.model, self.data
        q = pin.neutral(model)
        q[pm.q_crank] = (theta, s1)
        pin.forwardKinematics(model, data, q)
        p2 = data.oMi[pm.rod_joint].translation
        s4 = -float(pm.k4 @ (p2 - pm.F)) + side * pm.a2
        toward = (pm.F - s4 * pm.k4) - p2
        local = data.oMi[pm.crank_joint].rotation.T @ (toward / np.linalg.norm(toward))
        q[pm.q_rod] = pin.Quaternion.FromTwoVectors(np.array([1.0, 0.0, 0.0]), local).coeffs()
        q[pm.q_slider] = s4
        return q

    def step(self, q: np.ndarray, tangent: np.ndarray, crank_to: np.ndarray) -> tuple[np.ndarray, int, int, float]:
        """Predict along ``tangent`` from converged ``q`` to crank coordinates ``crank_to``, then Newton."""
        delta = crank_to - q[:2]
        dv = self.dv
        dv[2:] = tangent @ delta
        q = pin.integrate(self.model, q, dv)
        q[:2] = crank_to
        return self.close(q)


def _s1_at(case: Case, theta: np.ndarray) -> np.ndarray:
    """S1 at crank angles ``theta`` [rad] (for intermediate continuation steps)."""
    return case.motion.state(case.geometry.crank_axial_shift, np.degrees(theta)).s


def _continue(closure: _Closure, case: Case, q0: np.ndarray, tangent: np.ndarray,
              crank_to: np.ndarray) -> tuple[np.ndarray, int, int, float]:
    """Continue a converged ``q0`` to crank coordinates ``crank_to`` in steps of at most MAX_STEP_DEG.

    A step that fails (Newton) or lands on the other branch is retried from ``q0``
    with 4x more steps, at most ``STEP_REFINEMENTS`` times.
    """
    dtheta = crank_to[0] - q0[0]
    base = max(1, math.ceil(abs(math.degrees(dtheta)) / MAX_STEP_DEG - 1e-12))
    for refinement in range(STEP_REFINEMENTS + 1):
        m = base * 4**refinement
        if m == 1:
            waypoints = crank_to[None, :]
        else:
            theta = q0[0] + dtheta * np.arange(1, m + 1) / m
            waypoints = np.column_stack([theta, _s1_at(case, theta)])
            waypoints[-1] = crank_to
        q, t = q0, tangent
        for w, target in enumerate(waypoints):
            if w:
                t = closure.tangent()
            q, code, it, rnorm = closure.step(q, t, target)
            if code != _OK:
                break
        if code == _OK:
            return q, code, it, rnorm
    return q, code, it, rnorm


# ----------------------------------------------------------------------------- passes

def _length_scale(case: Case, state: CrankState) -> float:
    g = case.geometry
    return g.crank_length + g.rod_length + abs(g.slider_offset) + float(np.max(np.abs(state.s), initial=0.0))


def _positions(closure: _Closure, case: Case, state: CrankState) -> dict[str, np.ndarray]:
    """Pass 1 (sequential): close the loop at every tabulated position by continuation.

    Each position continues from the previous closed one (:func:`_continue`); the
    first one, one after a failed position, or one the continuation could not reach
    starts from :meth:`_Closure.crude_guess`, so a status always describes its own
    position.  Returns q (n, 7), the rate equations AB (n, 4, 6) and the tangent
    K = -A^{-1} B (n, 4, 2) at each closed position (NaN elsewhere), status codes,
    Newton iterations, closure residuals |r| and the closure condition |u·k4| (n,) (NaN where not closed).
    """
    n = len(state)
    q_all = np.empty((n, closure.model.nq))
    AB_all = np.full((n, 4, 6), np.nan)
    K_all = np.full((n, 4, 2), np.nan)
    status = np.empty(n, dtype=int)
    iterations = np.empty(n, dtype=int)
    residual = np.empty(n)
    condition = np.full(n, np.nan)
    crank = np.column_stack([state.theta, state.s])
    q_prev, t_prev = None, None
    for i in range(n):
        code = None
        if q_prev is not None:
            q, code, it, rnorm = _continue(closure, case, q_prev, t_prev, crank[i])
        if code != _OK:  # first position, after a failure, or continuation failed on the way: start afresh
            q, code, it, rnorm = closure.close(closure.crude_guess(crank[i, 0], crank[i, 1]))
        q_all[i], status[i], iterations[i], residual[i] = q, code, it, rnorm
        if code == _OK:
            t_prev = closure.tangent()
            AB_all[i], K_all[i], condition[i] = closure.AB, t_prev, closure.condition
            q_prev = q
        else:
            q_prev, t_prev = None, None  # restart from a crude guess at the next position
    return {"q": q_all, "AB": AB_all, "K": K_all, "status": status, "iterations": iterations,
            "residual": residual, "condition": condition}


def _dynamics(closure: _Closure, case: Case, pos: dict[str, np.ndarray], state: CrankState,
              rows: np.ndarray) -> dict[str, np.ndarray]:
    """Passes 2-3 at the closed positions ``rows``: rates, rnea, joint forces without the closure.

    Velocities are ``K @ (theta1_dot, S1_dot)`` (batched).  Per position:
    ``forwardKinematics(q, v, a0)`` with ``a0`` = crank accelerations only gives the
    drift, ``a_free = -A^{-1} drift``, then ``rnea(q, v, a)`` gives ``tau0`` and
    ``data.f`` (mapped to world axes with the ``data.oMi`` of that same
    ``forwardKinematics``: ``rnea`` itself does not update ``data.oMi``).

    Returns v, a (m, 6), tau0 (m, 6), f0 (m, 3, 6) (crank, rod, slider; world axes, moment
    about O) and the placements p2, p3, u, crank_origin (m, 3).
    """
    model, data, pm = closure.model, closure.data, closure.pm
    fe, fp, rod, crank, slider = pm.rod_end_frame, pm.slider_pin_frame, pm.rod_joint, pm.crank_joint, pm.slider_joint
    oMi, forces, spatial_acc = data.oMi, data.f, data.a
    classical = pin.getFrameClassicalAcceleration
    m, nv = rows.size, model.nv
    q = pos["q"][rows]
    v = np.empty((m, nv))
    a = np.zeros((m, nv))
    v[:, :2] = np.column_stack([state.theta_dot, state.s_dot])[rows]
    a[:, :2] = np.column_stack([state.theta_ddot, state.s_ddot])[rows]
    v[:, 2:] = np.einsum("nij,nj->ni", pos["K"][rows], v[:, :2])
    a_inv = np.linalg.inv(pos["AB"][rows, :, 2:])
    tau0 = np.empty((m, nv))
    f0 = np.empty((m, 3, 6))
    geometry = np.empty((m, 4, 3))  # P2, P3, u, crank origin
    drift = np.empty(4)
    for k in range(m):
        qk, vk, ak = q[k], v[k], a[k]
        pin.forwardKinematics(model, data, qk, vk, ak)  # ak holds only the crank accelerations here
        drift[:3] = classical(model, data, fe, _LWA).linear - classical(model, data, fp, _LWA).linear
        drift[3] = spatial_acc[rod].angular[0]
        ak[2:] = -(a_inv[k] @ drift)
        tau0[k] = pin.rnea(model, data, qk, vk, ak)
        for j, joint in enumerate((crank, rod, slider)):
            world = oMi[joint].act(forces[joint])  # keep the Force alive while its vector is read
            f0[k, j] = world.vector
        rod_placement = oMi[rod]
        geometry[k, 0] = rod_placement.translation
        geometry[k, 1] = oMi[slider].translation
        geometry[k, 2] = rod_placement.rotation[:, 0]
        geometry[k, 3] = oMi[crank].translation
    return {"v": v, "a": a, "tau0": tau0, "f0": f0, "p2": geometry[:, 0], "p3": geometry[:, 1],
            "u": geometry[:, 2], "crank_origin": geometry[:, 3]}


def _least_squares(lhs: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Batched least squares ``min |lhs x - rhs|`` by QR; lhs (m, 6, 5) of full column rank, rhs (m, 6)."""
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


def _closed_loop_inverse_dynamics(case: Case, pm: PinocchioSliderCrank, tau0: np.ndarray,
                                  jc: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Least-squares solution of ``tau0 = S^T tau + J_c^T lambda`` for the unknown efforts and lambda.

    The rows of the angular coordinates (crank angle, rod rotations; F·L) are divided by
    ``a2`` so that every row is a force: the least squares then weighs the equations the
    same way in any length unit (a moment row and a force row are otherwise weighed by
    the unit: at micrometre scale the moment rows all but vanish from the fit).

    Parameters
    ----------
    tau0 : numpy.ndarray, shape (m, 6)
        ``M qddot + b`` from ``rnea`` (gravity included).
    jc : numpy.ndarray, shape (m, 3, 6)
        Closure Jacobian (rod end minus slider pin, world axes).

    Returns
    -------
    effort : (m, 6) all joint efforts; lam : (m, 3) force of the slider on the rod at P3, world axes;
    ls_residual : (m,) ``|W (lhs x - rhs)| / |W rhs|`` with the row weights ``W``.
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
    lhs = np.concatenate([np.broadcast_to(E, (m, *E.shape)), np.swapaxes(jc, 1, 2)], axis=2) * w[:, None]  # (m, 6, 5)
    rhs = (tau0 - tau_known) * w
    x = _least_squares(lhs, rhs)
    ls_res = np.linalg.norm(np.einsum("nij,nj->ni", lhs, x) - rhs, axis=1) / np.maximum(
        np.linalg.norm(rhs, axis=1), np.finfo(float).tiny)
    effort = np.broadcast_to(tau_known, (m, nv)).copy()
    effort[:, unknown] = x[:, : len(unknown)]
    return effort, x[:, len(unknown):], ls_res


def _effort_split(case: Case, pm: PinocchioSliderCrank) -> tuple[dict[int, float], list[int]]:
    """Known efforts {v index: value} and the unknown effort indices, by load mode.

    The rod's ball joint carries zero effort (known); the axial force is always unknown.
    Torque mode: drive torque known, slider effort unknown; force mode the reverse.
    The prismatic effort along ``-k4`` is ``-k4·f = -slider_load``.
    """
    theta_i, s_i = pm.v_crank.start, pm.v_crank.start + 1
    s4_i = pm.v_slider.start
    known = {j: 0.0 for j in range(pm.v_rod.start, pm.v_rod.stop)}
    if case.loads.mode == "torque":
        known[theta_i] = float(case.loads.drive_torque)
        return known, [s_i, s4_i]
    known[s4_i] = -float(case.loads.slider_force)
    return known, [theta_i, s_i]


def _geometry_at(closure: _Closure, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """P2, P3, u, crank origin at configuration ``q`` (for rows whose closure failed), each (3,)."""
    model, data, pm = closure.model, closure.data, closure.pm
    pin.forwardKinematics(model, data, q)
    rod = data.oMi[pm.rod_joint]
    return (rod.translation.copy(), data.oMi[pm.slider_joint].translation.copy(), rod.rotation[:, 0].copy(),
            data.oMi[pm.crank_joint].translation.copy())


def _edges(closure: _Closure, pos: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Status codes, closure condition (n,) and configurations (n, 7) with the edges of assembly applied.

    :func:`dualmech.core.assembly.edge_status` on Pinocchio's own poses: the condition of a
    closed row is its ``|u·k4|`` (and its reach ``sqrt(1 - c^2)``); other rows get the reach
    of Pinocchio's crank pin.  An ``assembly_limit`` row whose closure failed is put at the
    limit pose (``S4`` of the foot of the perpendicular from ``P2``).
    """
    pm, q = closure.pm, pos["q"].copy()
    closed = pos["status"] == _OK
    failed = np.flatnonzero(~closed)
    with np.errstate(invalid="ignore"):
        rho = np.sqrt(1.0 - np.minimum(pos["condition"], 1.0) ** 2)
    p2 = np.array([_geometry_at(closure, q[i])[0] for i in failed]).reshape(-1, 3)
    rho[failed] = reach(p2, pm.F, pm.k4, pm.a2)
    words, condition = edge_status(_STATUS_WORDS[pos["status"]], closed, rho, pos["condition"],
                                   tolerances.ASSEMBLY_REACH.value, tolerances.ASSEMBLY_LIMIT_CONDITION.value)
    status = np.array([STATUSES.index(w) for w in words], dtype=int)
    at_limit = status[failed] == _LIMIT
    q[failed[at_limit], _Q_S4] = foot_s4(p2[at_limit], pm.F, pm.k4)
    return status, condition, q


def solve(case: Case, pm: PinocchioSliderCrank | None = None) -> tuple[PinocchioSolution, dict]:
    """Run the passes of the module docstring on ``case``.

    Parameters
    ----------
    case : Case
    pm : PinocchioSliderCrank, optional
        A model already built from ``case`` (reused by benchmarks); built if omitted.

    Returns
    -------
    solution : PinocchioSolution
        Status codes include dead centres (torque mode, ``|transmission| <
        tolerances.DEAD_CENTRE_TRANSMISSION``), where efforts and wrenches are NaN.
    timings : dict
        Seconds spent in ``model`` (build), ``positions`` (closure) and ``dynamics``
        (rates, rnea, least squares, wrenches).
    """
    t0 = time.perf_counter()
    pm = build_model(case) if pm is None else pm
    state = case.motion.state(case.geometry.crank_axial_shift)
    closure = _Closure(pm, _length_scale(case, state))
    t1 = time.perf_counter()
    pos = _positions(closure, case, state)
    t2 = time.perf_counter()
    n = len(state)
    status, condition, q = _edges(closure, pos)
    rows = np.flatnonzero(status == _OK)
    dyn = _dynamics(closure, case, {**pos, "q": q}, state, rows)

    def _full(values: np.ndarray, at: np.ndarray = rows) -> np.ndarray:
        out = np.full((n, *values.shape[1:]), np.nan)
        out[at] = values
        return out

    p2, p3, u, o1 = (_full(dyn[key]) for key in ("p2", "p3", "u", "crank_origin"))
    for i in np.flatnonzero(status != _OK):
        p2[i], p3[i], u[i], o1[i] = _geometry_at(closure, pos["q"][i])
    if case.loads.mode == "torque":
        dead = np.abs(_transmission(p2, o1, u, pm.a1)[rows]) < tolerances.DEAD_CENTRE_TRANSMISSION.value
        status[rows[dead]] = _DEAD
        keep = ~dead
    else:
        keep = np.ones(rows.size, dtype=bool)
    live = rows[keep]
    jc = pos["AB"][live, :3]  # (m, 3, 6): closure Jacobian rows stored by the closure pass
    effort, lam, ls_res = _closed_loop_inverse_dynamics(case, pm, dyn["tau0"][keep], jc)
    f0 = dyn["f0"][keep]
    closure_wrench = np.concatenate([lam, np.cross(dyn["p3"][keep], lam)], axis=1)
    t3 = time.perf_counter()
    solution = PinocchioSolution(
        q=q, v=_full(dyn["v"]), a=_full(dyn["a"]),
        effort=_full(effort, live), closure_force=_full(lam, live),
        wrench1=_full(f0[:, 0] - closure_wrench, live),
        wrench2=_full(f0[:, 1] - closure_wrench, live),
        wrench4=_full(f0[:, 2] + closure_wrench, live),
        p2=p2, p3=p3, u=u, crank_origin=o1,
        status=status, iterations=pos["iterations"], residual=pos["residual"],
        ls_residual=_full(ls_res, live), condition=condition,
    )
    timings = {"model": t1 - t0, "positions": t2 - t1, "dynamics": t3 - t2}
    return solution, timings


# ----------------------------------------------------------------------------- table

def _transmission(p2: np.ndarray, crank_origin: np.ndarray, u: np.ndarray, a1: float) -> np.ndarray:
    """``t = z·((P2 - (0,0,S1)) × u) / a1`` (conventions "Output columns"); inputs (n, 3), output (n,)."""
    arm = p2 - crank_origin
    return (arm[:, 0] * u[:, 1] - arm[:, 1] * u[:, 0]) / a1


def transmission(sol: PinocchioSolution, a1: float) -> np.ndarray:
    """The transmission column of ``sol``, shape (n,)."""
    return _transmission(sol.p2, sol.crank_origin, sol.u, a1)


def _angle_ranges(deg: np.ndarray, mask: np.ndarray) -> str:
    """``"0-33, 327-359 deg"``: the tabulated angles of each run of consecutive rows where ``mask`` holds."""
    idx = np.flatnonzero(mask)
    if idx.size == 0:
        return ""
    breaks = np.flatnonzero(np.diff(idx) > 1)
    starts, ends = np.r_[idx[0], idx[breaks + 1]], np.r_[idx[breaks], idx[-1]]
    parts = [f"{deg[i]:g}" if i == j else f"{deg[i]:g}-{deg[j]:g}" for i, j in zip(starts, ends)]
    return ", ".join(parts) + " deg"


def to_table(case: Case, sol: PinocchioSolution, meta: dict | None = None) -> ResultTable:
    """The :class:`ResultTable` of ``sol`` in the conventions' columns, statuses and signs."""
    state = case.motion.state(case.geometry.crank_axial_shift)
    status = sol.status
    t = transmission(sol, case.geometry.crank_length)
    w1, w2, w4 = sol.wrench1, sol.wrench2, sol.wrench4
    j4_moment_p3 = w4[:, 3:] - np.cross(sol.p3, w4[:, :3])
    cols = {
        "theta1_deg": np.asarray(case.motion.angles_deg, float).copy(),
        "S1": state.s.copy(),
        "S4": sol.q[:, _Q_S4].copy(),
        "S4_dot": sol.v[:, _V_S4].copy(),
        "S4_ddot": sol.a[:, _V_S4].copy(),
        "j1_fx": w1[:, 0], "j1_fy": w1[:, 1], "j1_fz": w1[:, 2],
        "j1_mx": w1[:, 3], "j1_my": w1[:, 4], "j1_mz": w1[:, 5],
        "j2_fx": w2[:, 0], "j2_fy": w2[:, 1], "j2_fz": w2[:, 2],
        "j3_fx": -sol.closure_force[:, 0], "j3_fy": -sol.closure_force[:, 1], "j3_fz": -sol.closure_force[:, 2],
        "j4_fx": w4[:, 0], "j4_fy": w4[:, 1], "j4_fz": w4[:, 2],
        "j4_mx": j4_moment_p3[:, 0], "j4_my": j4_moment_p3[:, 1], "j4_mz": j4_moment_p3[:, 2],
        "slider_load": w4[:, :3] @ slider_axis(case)[0],
        "drive_torque": w1[:, 5].copy(),
        "transmission": t,
        "residual": sol.residual / case.geometry.rod_length,
        "closure_condition": sol.condition,
    }
    cols = {k: np.array(v, dtype=float) for k, v in cols.items()}
    cols["residual"][status == _NO_ASSEMBLY] = np.nan
    words = settle(cols, _STATUS_WORDS[status], REACTION_COLUMNS)
    status = np.array([STATUSES.index(w) for w in words], dtype=int)
    messages = []
    for code, word in enumerate(_STATUS_WORDS):
        at = status == code
        if code == _OK or not at.any():
            continue
        messages.append(f"{word}: {at.sum()} positions at {_angle_ranges(cols['theta1_deg'], at)}")
        if code == _NO_ASSEMBLY:
            gap = np.max(sol.residual[at]) / case.geometry.rod_length
            messages[-1] += f" (the rod misses the slider line by up to {gap:.3g} a2)"
    info = {"pinocchio_version": pin.__version__, "messages": messages,
            "newton_iterations_max": int(sol.iterations[status == _OK].max(initial=0)),
            "newton_iterations_mean": float(sol.iterations[status == _OK].mean()) if np.any(status == _OK) else 0.0,
            "ls_residual_max": float(np.nanmax(sol.ls_residual, initial=0.0))}
    info.update(meta or {})
    return ResultTable(ENGINE, case.name, cols, words, info)


def solve_case(case: Case) -> ResultTable:
    """Solve ``case`` with Pinocchio alone; the engine behind ``dualmech solve --engine pinocchio``.

    Returns
    -------
    ResultTable
        Engine ``"pinocchio"``; every column of ``docs/conventions.md``.  ``meta``
        holds the Pinocchio version, Newton iteration counts, the worst
        least-squares residual of the inverse dynamics, timings and status messages.
    """
    sol, timings = solve(case)
    return to_table(case, sol, {"seconds": timings})


# ----------------------------------------------------------------------------- benchmark

def benchmark(case: Case, repeats: int = 5) -> dict:
    """Per-position cost of the Pinocchio path on ``case`` (best of ``repeats`` runs).

    The model is built once and reused (as a user of Pinocchio would); the timed
    part is closure + rates + inverse dynamics + table for every position.

    Returns
    -------
    dict
        ``engine``, ``case``, ``positions``, ``repeats``, ``seconds`` (best total),
        ``us_per_position``, ``model_build_us`` (once per case, not in the total) and the
        split of the best run per position: ``positions_us`` (closure by continuation) and
        ``dynamics_us`` (rates, rnea, least squares, wrenches); the rest is building the table.
    """
    if repeats < 1:
        raise ValueError(f"repeats: expected an integer >= 1, got {repeats!r}")
    t0 = time.perf_counter()
    pm = build_model(case)
    build = time.perf_counter() - t0
    n = len(case.motion.angles_deg)
    best, split = math.inf, {}
    for _ in range(repeats):
        t0 = time.perf_counter()
        sol, timings = solve(case, pm)
        to_table(case, sol)
        elapsed = time.perf_counter() - t0
        if elapsed < best:
            best, split = elapsed, timings
    return {
        "engine": ENGINE, "case": case.name, "positions": n, "repeats": repeats, "seconds": best,
        "us_per_position": 1e6 * best / n, "model_build_us": 1e6 * build,
        **{f"{k}_us": 1e6 * v / n for k, v in split.items() if k != "model"},
    }
