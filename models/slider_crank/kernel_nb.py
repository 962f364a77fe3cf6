"""The slider crank's closure strategy at one position, compiled: start estimates, branch, retries.

The per-position form of the strategy in :mod:`dualmech.models.slider_crank.analysis`
(:func:`~dualmech.models.slider_crank.analysis.close_loop`): the plane-geometry estimate of
``S4`` (thesis section 2.6.2), the branch-seeking estimate with the rod laid along
the slider line, geometric continuation from the planar mechanism, and the branch
rule :math:`(P_3 - P_2)\\cdot k_4 < 0` (``docs/conventions.md``).  The loop itself is
closed by the generic kernel (:func:`dualmech.core.kernel.dfp_nb.solve_closure`).

A position's geometry is the tuple ``g = (theta1, S1, a1, a2, a4, alpha4)``; its
state ``x`` is ``S4`` then the two ball rotations (row-major), the layout of
:data:`~dualmech.models.slider_crank.analysis.LOOP` flattened by
:func:`~dualmech.core.kernel.loop_nb.flatten`.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from dualmech.core.kernel import depends_on_kernel
from dualmech.core.kernel.closure_nb import (
    NO_ASSEMBLY,
    NOT_CONVERGED,
    OK,
    ClosureTols,
    Work,
    newton,
    retract,
    second_order_step,
)
from dualmech.core.kernel.dfp_nb import solve_closure
from dualmech.core.kernel.dual_nb import ALLOC, INLINE, JIT, copy, tmul
from dualmech.core.kernel.loop_nb import FlatLoop, closure_residual, evaluate, frame_origin, length_scale

depends_on_kernel(__file__)

#: Newton iterations a warm start may take and still be trusted (:func:`warm_start`): from the previous
#: position of a 1-degree grid the predictor leaves an error of ~1e-4 of the scale, which quadratic
#: convergence removes in 2-3 iterations; a start that needs more may sit in another basin.
WARM_ITERATIONS = 3
#: Largest crank step [rad] at which a warm start is predicted to second order (:func:`warm_start`): its
#: error, about step^3/6 of the pose's third derivative in the crank angle, is then ~2e-16 of it (grids
#: of 0.00057 degrees or finer, e.g. 10^6 positions a revolution), below the closure's round-off, so the
#: start is closed as it is.  On coarser grids the first-order start stays: there a second-order one
#: left Newton closures just under the tolerance instead of at round-off (1.7 instead of 2.0 steps on
#: the 1-degree grid, and reactions 1.4e-11 off the numpy solver's at one position).
FINE_SPAN = 1e-5


class Rules(NamedTuple):
    """What the per-position analysis needs besides the data (read from their homes at call time).

    ``vidx`` ``(6,)``: indices in ``vals`` of theta1, S1, a1, a2, a4, alpha4; ``codes``
    ``(8,)``: the codes of ok, dead_centre, assembly_limit, branch_jump, not_converged,
    no_assembly, not_finite, joint_lock (positions in :data:`dualmech.core.status.STATUSES`);
    ``refine_tols`` those of :func:`dualmech.core.closure.refine` (closed at the rounding level), for rows
    closer to an edge of assembly than ``refine_condition``.
    """

    tols: ClosureTols
    refine_tols: ClosureTols
    refine_condition: float
    vidx: np.ndarray
    codes: np.ndarray
    reach_tol: float
    limit_band: float
    dead_centre: float
    joint_lock: float
    continuation_steps: int


class Scratch(NamedTuple):
    """Per-thread arrays of the slider crank's strategy (``V`` values, ``S`` state)."""

    vals: np.ndarray  # (V,)
    rates: np.ndarray  # (2, V): input rates and accelerations
    x: np.ndarray  # (3, S): the state, a second attempt, the continuation
    vec: np.ndarray  # (16, 3)
    mats: np.ndarray  # (5, 3, 3)
    need: np.ndarray  # (3, 2, 3): what the joints supply to crank, rod, slider
    wide: np.ndarray  # (32, 3): vectors of the reaction elimination and of the universal joint


@njit(**ALLOC)
def make_scratch(n_vals: int, n_state: int) -> Scratch:
    return Scratch(
        np.zeros(n_vals),
        np.zeros((2, n_vals)),
        np.zeros((3, n_state)),
        np.zeros((16, 3)),
        np.zeros((5, 3, 3)),
        np.zeros((3, 2, 3)),
        np.zeros((32, 3)),
    )


@njit(**JIT)
def set_values(vidx: np.ndarray, g: tuple, vals: np.ndarray) -> None:
    """``vals`` of the loop at geometry ``g`` (:meth:`dualmech.models.slider_crank.analysis.Batch.inputs`)."""
    for k in range(6):
        vals[vidx[k]] = g[k]


@njit(**JIT)
def slider_line(g: tuple) -> tuple:
    """``F``, ``k4`` and the crank pin ``P2`` at geometry ``g`` (``docs/conventions.md``), 3-tuples."""
    th, s1, a1, _, a4, al4 = g
    return (-a4, 0.0, 0.0), (0.0, math.sin(al4), math.cos(al4)), (a1 * math.cos(th), a1 * math.sin(th), s1)


@njit(**JIT)
def reach_and_foot(g: tuple) -> tuple[float, float]:
    """``rho / a2`` and the ``S4`` of the foot of the perpendicular from ``P2``
    (:func:`dualmech.core.assembly.reach`, :func:`~dualmech.core.assembly.foot_s4`)."""
    f, k4, p2 = slider_line(g)
    d = (p2[0] - f[0], p2[1] - f[1], p2[2] - f[2])
    along = d[0] * k4[0] + d[1] * k4[1] + d[2] * k4[2]
    return math.sqrt(max(d[0] * d[0] + d[1] * d[1] + d[2] * d[2] - along**2, 0.0)) / g[3], -along


@njit(**JIT)
def planar_estimate(g: tuple) -> float:
    """:func:`dualmech.models.slider_crank.analysis.planar_estimate` at one position."""
    th, _, a1, a2, a4, al4 = g
    side = 1.0 if math.sin(al4) < 0 else -1.0
    return side * a1 * math.sin(th) + math.sqrt(max(a2**2 - (a1 * math.cos(th) + a4) ** 2, 0.0))


@njit(**JIT)
def along_slider_estimate(g: tuple) -> float:
    """:func:`dualmech.models.slider_crank.analysis.along_slider_estimate` at one position."""
    f, k4, p2 = slider_line(g)
    return g[3] - ((p2[0] - f[0]) * k4[0] + (p2[1] - f[1]) * k4[1] + (p2[2] - f[2]) * k4[2])


@njit(**JIT)
def on_branch(g: tuple, s4: float) -> bool:
    """``(P3 - P2)·k4 < 0`` with ``P3 = F - S4 k4``: the conventions' assembly branch."""
    f, k4, p2 = slider_line(g)
    return (f[0] - s4 * k4[0] - p2[0]) * k4[0] + (f[1] - s4 * k4[1] - p2[1]) * k4[1] + (
        f[2] - s4 * k4[2] - p2[2]
    ) * k4[2] < 0


@njit(**JIT)
def _unit(v: tuple) -> tuple:
    n = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    return v[0] / n, v[1] / n, v[2] / n


@njit(**JIT)
def _cross(a: tuple, b: tuple) -> tuple:
    return a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]


@njit(**JIT)
def state_from_slider(g: tuple, s4: float, x: np.ndarray) -> None:
    """:func:`dualmech.models.slider_crank.analysis.state_from_slider` at one position, into ``x``."""
    f, k4, p2 = slider_line(g)
    u = _unit((f[0] - s4 * k4[0] - p2[0], f[1] - s4 * k4[1] - p2[1], f[2] - s4 * k4[2] - p2[2]))
    ref = (1.0, 0.0, 0.0) if abs(u[2]) > 0.9 else (0.0, 0.0, 1.0)
    v = _unit(_cross(ref, u))
    w = _cross(u, v)
    rod = (u[0], v[0], w[0], u[1], v[1], w[1], u[2], v[2], w[2])  # columns u, v, w
    c, s = math.cos(g[0]), math.sin(g[0])
    rz_t = (c, s, 0.0, -s, c, 0.0, 0.0, 0.0, 1.0)  # Rz(theta1)^T
    ang = -g[5] - math.pi / 2
    c, s = math.cos(ang), math.sin(ang)
    rx = (1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c)
    rod_t = (rod[0], rod[3], rod[6], rod[1], rod[4], rod[7], rod[2], rod[5], rod[8])
    ball2, ball3 = (
        tmul(rz_t, rod),
        tmul(rod_t, rx),
    )  # ball 2 = Rz^T R_rod, ball 3 = R_rod^T Rx(-alpha4 - pi/2)
    x[0] = s4
    for k in range(9):
        x[1 + k], x[10 + k] = ball2[k], ball3[k]


@njit(**JIT)
def _blend(g: tuple, lam: float) -> tuple:
    """Geometry ``lam`` of the way from the planar reference to ``g``
    (:func:`~dualmech.models.slider_crank.analysis._blend`)."""
    th, s1, a1, a2, a4, al4 = g
    ref = 1.5 * math.pi if math.sin(al4) < 0 else 0.5 * math.pi
    diff = (al4 - ref + math.pi) % (2 * math.pi) - math.pi
    return (th, lam * s1, a1, a2, a4, ref + lam * diff)


@njit(**JIT)
def _attempt(
    fl: FlatLoop, rules: Rules, g: tuple, s4: float, x: np.ndarray, vals: np.ndarray, w: Work
) -> tuple[int, int, float]:
    """Close from the state that points the rod toward the slider at ``s4``: (code, iterations, residual)."""
    state_from_slider(g, s4, x)
    set_values(rules.vidx, g, vals)
    return solve_closure(fl, vals, x, rules.tols, w)


@njit(**JIT)
def continuation(fl: FlatLoop, rules: Rules, g: tuple, x: np.ndarray, vals: np.ndarray, w: Work) -> bool:
    """:func:`dualmech.models.slider_crank.analysis.continuation` at one position: whether every step closed
    on the branch."""
    start = _blend(g, 0.0)
    state_from_slider(start, planar_estimate(start), x)
    steps = rules.continuation_steps
    for k in range(steps + 1):
        b = _blend(g, 1.0 if k == steps else k * (1.0 / steps))
        set_values(rules.vidx, b, vals)
        code, _, _ = solve_closure(fl, vals, x, rules.tols, w)
        if not (code == OK and on_branch(b, x[0])):
            return False
    return True


@njit(**INLINE)
def warm_start(
    fl: FlatLoop, rules: Rules, g: tuple, step: float, bend: float, w: Work, sc: Scratch
) -> tuple[bool, int, float]:
    """Close from the previous position's state ``sc.x[0]`` (into ``sc.x[1]``), moved ``step`` times
    its rates ``w.q_dot`` (the crank's time step to here, 0 without a predictor): (accepted, iterations,
    residual).

    Accepted only if Newton alone closes within :data:`WARM_ITERATIONS` on the conventions' branch:
    a quick quadratic convergence says the start lies in the root's own basin, so the cold
    strategy (:func:`close_reachable`) would reach the same root (statuses stay those of the numpy
    solver, which starts every position cold).  The caller offers it only between consecutive
    positions of one case whose previous one closed (``ok`` or ``dead_centre``), i.e. never across
    an edge of assembly or a branch change.

    On a fine grid (a crank step of at most :data:`FINE_SPAN`; ``bend`` = the crank's acceleration over
    its speed there, NaN elsewhere) the start is second order in the crank angle: the pose is a function
    of the angle alone, x(theta), with x' = q_dot / theta_dot and
    x'' = (q_ddot - q_dot theta_ddot / theta_dot) / theta_dot^2, so the change is
    ``step`` (q_dot + ``step`` (q_ddot - q_dot ``bend``) / 2) in time steps, closed to round-off there
    (Newton takes no step).
    """
    x = sc.x[1]
    copy(sc.x[0], x)
    if step != 0.0 and bend == bend:
        # w.step: scratch here, newton() starts by clearing it
        second_order_step(fl.n_scalar, x, w.q_dot, w.q_ddot, step, bend, w.step, x)
    elif step != 0.0:
        retract(fl.n_scalar, x, w.q_dot, step, x)
    set_values(rules.vidx, g, sc.vals)
    iters, residual = newton(fl, sc.vals, x, rules.tols, w)  # stopped early: w.frames hold x
    accepted = iters <= WARM_ITERATIONS and not residual > rules.tols.rounding and on_branch(g, x[0])
    if accepted:
        copy(x, sc.x[0])
    return accepted, iters, residual


@njit(**JIT)
def close_reachable(fl: FlatLoop, rules: Rules, g: tuple, w: Work, sc: Scratch) -> tuple[int, int, float]:
    """:func:`dualmech.models.slider_crank.analysis._close_reachable` at one position, the state into
    ``sc.x[0]``.

    Returns (status code of :class:`Rules`, iterations, closure residual).
    """
    x, again, vals, codes = sc.x[0], sc.x[1], sc.vals, rules.codes
    code, iters, residual = _attempt(fl, rules, g, planar_estimate(g), x, vals, w)
    wrong = code == OK and not on_branch(g, x[0])
    if code == NOT_CONVERGED or wrong:  # second estimate: the rod laid along the slider line
        code2, it2, res2 = _attempt(fl, rules, g, along_slider_estimate(g), again, vals, w)
        iters += it2
        if code2 != NOT_CONVERGED and not (code2 == OK and not on_branch(g, again[0])):
            copy(again, x)
            code, residual, wrong = code2, res2, False
    status = codes[5] if code == NO_ASSEMBLY else codes[0]
    if code == NOT_CONVERGED or wrong:
        if continuation(fl, rules, g, sc.x[2], vals, w):
            copy(sc.x[2], x)
        elif code == OK:
            status = codes[3]
        else:
            status = codes[4]
        set_values(rules.vidx, g, vals)
        evaluate(fl, vals, x, w.frames, w.lines, w.turns)
        residual = closure_residual(w.frames, length_scale(fl, vals))
    return status, iters, residual


@njit(**INLINE)
def pins(
    fl: FlatLoop,
    vidx: np.ndarray,
    g: tuple,
    x: np.ndarray,
    vals: np.ndarray,
    frames: np.ndarray,
    lines: np.ndarray,
    turns: np.ndarray,
    fresh: bool,
) -> tuple:
    """Evaluate the loop at ``x`` (into ``frames``, ``lines``; not if ``fresh``: they hold it already, as
    after an accepted :func:`warm_start`) and give the ball centres ``P2``, ``P3``."""
    if not fresh:
        set_values(vidx, g, vals)
        evaluate(fl, vals, x, frames, lines, turns)
    return frame_origin(frames, 0), frame_origin(frames, 1)
