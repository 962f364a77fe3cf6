"""Pinocchio judge, pass 1: closing the loop at every crank position (thesis method, step 1 of
:mod:`~dualmech.validation.judges.pinocchio_slider_crank.engine`).

The residual is the gap between the rod end and the slider pin, both Pinocchio frames, in world axes,

.. math:: r(q) = p_{end}(q) - p_{pin}(q), \\qquad
          J_c = J^{LWA}_{end,lin} - J^{LWA}_{pin,lin}  \\in R^{3\\times 6},

and Gauss–Newton moves the free coordinates (rod quaternion, ``S4``) by the minimum-norm step
:math:`\\delta = -J_f^T (J_f J_f^T + \\mu I)^{-1} r`, integrated on the configuration manifold with
``pin.integrate``; Levenberg–Marquardt takes over when it stalls and tells a least-squares minimum
with a gap (``no_assembly``) from a failure.  Positions continue from the previous one
(:func:`continue_to`, :func:`close_positions`).
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from dualmech.core.motion import CrankState
from dualmech.core.status import Status
from dualmech.core.table import STATUSES
from dualmech.models.case import Case
from dualmech.validation.judges.pinocchio_slider_crank.model import PinocchioSliderCrank

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
#: A converged pose whose closure condition |u·k4| is below this goes on while each Newton step halves the
#: gap (at most EDGE_STEPS more): S4 carries the gap times 1/|u·k4|, S4_ddot ~1/|u·k4|^3.  Stopped at
#: CLOSURE_TOLERANCE, a random case at |u·k4| = 0.016 left S4_ddot 2.1e-10 of its peak off the closed form
#: (over the matrix's 1e-10); the in-house engine and MuJoCo agreed with the closed form to 1e-11.
EDGE_CONDITION = 0.1
EDGE_STEPS = 4
#: |J_i·r| <= this * |J_i| |r| for every free column J_i at a non-zero residual: a least-squares minimum,
#: the rod cannot reach the slider line.
STATIONARY_GRADIENT = 1e-6

LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
_LOCAL = pin.ReferenceFrame.LOCAL

# internal status codes: indices into STATUSES (core/table.py)
STATUS_WORDS = np.array(STATUSES, dtype=object)
OK, DEAD, LIMIT, BRANCH, NOT_CONVERGED, NO_ASSEMBLY = (
    STATUSES.index(w)
    for w in (
        Status.OK,
        Status.DEAD_CENTRE,
        Status.ASSEMBLY_LIMIT,
        Status.BRANCH_JUMP,
        Status.NOT_CONVERGED,
        Status.NO_ASSEMBLY,
    )
)


def _min_norm_step(jf: np.ndarray, r: tuple[float, float, float], mu: float) -> list[float]:
    """Damped minimum-norm Newton step ``x = -J^T (J J^T + mu I)^{-1} r`` on the free columns ``jf``.

    ``jf`` (3x4) are the free columns (rod, S4) of the closure Jacobian.
    The 3x3 solve is written out (adjugate of the symmetric ``G = J J^T + mu I``)
    because the per-call overhead of ``numpy.linalg.solve`` dominates a 3x3 problem.
    """
    (a, b, c, d), (e, f, g, h), (i, j, k, m) = jf.tolist()
    r0, r1, r2 = r
    s00 = a * a + b * b + c * c + d * d + mu
    s01 = a * e + b * f + c * g + d * h
    s02 = a * i + b * j + c * k + d * m
    s11 = e * e + f * f + g * g + h * h + mu
    s12 = e * i + f * j + g * k + h * m
    s22 = i * i + j * j + k * k + m * m + mu
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
    return [
        a * y0 + e * y1 + i * y2,
        b * y0 + f * y1 + j * y2,
        c * y0 + g * y1 + k * y2,
        d * y0 + h * y1 + m * y2,
    ]


class Closure:
    """Gauss–Newton loop closure on one model/data pair, reused for every position of a case.

    After a converged :meth:`close`, ``self.AB`` (4 x nv) holds the rate equations
    ``AB qdot = 0`` at the solution (rows: J_c, then zero spin with a ball at P3 or the universal
    joint's ``omega_rod·n = 0``); its last 4 columns are ``A`` (free coordinates: rod, S4) and the first
    ``nc`` are ``B`` (crank coordinates).  With a universal joint every converged pose is turned about
    the rod axis so that the rod's y axis is ``a_r = u x k4 / |u x k4|`` (:meth:`_align_spin`).
    """

    def __init__(self, pm: PinocchioSliderCrank, length_scale: float) -> None:
        self.pm = pm
        self.model = pm.model
        self.data = pm.model.createData()
        self.oMf = self.data.oMf  # a view on data's frame placements, updated in place
        self.tol2 = (CLOSURE_TOLERANCE * length_scale) ** 2
        self.mu = STEP_DAMPING * pm.a2**2
        self.dv = np.zeros(pm.model.nv)
        self.AB = np.empty((4, pm.model.nv))
        self.condition = math.nan  # |u·k4| at the last converged solution
        nc = self.nc = pm.nc
        layout = (pm.q_crank, pm.q_rod, pm.q_slider, pm.v_crank, pm.v_rod, pm.v_slider)
        if layout != (slice(0, nc), slice(nc, nc + 4), slice(nc + 4, nc + 5), slice(0, nc), slice(nc, nc + 3),
                      slice(nc + 3, nc + 4)):
            raise ValueError(f"pinocchio model: unexpected coordinate layout {layout}")

    def _evaluate(self, q: np.ndarray) -> tuple[np.ndarray, tuple[float, float, float], float]:
        """Closure Jacobian (3x6), residual ``p_end - p_pin`` and its squared norm at ``q``."""
        model, data, oMf = self.model, self.data, self.oMf
        fe, fp = self.pm.rod_end_frame, self.pm.slider_pin_frame
        pin.computeJointJacobians(model, data, q)  # also places every joint (data.oMi)
        jc = pin.getFrameJacobian(model, data, fe, LWA)[:3] - pin.getFrameJacobian(model, data, fp, LWA)[:3]
        r = (oMf[fe].translation - oMf[fp].translation).tolist()
        return jc, r, r[0] * r[0] + r[1] * r[1] + r[2] * r[2]

    def close(self, q: np.ndarray) -> tuple[np.ndarray, int, int, float]:
        """Newton from ``q`` (its crank coordinates are kept). Returns (q, status code, iterations, |r|).

        Gauss–Newton with the tiny fixed damping; if it has not converged after
        ``MAX_NEWTON_ITERATIONS`` (or the gap grew a hundredfold: no assembly nearby),
        :meth:`_minimize` continues from the best iterate and decides between a
        least-squares minimum with a gap (``no_assembly``) and plain failure (``not_converged``).
        """
        model, dv, tol2, mu, nc = self.model, self.dv, self.tol2, self.mu, self.nc
        best_q, best_rr = q, math.inf
        for it in range(MAX_NEWTON_ITERATIONS + 1):
            jc, r, rr = self._evaluate(q)
            if rr <= tol2:
                if abs(self._along()) < EDGE_CONDITION:
                    q, jc, rr = self._on_to_rounding(q, jc, r, rr)
                return self._converged(q, jc, it, rr)
            if rr < best_rr:
                best_q, best_rr = q, rr
            if it == MAX_NEWTON_ITERATIONS or not rr <= 1e4 * best_rr:  # also catches NaN
                break
            dv[nc:] = _min_norm_step(jc[:, nc:], r, mu)
            q = pin.integrate(model, q, dv)
        return self._minimize(best_q, it)

    def _along(self) -> float:
        """``u·k4`` at the pose ``data`` holds (``u`` = the rod frame's x axis)."""
        return float(self.data.oMi[self.pm.rod_joint].rotation[:, 0] @ self.pm.k4)

    def _on_to_rounding(self, q: np.ndarray, jc: np.ndarray, r: tuple[float, float, float],
                        rr: float) -> tuple[np.ndarray, np.ndarray, float]:
        """Newton steps from the converged ``q`` (data evaluated there) while each halves the gap
        (:data:`EDGE_CONDITION`); returns the last such iterate, its Jacobian and squared gap, data there."""
        for _ in range(EDGE_STEPS):
            self.dv[self.nc:] = _min_norm_step(jc[:, self.nc:], r, self.mu)
            trial = pin.integrate(self.model, q, self.dv)
            jc_t, r_t, rr_t = self._evaluate(trial)
            if not rr_t <= 0.25 * rr:
                self._evaluate(q)  # data back at the accepted iterate
                break
            q, jc, r, rr = trial, jc_t, r_t, rr_t
        return q, jc, rr

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
        model, dv, tol2, nc = self.model, self.dv, self.tol2, self.nc
        jc, r, rr = self._evaluate(q)
        lm = 1e-3
        for extra in range(LM_ITERATIONS + 1):
            if not math.isfinite(rr):
                break
            if rr <= tol2:
                return self._converged(q, jc, it + extra, rr)
            jf = jc[:, nc:]
            gram = jf.T @ jf
            col2 = np.diag(gram) + 1e-20 * np.max(np.diag(gram))  # floor: the rod's spin column is ~0
            gradient = jf.T @ np.asarray(r)
            if np.all(np.abs(gradient) <= STATIONARY_GRADIENT * np.sqrt(col2 * rr)):
                return q, NO_ASSEMBLY, it + extra, math.sqrt(rr)
            if extra == LM_ITERATIONS:
                break
            damping = lm * (col2 + 1e-12 * col2.max())
            dv[nc:] = -np.linalg.solve(gram + np.diag(damping), gradient)
            trial = pin.integrate(model, q, dv)
            jc_t, r_t, rr_t = self._evaluate(trial)
            if rr_t < rr:
                q, jc, r, rr, lm = trial, jc_t, r_t, rr_t, lm / 3.0
            else:
                lm *= 4.0
                self._evaluate(q)  # restore data to the current iterate
        return q, NOT_CONVERGED, it + extra, math.sqrt(rr)

    def _converged(self, q: np.ndarray, jc: np.ndarray, it: int,
                   rr: float) -> tuple[np.ndarray, int, int, float]:
        """Store the rate equations at the solution ``q`` (data evaluated there); classify the branch.

        Returns what :meth:`close` returns.  With a universal joint the pose is first turned about ``u``
        (:meth:`_align_spin`), and the fourth row is the joint's ``n^T J_omega`` (rod axes), else the
        zero-spin gauge ``u^T J_omega``.
        """
        model, data, pm = self.model, self.data, self.pm
        if pm.universal:
            q = self._align_spin(q)
            jc, _, rr = self._evaluate(q)
        AB = self.AB
        AB[:3] = jc
        rotation = data.oMi[pm.rod_joint].rotation
        if pm.universal:  # omega_rod·n, n = a_r x k4 (rod axes: a_r = y)
            AB[3] = np.cross([0.0, 1.0, 0.0], rotation.T @ pm.k4) @ pin.getJointJacobian(
                model, data, pm.rod_joint, _LOCAL)[3:]
        else:  # rod angular velocity along its x = u
            AB[3] = pin.getJointJacobian(model, data, pm.rod_joint, _LOCAL)[3]
        along = self._along()
        self.condition = abs(along)
        return q, OK if along < 0.0 else BRANCH, it, math.sqrt(rr)

    def _align_spin(self, q: np.ndarray) -> np.ndarray:
        """``q`` with the rod turned about its axis ``u`` so that its y axis is ``a_r = u x k4 / |u x k4|``.

        The universal joint's condition ``e·k4 = 0`` on the rod-side axis ``e`` (the rod's y); a turn about
        ``u`` moves neither ``P2`` nor the rod end, so the closure is kept.  ``data`` must be at ``q``.
        """
        rotation = self.data.oMi[self.pm.rod_joint].rotation
        u, e = rotation[:, 0], rotation[:, 1]
        a_r = np.cross(u, self.pm.k4)
        a_r /= np.linalg.norm(a_r)
        dv = np.zeros(self.model.nv)
        dv[self.pm.v_rod.start] = math.atan2(float(u @ np.cross(e, a_r)), float(e @ a_r))  # about local x = u
        return pin.integrate(self.model, q, dv)

    def tangent(self) -> np.ndarray:
        """``d q_free / d (crank coordinates) = -A^{-1} B`` at the last converged solution, shape (4, nc)
        (NaN where ``A`` is singular).

        numpy's solve, not SciPy's LAPACK wrapper: importing ``scipy.linalg`` cost each worker 0.15 s of
        CPU, the wrapper's lower overhead a few ms a matrix of cases.
        """
        try:
            return -np.linalg.solve(self.AB[:, self.nc:], self.AB[:, :self.nc])
        except np.linalg.LinAlgError:
            return np.full((4, self.nc), np.nan)

    def crude_guess(self, theta: float, s1: float, side: float = 1.0) -> np.ndarray:
        """A rough assembly: ``S4`` a rod length beyond the foot of the perpendicular from ``P2``, rod aimed
        there.

        Uses Pinocchio's placement of the crank pin.  With ``side = +1`` the guess is on
        the conventions' branch side (``(P3 - P2)·k4 = -a2 < 0``), at a distance
        ``>= a2`` from ``P2``; ``side = -1`` mirrors it (tests use that to provoke a branch jump).
        """
        pm, model, data = self.pm, self.model, self.data
        q = pin.neutral(model)
        q[pm.q_crank] = (theta, s1)[:self.nc]
        pin.forwardKinematics(model, data, q)
        p2 = data.oMi[pm.rod_joint].translation
        s4 = -float(pm.k4 @ (p2 - pm.F)) + side * pm.a2
        toward = (pm.F - s4 * pm.k4) - p2
        local = data.oMi[pm.crank_joint].rotation.T @ (toward / np.linalg.norm(toward))
        q[pm.q_rod] = pin.Quaternion.FromTwoVectors(np.array([1.0, 0.0, 0.0]), local).coeffs()
        q[pm.q_slider] = s4
        return q

    def step(
        self, q: np.ndarray, tangent: np.ndarray, crank_to: np.ndarray
    ) -> tuple[np.ndarray, int, int, float]:
        """Predict along ``tangent`` from converged ``q`` to crank coordinates ``crank_to``, then Newton."""
        nc = self.nc
        delta = crank_to - q[:nc]
        dv = self.dv
        dv[nc:] = tangent @ delta
        q = pin.integrate(self.model, q, dv)
        q[:nc] = crank_to
        return self.close(q)


def _s1_at(case: Case, theta: np.ndarray) -> np.ndarray:
    """S1 at crank angles ``theta`` [rad] (for intermediate continuation steps)."""
    return case.own_crank_states(np.degrees(theta)).s


def continue_to(closure: Closure, case: Case, q0: np.ndarray, tangent: np.ndarray,
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
            waypoints = np.column_stack([theta, _s1_at(case, theta)])[:, :closure.nc]
            waypoints[-1] = crank_to
        q, t = q0, tangent
        for w, target in enumerate(waypoints):
            if w:
                t = closure.tangent()
            q, code, it, rnorm = closure.step(q, t, target)
            if code != OK:
                break
        if code == OK:
            return q, code, it, rnorm
    return q, code, it, rnorm


def length_scale(case: Case, state: CrankState) -> float:
    g = case.geometry
    return g.crank_length + g.rod_length + abs(g.slider_offset) + float(np.max(np.abs(state.s), initial=0.0))


def close_positions(closure: Closure, case: Case, state: CrankState) -> dict[str, np.ndarray]:
    """Pass 1 (sequential): close the loop at every tabulated position by continuation.

    Each position continues from the previous closed one (:func:`continue_to`); the
    first one, one after a failed position, or one the continuation could not reach
    starts from :meth:`Closure.crude_guess`, so a status always describes its own
    position.  Returns q (n, nq), the rate equations AB (n, 4, nv) and the tangent
    K = -A^{-1} B (n, 4, nc) at each closed position (NaN elsewhere), status codes,
    Newton iterations, closure residuals |r| and the closure condition |u·k4| (n,) (NaN where not closed).
    """
    n = len(state)
    q_all = np.empty((n, closure.model.nq))
    AB_all = np.full((n, 4, closure.model.nv), np.nan)
    K_all = np.full((n, 4, closure.nc), np.nan)
    status = np.empty(n, dtype=int)
    iterations = np.empty(n, dtype=int)
    residual = np.empty(n)
    condition = np.full(n, np.nan)
    crank = np.column_stack([state.theta, state.s])[:, :closure.nc]
    q_prev, t_prev = None, None
    for i in range(n):
        code = None
        if q_prev is not None:
            q, code, it, rnorm = continue_to(closure, case, q_prev, t_prev, crank[i])
        if code != OK:  # first position, after a failure, or continuation failed on the way: start afresh
            q, code, it, rnorm = closure.close(closure.crude_guess(crank[i, 0], state.s[i]))
        q_all[i], status[i], iterations[i], residual[i] = q, code, it, rnorm
        if code == OK:
            t_prev = closure.tangent()
            AB_all[i], K_all[i], condition[i] = closure.AB, t_prev, closure.condition
            q_prev = q
        else:
            q_prev, t_prev = None, None  # restart from a crude guess at the next position
    return {"q": q_all, "AB": AB_all, "K": K_all, "status": status, "iterations": iterations,
            "residual": residual, "condition": condition}
