"""Displacement analysis: close the dual loop equation at every position at once.

Newton-Raphson on the loop-closure equation (thesis eq. 5) with the screws of
:mod:`dualmech.core.loop` as derivative operators (eq. 8-17) and a least-squares
solve of the primary and dual equations (eq. 20-26, 23a).  Positions where
Newton stalls go to a Davidon-Fletcher-Powell minimization of the closure
error (Hall, Root & Sandgren's dependable method, thesis section 2.6.1).  A
position whose closure error has a non-zero stationary minimum cannot assemble.

All positions iterate together: every step is a numpy operation over the
batch of still-active positions, never a Python loop over positions.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

import numpy as np

from dualmech.core.dual import skew
from dualmech.core.loop import (
    Chain,
    Loop,
    LoopState,
    Screw,
    closure_error,
    closure_residual,
    evaluate,
    gauge_rows,
    screw_jacobian,
)

#: Closure residual (dimensionless, see :func:`~dualmech.core.loop.closure_residual`) at which a position
#: counts as closed.
CLOSURE_TOL = 1e-14
#: A residual this small that Newton can no longer halve is rounding noise: also closed.
ROUNDING_TOL = 1e-12
#: A stationary point of the closure error: the error is this nearly orthogonal to every achievable change.
STATIONARY_COSINE = 1e-7
#: Below this residual a DFP point is taken to be near a root, and Newton finishes the job.
NEAR_ROOT = 1e-4
#: DFP iterations between restarts of the inverse-Hessian estimate: the rotation unknowns are
#: increments about axes that turn with the joints, so old secant pairs go stale.
DFP_RESTART = 10


class ClosureStatus(IntEnum):
    """Outcome of the closure at one position."""

    OK = 0
    NOT_CONVERGED = 1
    NO_ASSEMBLY = 2


@dataclass(frozen=True)
class ClosureResult:
    """Solved loop at ``n`` positions.

    Attributes
    ----------
    state : LoopState
        The unknowns (NaN-free; meaningful where ``status == OK``).
    status : numpy.ndarray of ClosureStatus codes, shape (n,)
    iterations : numpy.ndarray of int, shape (n,)
        Newton iterations plus DFP iterations.
    residual : numpy.ndarray, shape (n,)
        Final closure residual (:func:`~dualmech.core.loop.closure_residual`).
    used_dfp : numpy.ndarray of bool, shape (n,)
        Whether the DFP fallback was needed.
    """

    state: LoopState
    status: np.ndarray
    iterations: np.ndarray
    residual: np.ndarray
    used_dfp: np.ndarray


def gauge_block(chain, loop: Loop) -> np.ndarray:
    """Spin-gauge rows over the tangent step, ``(n, g, k)``."""
    rows, _ = gauge_rows(chain, loop)
    gauge = np.zeros(rows.shape[:2] + (loop.n_unknown,), rows.dtype)
    for j, s in enumerate(chain.screws):
        if s.var[0] == "unknown":
            gauge[:, :, s.var[1]] = rows[:, :, j]
    return gauge


def least_squares(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Batched solution of ``a x = b`` in the least-squares sense (thesis eq. 23a).

    ``a`` ``(n, m, k)`` with ``m >= k``, ``b`` ``(n, m)``.  Square systems are solved
    directly; otherwise :math:`x = (A^TA)^{-1}A^Tb`.  A batch whose matrix is
    exactly singular falls back to the pseudo-inverse.
    """
    if a.shape[1] != a.shape[2]:
        at = np.swapaxes(a, 1, 2)
        a, b = at @ a, np.einsum("nkm,nm->nk", at, b)
    try:
        return np.linalg.solve(a, b[..., None])[..., 0]
    except np.linalg.LinAlgError:
        return np.einsum("nkm,nm->nk", np.linalg.pinv(a), b)


def closure_system(chain, loop: Loop) -> tuple[np.ndarray, np.ndarray]:
    """The linearized closure at ``chain``: the unknowns' screws ``(n, 6 + g, k)`` and the closure error
    ``(n, 6 + g)`` (eq. 11, 23a), each with the spin gauge's rows (their error zero)."""
    jac = screw_jacobian(chain, loop)
    err = closure_error(chain, loop)
    if loop.spin_gauges:
        jac = np.concatenate([jac, gauge_block(chain, loop)], axis=1)
        err = np.concatenate([err, np.zeros((err.shape[0], len(loop.spin_gauges)), err.dtype)], axis=1)
    return jac, err


def _newton_step(chain, loop: Loop) -> np.ndarray:
    """Newton step: screws times step = minus the closure error (eq. 11, 23a), with the spin gauge."""
    jac, err = closure_system(chain, loop)
    return least_squares(jac, -err)


def polish(loop: Loop, inputs: dict[str, np.ndarray], state: LoopState, steps: int = 2) -> LoopState:
    """``steps`` full Newton steps (eq. 11, 23a) from a closed ``state``, without step control.

    Every operation of a step is analytic in the inputs: the loop product, the screws, the closure
    error, the least-squares solve (an LU factorization; not the DFP fallback's pseudo-inverse) and
    the retraction (:func:`~dualmech.core.loop.rodrigues`).  With complex inputs :math:`p + ih\\,\\delta p`
    and the real closed state :math:`x(p)`, a step therefore lands on
    :math:`x(p) + ih\\,x'(p)\\delta p` to first order in ``h``: the implicit function theorem,
    :math:`x' = -J_x^{-1} g_p`, evaluated by the solver's own Newton step.  The imaginary part of a
    step is off by the real closure error times :math:`h` (~1e-15 relative at a closed state); the
    second step removes even that.  Used by the tolerance study's sensitivities
    (:mod:`dualmech.models.tolerance.sensitivity`).
    """
    for _ in range(steps):
        state = state.retract(_newton_step(evaluate(loop, inputs, state), loop), loop)
    return state


def refine(loop: Loop, inputs: dict[str, np.ndarray], state: LoopState,
           max_iter: int = 30) -> tuple[LoopState, np.ndarray, np.ndarray]:
    """Newton from a closed ``state`` on to the rounding level: until a step no longer halves the residual.

    Where the closure is ill-conditioned the unknowns carry the residual times its gain (the slider
    crank near an edge of assembly: ``1/c``, accelerations ``1/c^3``), so the ``CLOSURE_TOL`` that
    suffices elsewhere leaves digits there (``EDGE_REFINE_CONDITION`` in ``core/thresholds.py``).
    Returns the state, the Newton iterations taken and the residual, per position.
    """
    n = state.scalars.shape[0]
    active, iters, residual = np.ones(n, dtype=bool), np.zeros(n, dtype=int), np.full(n, np.inf)
    state, _, iters, residual = _newton(loop, inputs, state, active, iters, residual, max_iter, tol=0.0)
    return state, iters, residual


def _newton(loop, inputs, state, active, iters, residual, max_iter, tol=CLOSURE_TOL):
    """Newton with step halving, one loop evaluation per iteration, over the active positions.

    A step that increases the residual is halved (up to 6 times) before a new
    Newton step is taken from the accepted point; a position is closed at a residual
    of ``tol`` (:func:`refine`: 0, on to the rounding level).  Returns the updated state and
    arrays; ``active`` ends true where Newton stalled or ran out of iterations.
    """
    n = active.shape[0]
    stalls = np.zeros(n, dtype=int)
    halvings = np.zeros(n, dtype=int)
    base, step = state, np.zeros((n, loop.n_unknown))
    base_res = np.full(n, np.inf)
    for _ in range(max_iter + 1):
        idx = np.flatnonzero(active)
        if idx.size == 0:
            break
        sub_in = {k: v[idx] for k, v in inputs.items()}
        chain = evaluate(loop, sub_in, state.take(idx))
        res = closure_residual(chain, loop)
        residual[idx] = res
        worse = (res > base_res[idx]) & (halvings[idx] < 6)
        done = res <= tol
        # back off where the step made things worse
        back = idx[worse & ~done]
        if back.size:
            halvings[back] += 1
            step[back] *= 0.5
            state = state.put(back, base.take(back).retract(step[back], loop))
        # accept elsewhere, and take a new Newton step
        acc = ~worse & ~done
        good = idx[acc]
        improved = res[acc] < 0.5 * base_res[good]
        stalls[good] = np.where(improved, 0, stalls[good] + 1)
        rounding = ~improved & (res[acc] <= ROUNDING_TOL)
        active[good[rounding]] = False
        active[idx[done]] = False
        go = acc.copy()
        go[acc] = ~rounding & (stalls[good] < 3)
        active[idx[acc][~go[acc]]] = False
        take = np.flatnonzero(go)
        if take.size:
            sel = idx[take]
            sub_chain = _take_chain(chain, take)
            step[sel] = _newton_step(sub_chain, loop)
            base = base.put(sel, state.take(sel))
            base_res[sel] = res[take]
            halvings[sel] = 0
            state = state.put(sel, state.take(sel).retract(step[sel], loop))
            iters[sel] += 1
    # positions still marked active ran out of iterations at an unevaluated trial point: step back
    left = np.flatnonzero(active & np.isfinite(base_res))
    if left.size:
        state = state.put(left, base.take(left))
        residual[left] = base_res[left]
    return state, active, iters, residual


def _take_chain(chain, index: np.ndarray):
    """The chain at a subset of its positions."""
    frames = [f.take(index) for f in chain.frames]
    screws = [Screw(s.line.take(index), s.var, s.row, s.carrier) for s in chain.screws]
    return Chain(frames, chain.closure.take(index), screws, chain.scale[index])


def _objective(loop, inputs, state):
    """DFP objective :math:`\\tfrac12\\|\\hat B - \\hat I\\|^2`, gradient, Jacobian (+ gauge rows),
    stationarity cosine, residual.

    The whole matrix, not only its skew part: a loop product rotated by :math:`\\pi`
    has no skew part, and minimizing the skew part alone converges to such spurious
    roots (the reason for the thesis's diagonal terms in eq. 22).  The dual part
    is divided by the length scale.
    """
    chain = evaluate(loop, inputs, state)
    b, scale = chain.closure, chain.scale[:, None, None]
    n = b.re.shape[0]
    r = np.concatenate([(b.re - np.eye(3)).reshape(n, 9), (b.du / scale).reshape(n, 9)], axis=1)
    jac = np.zeros((n, 18, loop.n_unknown))
    for s in chain.screws:
        if s.var[0] == "unknown":
            sk_re, sk_du = skew(s.line.re), skew(s.line.du)
            jac[:, :9, s.var[1]] = (sk_re @ b.re).reshape(n, 9)
            jac[:, 9:, s.var[1]] = ((sk_re @ b.du + sk_du @ b.re) / scale).reshape(n, 9)
    grad = np.einsum("nmk,nm->nk", jac, r)
    f = 0.5 * np.einsum("nm,nm->n", r, r)
    cosine = np.linalg.norm(grad, axis=1) / np.maximum(
        np.linalg.norm(jac, axis=(1, 2)) * np.linalg.norm(r, axis=1), 1e-300
    )
    jac_g = np.concatenate([jac, gauge_block(chain, loop)], axis=1) if loop.spin_gauges else jac
    return f, grad, jac_g, cosine, closure_residual(chain, loop)


def davidon_fletcher_powell(loop: Loop, inputs: dict[str, np.ndarray], state: LoopState,
                            max_iter: int = 200) -> tuple[LoopState, np.ndarray, np.ndarray, np.ndarray]:
    """Minimize :math:`\\tfrac12\\|\\hat B - \\hat I\\|^2` by DFP with an Armijo line search, batched.

    Returns the state, iterations, final residual and the stationarity cosine
    :math:`\\|J^T r\\| / (\\|J\\|\\|r\\|)` at every position (``r`` the entries of
    :math:`\\hat B - \\hat I`).
    """
    n = state.scalars.shape[0]
    f, grad, jac_g, cosine, res = _objective(loop, inputs, state)
    h = _gauss_newton_inverse(jac_g)
    iters = np.zeros(n, dtype=int)
    active = (res > CLOSURE_TOL) & (cosine > STATIONARY_COSINE)
    for it in range(max_iter):
        idx = np.flatnonzero(active)
        if idx.size == 0:
            break
        if it and it % DFP_RESTART == 0:  # the tangent axes turn with the joints: refresh the estimate
            h[idx] = _gauss_newton_inverse(_objective(loop, {key: v[idx] for key, v in inputs.items()},
                                                      state.take(idx))[2])
        p = -np.einsum("nij,nj->ni", h[idx], grad[idx])
        slope = np.einsum("ni,ni->n", p, grad[idx])
        alpha = np.ones(idx.size)
        pending = np.ones(idx.size, dtype=bool)
        for _ in range(40):  # Armijo backtracking, evaluating only the positions still searching
            loc = np.flatnonzero(pending)
            if loc.size == 0:
                break
            gi = idx[loc]
            trial = state.take(gi).retract(p[loc] * alpha[loc, None], loop)
            f_t, g_t, _, c_t, r_t = _objective(loop, {key: v[gi] for key, v in inputs.items()}, trial)
            ok = f_t <= f[gi] + 1e-4 * alpha[loc] * slope[loc]
            if ok.any():
                sel, acc = loc[ok], gi[ok]
                state = state.put(acc, trial.take(np.flatnonzero(ok)))
                h[acc] = _dfp_update(h[acc], p[sel] * alpha[sel, None], g_t[ok] - grad[acc])
                f[acc], grad[acc], cosine[acc], res[acc] = f_t[ok], g_t[ok], c_t[ok], r_t[ok]
                pending[sel] = False
            alpha[loc[~ok]] *= 0.5
        iters[idx] += 1
        active[idx] = ~pending & (res[idx] > CLOSURE_TOL) & (cosine[idx] > STATIONARY_COSINE)
    return state, iters, res, cosine


def _gauss_newton_inverse(jac_g: np.ndarray) -> np.ndarray:
    """Inverse of the Gauss-Newton Hessian with the gauge rows (full rank off singular poses),
    ``(n, k, k)``."""
    gram = np.swapaxes(jac_g, 1, 2) @ jac_g
    gram += 1e-12 * np.trace(gram, axis1=1, axis2=2)[:, None, None] * np.eye(gram.shape[-1])
    return np.linalg.pinv(gram, hermitian=True)


def _dfp_update(h: np.ndarray, s: np.ndarray, y: np.ndarray) -> np.ndarray:
    """DFP update of the inverse Hessian: :math:`H + ss^T/s^Ty - Hyy^TH/y^THy` (skipped where not
    positive)."""
    sy = np.einsum("ni,ni->n", s, y)
    hy = np.einsum("nij,nj->ni", h, y)
    yhy = np.einsum("ni,ni->n", y, hy)
    good = (sy > 1e-300) & (yhy > 1e-300)
    sy, yhy = np.where(good, sy, 1.0), np.where(good, yhy, 1.0)
    upd = (h + np.einsum("ni,nj->nij", s, s) / sy[:, None, None]
           - np.einsum("ni,nj->nij", hy, hy) / yhy[:, None, None])
    return np.where(good[:, None, None], upd, h)


def _better_run(res_a, cos_a, res_b, cos_b) -> np.ndarray:
    """Whether DFP run b beats run a: closed beats stationary beats neither; ties go to the lower residual."""
    def rank(res, cos):
        return np.where(res <= ROUNDING_TOL, 0, np.where(cos <= STATIONARY_COSINE, 1, 2))

    ra, rb = rank(res_a, cos_a), rank(res_b, cos_b)
    return (rb < ra) | ((rb == ra) & (res_b < res_a))


def solve_closure(loop: Loop, inputs: dict[str, np.ndarray], guess: LoopState,
                  max_newton: int = 30, max_dfp: int = 200) -> ClosureResult:
    """Close ``loop`` at every position, starting from ``guess``.

    Parameters
    ----------
    loop : Loop
    inputs : dict of name -> ``(n,)`` array
        Values of the prescribed inputs.
    guess : LoopState
        Initial estimates of the unknowns at the ``n`` positions.

    Returns
    -------
    ClosureResult
    """
    n = guess.scalars.shape[0]
    iters = np.zeros(n, dtype=int)
    residual = np.full(n, np.inf)
    active = np.ones(n, dtype=bool)
    state, _, iters, residual = _newton(loop, inputs, guess, active, iters, residual, max_newton)
    status = np.full(n, ClosureStatus.OK, dtype=np.int8)
    used_dfp = residual > ROUNDING_TOL
    idx = np.flatnonzero(used_dfp)
    if idx.size:
        sub_in = {k: v[idx] for k, v in inputs.items()}
        # DFP from both the estimate and where Newton stalled (batched together); keep the better outcome
        k = idx.size
        both_in = {key: np.concatenate([v, v]) for key, v in sub_in.items()}
        starts = LoopState(np.concatenate([guess.scalars[idx], state.scalars[idx]]),
                           np.concatenate([guess.rotations[idx], state.rotations[idx]]))
        runs, it2, res2, cos2 = davidon_fletcher_powell(loop, both_in, starts, max_dfp)
        pick = _better_run(res2[:k], cos2[:k], res2[k:], cos2[k:])
        rows = np.where(pick, np.arange(k, 2 * k), np.arange(k))
        sub, it, res, cosine = runs.take(rows), it2[:k] + it2[k:], res2[rows], cos2[rows]
        # Newton finishes quadratically where DFP has come near a root (not at a non-zero minimum)
        near = (res > ROUNDING_TOL) & (res < NEAR_ROOT)
        if near.any():
            k = np.flatnonzero(near)
            it_n = np.zeros(k.size, dtype=int)
            polished, _, it_n, res_n = _newton(loop, {key: v[k] for key, v in sub_in.items()}, sub.take(k),
                                               np.ones(k.size, dtype=bool), it_n, res[k].copy(), max_newton)
            better = res_n < res[k]
            sub = sub.put(k[better], polished.take(np.flatnonzero(better)))
            res[k[better]] = res_n[better]
            it[k] += it_n
        state = state.put(idx, sub)
        iters[idx] += it
        residual[idx] = res
        failed = res > ROUNDING_TOL
        status[idx[failed]] = np.where(cosine[failed] <= STATIONARY_COSINE,
                                       ClosureStatus.NO_ASSEMBLY, ClosureStatus.NOT_CONVERGED)
    return ClosureResult(state, status, iters, residual, used_dfp)
