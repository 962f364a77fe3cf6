"""The in-house engine at one position, compiled: closure, edges, rates, reactions, status, one output row.

Per position (:func:`analyze_range` runs a block of them on one thread): the closure strategy of
:mod:`dualmech.models.slider_crank.kernel_nb` (a warm start from the previous position where that is
safe), the edges of assembly (:func:`dualmech.core.assembly.edge_status`), rates from screws
(:func:`dualmech.core.kernel.rates_nb.solve_rates`), inverse dynamics by dual momentum and
D'Alembert (:mod:`dualmech.core.kernel.dynamics_nb` and the closed-form elimination of
:func:`dualmech.core.reactions.solve_reactions`), dead centres, and the last step of
:func:`dualmech.core.status.settle` (``not_finite``, and NaN wherever a row's word does not
give a column).  Status words are integer codes (their positions in
:data:`dualmech.core.status.STATUSES`); :mod:`dualmech.models.slider_crank.kernel` drives the
blocks and turns codes into words.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from dualmech.core.kernel import depends_on_kernel
from dualmech.core.kernel.closure_nb import Work, newton
from dualmech.core.kernel.dual_nb import INLINE, JIT, cross, dot
from dualmech.core.kernel.dynamics_nb import required_wrench
from dualmech.core.kernel.rates_nb import solve_rates
from dualmech.core.kernel.universal_nb import universal_motion
from dualmech.models.slider_crank.kernel_nb import (
    FINE_SPAN,
    Rules,
    Scratch,
    close_reachable,
    pins,
    reach_and_foot,
    set_values,
    slider_line,
    warm_start,
)

depends_on_kernel(__file__)

#: Rows of the output array, in this order (the names of ``docs/conventions.md``, "Output columns").
OUT_COLUMNS: tuple[str, ...] = (
    "theta1_deg",
    "S1",
    "S4",
    "S4_dot",
    "S4_ddot",
    "j1_fx",
    "j1_fy",
    "j1_fz",
    "j1_mx",
    "j1_my",
    "j1_mz",
    "j2_fx",
    "j2_fy",
    "j2_fz",
    "j3_fx",
    "j3_fy",
    "j3_fz",
    "j3_mx",
    "j3_my",
    "j3_mz",
    "j4_fx",
    "j4_fy",
    "j4_fz",
    "j4_mx",
    "j4_my",
    "j4_mz",
    "slider_load",
    "drive_torque",
    "transmission",
    "residual",
    "closure_condition",
)
_THETA, _S1, _S4, _S4_DOT, _S4_DDOT, _REACT, _TRANS, _RESID, _COND = 0, 1, 2, 3, 4, 5, 28, 29, 30
#: Reaction columns (``_REACT`` onward).
N_REACT = 23
#: Largest crank-angle step [rad] across which a position starts from its predecessor (2 degrees:
#: the thesis's grids are 1 degree; a coarser grid starts every position cold, as the numpy solver).
WARM_SPAN = math.radians(2.0)


@njit(**INLINE)
def _rod_force(
    need: np.ndarray,
    p2: np.ndarray,
    p3: np.ndarray,
    k4: np.ndarray,
    torque: float,
    load: float,
    axis: np.ndarray,
    v: np.ndarray,
) -> float:
    """The joint-3 force's part ``j3'`` normal to the rod into ``v[3]``, the rod's unit vector ``u`` into
    ``v[1]``, the universal joint's moment (zero for a ball, ``axis`` zero) into ``v[14]``; returns the
    multiplier ``lambda`` of ``u`` that the given torque (or slider load) fixes
    (:func:`dualmech.core.reactions.solve_reactions`, steps 1-2)."""
    d, u, k2, j3p, j2p, t, j3m = v[0], v[1], v[2], v[3], v[4], v[5], v[14]
    for i in range(3):
        d[i] = p3[i] - p2[i]
    a2 = math.sqrt(dot(d, d))
    for i in range(3):
        u[i] = d[i] / a2
    cross(p2, need[1, 0], t)
    for i in range(3):
        k2[i] = need[1, 1, i] - t[i]
    n_u = dot(axis, u)
    mu = -dot(u, k2) / n_u if n_u != 0.0 else 0.0
    for i in range(3):
        j3m[i] = mu * axis[i]
        k2[i] += j3m[i]
    cross(u, k2, j3p)
    for i in range(3):
        j3p[i] /= a2
        j2p[i] = need[1, 0, i] + j3p[i]
    cross(p2, j2p, t)
    tau0 = need[0, 1, 2] + t[2]
    cross(p2, u, t)
    lever = t[2]
    s0 = 0.0  # the slider's own need along k4, less j3'
    for i in range(3):
        s0 += (need[2, 0, i] - j3p[i]) * k4[i]
    return (torque - tau0) / lever if math.isfinite(torque) else (s0 - load) / dot(u, k4)


@njit(**INLINE)
def _reactions(
    need: np.ndarray,
    p2: np.ndarray,
    p3: np.ndarray,
    k4: np.ndarray,
    torque: float,
    load: float,
    axis: np.ndarray,
    v: np.ndarray,
    out: np.ndarray,
) -> float:
    """The 23 reaction columns into ``out`` (order of :data:`OUT_COLUMNS`); returns the Newton-Euler residual.

    :func:`dualmech.core.reactions.solve_reactions` for one position: ``need`` ``(3, 2, 3)``
    what the joints must supply to crank, rod and slider; ``axis`` the universal joint's moment
    axis ``n`` (zero: a ball joint); ``v`` ``(16, 3)`` scratch (rows 13 and 15 the residual's: row 14
    holds the universal joint's moment until the residual has read it).
    """
    lam = _rod_force(need, p2, p3, k4, torque, load, axis, v)
    u, j3p, t, j3, j2 = v[1], v[3], v[5], v[6], v[7]
    j3m = v[14]
    j1f, j1m, j4f, j4mo, j4m = v[8], v[9], v[10], v[11], v[12]
    for i in range(3):
        j3[i] = j3p[i] + lam * u[i]
        j2[i] = need[1, 0, i] + j3[i]
        j1f[i] = need[0, 0, i] + j2[i]
        j4f[i] = need[2, 0, i] - j3[i]
    cross(p2, j2, t)
    for i in range(3):
        j1m[i] = need[0, 1, i] + t[i]
    cross(p3, j3, t)
    for i in range(3):
        j4mo[i] = need[2, 1, i] - t[i] - j3m[i]
    cross(p3, j4f, t)
    for i in range(3):
        j4m[i] = j4mo[i] - t[i]
        out[i], out[3 + i], out[6 + i] = j1f[i], j1m[i], j2[i]
        out[9 + i], out[12 + i], out[15 + i], out[18 + i] = j3[i], j3m[i], j4f[i], j4m[i]
    out[21], out[22] = dot(j4f, k4), j1m[2]
    return _newton_euler_residual(need, p2, p3, j1f, j1m, j2, j3, j3m, j4f, j4mo, v[13], v[15])


@njit(**INLINE)
def _newton_euler_residual(need, p2, p3, f1, m1, j2, j3, j3m, f4, m4o, t2, t3) -> float:
    """Largest violation of the 18 equations (:func:`dualmech.core.reactions._newton_euler_residual`);
    ``t2``, ``t3`` ``(3,)`` scratch, distinct from every other argument."""
    cross(p2, j2, t2)
    cross(p3, j3, t3)
    f_err, m_err, f_scale, m_big = 0.0, 0.0, 0.0, 0.0
    for i in range(3):
        f_err = max(
            f_err,
            abs(f1[i] - j2[i] - need[0, 0, i]),
            abs(j2[i] - j3[i] - need[1, 0, i]),
            abs(j3[i] + f4[i] - need[2, 0, i]),
        )
        m_err = max(
            m_err,
            abs(m1[i] - t2[i] - need[0, 1, i]),
            abs(t2[i] - t3[i] - j3m[i] - need[1, 1, i]),
            abs(t3[i] + m4o[i] + j3m[i] - need[2, 1, i]),
        )
        f_scale = max(f_scale, abs(f1[i]), abs(j2[i]), abs(j3[i]), abs(f4[i]))
        m_big = max(m_big, abs(m1[i]), abs(m4o[i]))
    f_scale = max(f_scale, 1e-300)
    m_scale = max(m_big, f_scale * max(math.sqrt(dot(p2, p2)), math.sqrt(dot(p3, p3))))
    return max(f_err / f_scale, m_err / m_scale)


@njit(**INLINE)
def _dynamics(
    rules: Rules,
    g: tuple,
    universal: bool,
    crank: np.ndarray,
    i: int,
    body: tuple,
    w: Work,
    sc: Scratch,
    p2: np.ndarray,
    p3: np.ndarray,
    k4: np.ndarray,
    col: np.ndarray,
) -> float:
    """Rates, transmission and reactions of a closed position into ``col`` (the rod's spin by the
    universal joint at ``P3`` where ``universal``); returns the Newton-Euler residual."""
    fl, mass, com, inertia, gravity, torque, load = body
    sc.rates[:] = 0.0
    sc.rates[0, rules.vidx[0]], sc.rates[0, rules.vidx[1]] = crank[2, i], crank[3, i]
    sc.rates[1, rules.vidx[0]], sc.rates[1, rules.vidx[1]] = crank[4, i], crank[5, i]
    solve_rates(fl, sc.rates[0], sc.rates[1], w)
    col[_S4_DOT], col[_S4_DDOT] = w.q_dot[0], w.q_ddot[0]
    hub, need, rot = sc.vec[8], sc.need, sc.mats[3]
    hub[0], hub[1], hub[2] = 0.0, 0.0, g[1]
    col[_TRANS] = ((p2[0] - hub[0]) * (p3[1] - p2[1]) - (p2[1] - hub[1]) * (p3[0] - p2[0])) / g[3] / g[2]
    rot[:] = 0.0
    for k in range(3):
        rot[k, k] = 1.0
    axis = sc.wide[31]
    axis[:] = 0.0
    rod_frame = w.frames[1, 0]
    if universal:
        rod_frame = sc.mats[4]
        universal_motion(w.twists[1], w.accels[1], p2, p3, k4, rod_frame, axis, sc.wide[24:31])
    frames = (w.frames[0, 0], rod_frame, rot)
    origins = (hub, p2, p3)
    for b in range(3):
        required_wrench(
            mass[b],
            com[b],
            inertia[b],
            frames[b],
            origins[b],
            w.twists[b],
            w.accels[b],
            gravity,
            sc.wide[16:24],
            need[b],
        )
    return _reactions(need, p2, p3, k4, torque, load, axis, sc.wide[:16], col[_REACT : _REACT + N_REACT])


@njit(**INLINE)
def _settle(rules: Rules, status: int, col: np.ndarray) -> int:
    """``not_finite`` where a given column is not finite, then NaN where the word does not give it
    (:func:`dualmech.core.status.settle`)."""
    ok, dead, not_finite = rules.codes[0], rules.codes[1], rules.codes[6]
    pose = status == rules.codes[2] or status == rules.codes[7]  # assembly_limit, joint_lock: the pose only
    n_check = 5 + N_REACT if status == ok else (5 if status == dead else (2 if pose else 0))
    checks = (_S4, _COND, _S4_DOT, _S4_DDOT, _TRANS)
    for k in range(n_check):
        c = checks[k] if k < 5 else _REACT + k - 5
        if not math.isfinite(col[c]):
            status, pose = not_finite, False
    if status != ok:
        col[_REACT : _REACT + N_REACT] = np.nan
    if status != ok and status != dead:
        col[_S4_DOT], col[_S4_DDOT], col[_TRANS] = np.nan, np.nan, np.nan
    if status != ok and status != dead and not pose:
        col[_S4], col[_COND] = np.nan, np.nan
    return status


@njit(**INLINE)
def _close(
    fl, rules: Rules, crank: np.ndarray, i: int, g: tuple, rho: float, warm: bool, w: Work, sc: Scratch
) -> tuple[int, int, float, bool]:
    """Close position ``i`` (reachable; ``rho`` its reach over ``a2``) into ``sc.x[0]``: from position
    ``i - 1`` where ``warm`` and :func:`~dualmech.models.slider_crank.kernel_nb.warm_start` accepts, else by
    the
    cold strategy; closed nearer an edge of assembly than ``rules.refine_condition`` (not at its limit),
    on to the rounding level (:func:`dualmech.core.closure.refine`).  Returns (status code, iterations,
    residual, whether the frames in ``w`` hold the state: an accepted warm start, not refined)."""
    accepted, it, residual, word = False, 0, 0.0, rules.codes[0]
    if warm:
        speed, turn = crank[2, i - 1], crank[0, i] - crank[0, i - 1]
        step = turn / speed if speed != 0.0 else 0.0
        bend = crank[4, i - 1] / speed if speed != 0.0 and abs(turn) <= FINE_SPAN else np.nan
        accepted, it, residual = warm_start(fl, rules, g, step, bend, w, sc)
    if not accepted:
        word, more, residual = close_reachable(fl, rules, g, w, sc)
        it += more
    c2 = 1.0 - rho * rho  # the geometric closure condition, squared: an assembly_limit below the band
    if word == rules.codes[0] and rules.limit_band**2 <= c2 < rules.refine_condition**2:
        set_values(rules.vidx, g, sc.vals)
        more, residual = newton(fl, sc.vals, sc.x[0], rules.refine_tols, w)
        it, accepted = it + more, False
    return word, it, residual, accepted


@njit(**INLINE)
def _position(
    i: int,
    fl,
    rules: Rules,
    crank: np.ndarray,
    case_of: np.ndarray,
    geo: np.ndarray,
    bodies: tuple,
    w: Work,
    sc: Scratch,
    out: np.ndarray,
    status: np.ndarray,
    iters: np.ndarray,
    dyn: np.ndarray,
    warm: bool,
) -> bool:
    """Analyse position ``i`` into column ``i`` of ``out``, with its status code, iterations and
    dynamics residual; ``warm``: whether position ``i - 1`` left a closed state and its rates in
    ``sc``, ``w`` to start from.  Returns whether position ``i`` leaves them for ``i + 1``."""
    c = case_of[i]
    g = (crank[0, i], crank[1, i], geo[c, 0], geo[c, 1], geo[c, 2], geo[c, 3])
    col = out[:, i]
    col[:] = np.nan
    col[_THETA], col[_S1] = math.degrees(g[0]), g[1]
    rho, foot = reach_and_foot(g)
    beyond = rho > 1.0 + rules.reach_tol
    word, it, residual, closed = rules.codes[5], 0, max(rho - 1.0, 0.0), False
    accepted = False
    if not beyond:
        word, it, residual, accepted = _close(fl, rules, crank, i, g, rho, warm, w, sc)
        closed = word == rules.codes[0]
    col[_RESID] = residual
    k4, p2, p3 = sc.vec[11], sc.vec[12], sc.vec[13]
    cond = math.sqrt(1.0 - min(rho, 1.0) ** 2)
    if closed:
        k4_t = slider_line(g)[1]
        p2_t, p3_t = pins(fl, rules.vidx, g, sc.x[0], sc.vals, w.frames, w.lines, w.turns, accepted)
        for k in range(3):
            k4[k], p2[k], p3[k] = k4_t[k], p2_t[k], p3_t[k]
        rod = (p3[0] - p2[0], p3[1] - p2[1], p3[2] - p2[2])
        cond = abs(rod[0] * k4[0] + rod[1] * k4[1] + rod[2] * k4[2]) / math.sqrt(
            rod[0] * rod[0] + rod[1] * rod[1] + rod[2] * rod[2]
        )
    if not beyond and word == rules.codes[5]:
        word = rules.codes[4]
    if not beyond and cond < rules.limit_band:
        word = rules.codes[2]
    col[_COND] = np.nan if beyond else cond
    col[_S4] = foot if (word == rules.codes[2] and not closed) else sc.x[0, 0]
    dyn[i] = np.nan
    if word == rules.codes[0]:
        torque, load = bodies[4][c], bodies[5][c]
        body = (fl, bodies[0][c], bodies[1][c], bodies[2][c], bodies[3][c], torque, load)
        locked = geo[c, 4] != 0.0 and cond >= rules.joint_lock  # spin undetermined: gauge's (pose only)
        dyn[i] = _dynamics(rules, g, geo[c, 4] != 0.0 and not locked, crank, i, body, w, sc, p2, p3, k4, col)
        dead = math.isfinite(torque) and abs(col[_TRANS]) < rules.dead_centre
        word = rules.codes[7] if locked else (rules.codes[1] if dead else word)
    status[i] = _settle(rules, word, col)
    iters[i] = it
    return status[i] == rules.codes[0] or status[i] == rules.codes[1] or status[i] == rules.codes[7]


@njit(**JIT)
def analyze_range(
    lo: int,
    hi: int,
    w: Work,
    sc: Scratch,
    fl,
    rules: Rules,
    crank: np.ndarray,
    case_of: np.ndarray,
    geo: np.ndarray,
    bodies: tuple,
    out: np.ndarray,
    status: np.ndarray,
    iters: np.ndarray,
    dyn: np.ndarray,
    cold: np.ndarray,
) -> None:
    """Analyse positions ``lo..hi-1`` into the preallocated outputs (one thread; the GIL released).

    ``crank`` ``(6, n)``: theta, S1 and their first and second rates; ``case_of`` ``(n,)``
    the case of each position; ``geo`` ``(cases, 5)``: a1, a2, a4, alpha4 and 1 where joint 3 is
    universal (0: ball); ``bodies``: per
    case the masses ``(cases, 3)``, centres of mass ``(cases, 3, 3)``, inertias ``(cases, 3, 3, 3)``
    of crank, rod and slider, gravity ``(cases, 3)``, the given drive torque and slider load
    ``(cases,)`` (NaN where not given); ``out`` ``(len(OUT_COLUMNS), n)`` (a column per position, written
    where it is computed: each output is then one contiguous row, what a writer takes as it is), ``status``,
    ``iters``, ``dyn`` ``(n,)``; ``cold`` ``(n,)`` bool: the positions that start cold
    (:func:`~dualmech.models.slider_crank.kernel.chain_starts`; ``lo`` must be one); ``w``, ``sc``:
    this thread's scratch (:func:`~dualmech.models.slider_crank.kernel._scratch`).
    """
    warm = False
    for i in range(lo, hi):
        warm = warm and not cold[i] and abs(crank[0, i] - crank[0, i - 1]) <= WARM_SPAN
        warm = _position(i, fl, rules, crank, case_of, geo, bodies, w, sc, out, status, iters, dyn, warm)
