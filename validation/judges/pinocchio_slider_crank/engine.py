"""Pinocchio judge: the result table of a case computed by Pinocchio alone.

The model is :func:`~dualmech.validation.judges.pinocchio_slider_crank.model.build_model` (a tree
cut at joint 3, closed by a 3-D point constraint).  Nothing here imports or is
seeded by the in-house solver (``dualmech.models.slider_crank.analysis`` / ``dualmech.core``
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
         + \\begin{bmatrix} a^{cl}_{end} - a^{cl}_{pin} \\\\ \\dot\\omega_{rod,x} \\end{bmatrix}_{\\ddot
         q_{free}=0} = 0,

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
   reference points (joint 4 about ``P3``).  With a universal joint at P3 the
   closure also carries the moment :math:`\\mu n` of the slider on the rod
   (``pinocchio_dynamics``), added to the closure wrench the same way; the
   ``j3_m`` columns are :math:`-\\mu n` (0 with a ball).

Step 1 is :mod:`~dualmech.validation.judges.pinocchio_slider_crank.closure`, steps 2-3 are
:mod:`~dualmech.validation.judges.pinocchio_slider_crank.dynamics`; this module runs them on a case
(:func:`solve`), adds the edges of assembly and dead centres, and writes the table.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from dualmech.core.assembly import edge_status, foot_s4, reach
from dualmech.core.status import flag_joint_lock, settle
from dualmech.core.table import REACTION_COLUMNS, STATUSES, ResultTable
from dualmech.models.case import Case
from dualmech.validation import tolerances
from dualmech.validation.judges.pinocchio_slider_crank.closure import (
    DEAD,
    LIMIT,
    NO_ASSEMBLY,
    OK,
    STATUS_WORDS,
    Closure,
    close_positions,
    length_scale,
)
from dualmech.validation.judges.pinocchio_slider_crank.dynamics import (
    closed_loop_inverse_dynamics,
    rates_and_rnea,
)
from dualmech.validation.judges.pinocchio_slider_crank.model import (
    PinocchioSliderCrank,
    build_model,
    slider_axis,
)

ENGINE = "pinocchio"


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
    closure_moment : numpy.ndarray, shape (n, 3)
        mu n, the moment of the slider on the rod through the universal joint, world axes (0 with a ball).
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
    closure_moment: np.ndarray
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



def _geometry_at(closure: Closure, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """P2, P3, u, crank origin at configuration ``q`` (for rows whose closure failed), each (3,)."""
    model, data, pm = closure.model, closure.data, closure.pm
    pin.forwardKinematics(model, data, q)
    rod = data.oMi[pm.rod_joint]
    return (rod.translation.copy(), data.oMi[pm.slider_joint].translation.copy(), rod.rotation[:, 0].copy(),
            data.oMi[pm.crank_joint].translation.copy())


def _edges(closure: Closure, pos: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Status codes, closure condition (n,) and configurations (n, 7) with the edges of assembly applied.

    :func:`dualmech.core.assembly.edge_status` on Pinocchio's own poses: the condition of a
    closed row is its ``|u·k4|`` (and its reach ``sqrt(1 - c^2)``); other rows get the reach
    of Pinocchio's crank pin.  An ``assembly_limit`` row whose closure failed is put at the
    limit pose (``S4`` of the foot of the perpendicular from ``P2``).
    """
    pm, q = closure.pm, pos["q"].copy()
    closed = pos["status"] == OK
    failed = np.flatnonzero(~closed)
    with np.errstate(invalid="ignore"):
        rho = np.sqrt(1.0 - np.minimum(pos["condition"], 1.0) ** 2)
    p2 = np.array([_geometry_at(closure, q[i])[0] for i in failed]).reshape(-1, 3)
    rho[failed] = reach(p2, pm.F, pm.k4, pm.a2)
    words, condition = edge_status(STATUS_WORDS[pos["status"]], closed, rho, pos["condition"],
                                   tolerances.ASSEMBLY_REACH.value, tolerances.ASSEMBLY_LIMIT_CONDITION.value)
    status = np.array([STATUSES.index(w) for w in words], dtype=int)
    at_limit = status[failed] == LIMIT
    q[failed[at_limit], pm.q_slider.start] = foot_s4(p2[at_limit], pm.F, pm.k4)
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
    state = case.own_crank_states()
    closure = Closure(pm, length_scale(case, state))
    t1 = time.perf_counter()
    pos = close_positions(closure, case, state)
    t2 = time.perf_counter()
    status, condition, q = _edges(closure, pos)
    rows = np.flatnonzero(status == OK)
    dyn = rates_and_rnea(closure, case, {**pos, "q": q}, state, rows)
    n = len(state)
    p2, p3, u, o1 = (_full(n, dyn[key], rows) for key in ("p2", "p3", "u", "crank_origin"))
    for i in np.flatnonzero(status != OK):
        p2[i], p3[i], u[i], o1[i] = _geometry_at(closure, pos["q"][i])
    if case.loads.mode == "torque":
        dead = np.abs(_transmission(p2, o1, u, pm.a1)[rows]) < tolerances.DEAD_CENTRE_TRANSMISSION.value
        status[rows[dead]] = DEAD
        keep = ~dead
    else:
        keep = np.ones(rows.size, dtype=bool)
    solution = PinocchioSolution(
        q=q, v=_full(n, dyn["v"], rows), a=_full(n, dyn["a"], rows),
        p2=p2, p3=p3, u=u, crank_origin=o1,
        status=status, iterations=pos["iterations"], residual=pos["residual"], condition=condition,
        **_efforts(case, pm, pos, dyn, n, rows, keep),
    )
    t3 = time.perf_counter()
    timings = {"model": t1 - t0, "positions": t2 - t1, "dynamics": t3 - t2}
    return solution, timings


def _full(n: int, values: np.ndarray, at: np.ndarray) -> np.ndarray:
    """``values`` (m, ...) at rows ``at`` of an (n, ...) array that is NaN elsewhere."""
    out = np.full((n, *values.shape[1:]), np.nan)
    out[at] = values
    return out


def _efforts(case: Case, pm: PinocchioSliderCrank, pos: dict[str, np.ndarray], dyn: dict[str, np.ndarray],
             n: int, rows: np.ndarray, keep: np.ndarray) -> dict[str, np.ndarray]:
    """Efforts, closure force, joint wrenches and least-squares residual, each (n, ...), at ``rows[keep]``.

    The closure force enters the ``rnea`` wrenches by superposition (step 4 of the module docstring);
    every other row is NaN.
    """
    live = rows[keep]
    jc = pos["AB"][live, :4 if pm.universal else 3]  # (m, 3 or 4, nv): constraint rows of the closure pass
    effort, multipliers, ls_res = closed_loop_inverse_dynamics(case, pm, dyn["tau0"][keep], jc)
    lam = multipliers[:, :3]
    moment = multipliers[:, 3:] * dyn["n"][keep] if pm.universal else np.zeros_like(lam)
    f0 = dyn["f0"][keep]
    closure_wrench = np.concatenate([lam, np.cross(dyn["p3"][keep], lam) + moment], axis=1)
    return {
        "effort": _full(n, effort, live), "closure_force": _full(n, lam, live),
        "closure_moment": _full(n, moment, live),
        "wrench1": _full(n, f0[:, 0] - closure_wrench, live),
        "wrench2": _full(n, f0[:, 1] - closure_wrench, live),
        "wrench4": _full(n, f0[:, 2] + closure_wrench, live),
        "ls_residual": _full(n, ls_res, live),
    }


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
    state = case.own_crank_states()
    status = sol.status
    t = transmission(sol, case.geometry.crank_length)
    w1, w2, w4 = sol.wrench1, sol.wrench2, sol.wrench4
    j4_moment_p3 = w4[:, 3:] - np.cross(sol.p3, w4[:, :3])
    j3_moment = 0.0 - sol.closure_moment  # the rod's moment on the slider (+0.0, not -0.0, with a ball)
    cols = {
        "theta1_deg": np.asarray(case.motion.angles_deg, float).copy(),
        "S1": state.s.copy(),
        "S4": sol.q[:, -1].copy(),  # S4 is the last coordinate of build_model's layout
        "S4_dot": sol.v[:, -1].copy(),
        "S4_ddot": sol.a[:, -1].copy(),
        "j1_fx": w1[:, 0], "j1_fy": w1[:, 1], "j1_fz": w1[:, 2],
        "j1_mx": w1[:, 3], "j1_my": w1[:, 4], "j1_mz": w1[:, 5],
        "j2_fx": w2[:, 0], "j2_fy": w2[:, 1], "j2_fz": w2[:, 2],
        "j3_fx": -sol.closure_force[:, 0], "j3_fy": -sol.closure_force[:, 1],
        "j3_fz": -sol.closure_force[:, 2],
        "j3_mx": j3_moment[:, 0], "j3_my": j3_moment[:, 1], "j3_mz": j3_moment[:, 2],
        "j4_fx": w4[:, 0], "j4_fy": w4[:, 1], "j4_fz": w4[:, 2],
        "j4_mx": j4_moment_p3[:, 0], "j4_my": j4_moment_p3[:, 1], "j4_mz": j4_moment_p3[:, 2],
        "slider_load": w4[:, :3] @ slider_axis(case)[0],
        "drive_torque": w1[:, 5].copy(),
        "transmission": t,
        "residual": sol.residual / case.geometry.rod_length,
        "closure_condition": sol.condition,
    }
    cols = {k: np.array(v, dtype=float) for k, v in cols.items()}
    cols["residual"][status == NO_ASSEMBLY] = np.nan
    words = settle(cols, flag_joint_lock(STATUS_WORDS[status], sol.condition, case.joints.universal),
                   REACTION_COLUMNS)
    status = np.array([STATUSES.index(w) for w in words], dtype=int)
    messages = []
    for code, word in enumerate(STATUS_WORDS):
        at = status == code
        if code == OK or not at.any():
            continue
        messages.append(f"{word}: {at.sum()} positions at {_angle_ranges(cols['theta1_deg'], at)}")
        if code == NO_ASSEMBLY:
            gap = np.max(sol.residual[at]) / case.geometry.rod_length
            messages[-1] += f" (the rod misses the slider line by up to {gap:.3g} a2)"
    info = {
        "pinocchio_version": pin.__version__,
        "messages": messages,
        "newton_iterations_max": int(sol.iterations[status == OK].max(initial=0)),
        "newton_iterations_mean": float(sol.iterations[status == OK].mean()) if np.any(status == OK) else 0.0,
        "ls_residual_max": float(np.nanmax(sol.ls_residual, initial=0.0)),
    }
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
