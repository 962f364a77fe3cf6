"""The generalized slider crank as one instance of the link-joint table, and the in-house engine.

::

    row  joint              theta     S      eta   alpha    a      (thesis Table 1)
    1    cylindrical (1)    theta1*   S1*    0     0        a1
    2    ball (2)           -- free rotation --    0        a2
    3    ball (3)           -- free rotation --    pi/2     0
    4    prismatic (4)      0         S4?    0     alpha4   a4

    * prescribed input   ? unknown

The thesis gives the balls Z-Y angles (theta2, eta2, theta3, eta3); those
five unknowns cannot close a spatial loop (errata E2), so each ball here is a
free rotation and the rod's spin is fixed by the zero-spin gauge
(``docs/conventions.md``).

:func:`analyze` runs displacement, velocity, acceleration and inverse
dynamics for all positions of a case at once; :func:`solve_case` turns the
result into the common :class:`~dualmech.core.table.ResultTable`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from dualmech.core.closure import ClosureStatus, solve_closure
from dualmech.core.loop import Loop, LoopState, Row, evaluate, inp, unk
from dualmech.core.motion import CrankState
from dualmech.core.rates import Rates, solve_rates
from dualmech.core.reactions import BodyMotion, Reactions, body_motion, solve_reactions
from dualmech.core.table import NUMERIC_COLUMNS, ResultTable
from dualmech.models.case import Case, Geometry

#: |transmission| below which a torque-mode position is a dead centre (see validation/tolerances.py).
DEAD_CENTRE = 1e-9
#: Geometry steps of the continuation fallback (from the planar mechanism to the case).
CONTINUATION_STEPS = 8


def build_loop(geom: Geometry) -> Loop:
    """The slider-crank loop of ``geom`` (rows as in the module docstring)."""
    return Loop(
        rows=(
            Row("joint1", theta=inp("theta1"), s=inp("S1"), a=geom.crank_length),
            Row("joint2", spherical=True, a=geom.rod_length),
            Row("joint3", spherical=True, alpha=math.pi / 2),
            Row("joint4", s=unk("S4"), alpha=geom.slider_twist, a=geom.slider_offset),
        ),
        spin_gauges=(1,),
        length_scale=geom.rod_length,
    )


def slider_axis(geom: Geometry) -> tuple[np.ndarray, np.ndarray]:
    """Foot ``F`` of the common normal on the slider line, and the slider direction ``k4``."""
    a = geom.slider_twist
    return np.array([-geom.slider_offset, 0.0, 0.0]), np.array([0.0, math.sin(a), math.cos(a)])


def _rod_frame(u: np.ndarray) -> np.ndarray:
    """A rotation with x axis ``u`` ``(n, 3)``: y horizontal (``z x u``) unless ``u`` is vertical."""
    ref = np.where(np.abs(u[:, 2:3]) > 0.9, np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0]))
    v = np.cross(ref, u)
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    return np.stack([u, v, np.cross(u, v)], axis=2)


def _rz(theta: np.ndarray) -> np.ndarray:
    c, s = np.cos(theta), np.sin(theta)
    out = np.zeros(theta.shape + (3, 3))
    out[:, 0, 0], out[:, 0, 1], out[:, 1, 0], out[:, 1, 1], out[:, 2, 2] = c, -s, s, c, 1.0
    return out


def _rx(alpha: float) -> np.ndarray:
    c, s = math.cos(alpha), math.sin(alpha)
    return np.array([[1.0, 0, 0], [0, c, -s], [0, s, c]])


def state_from_slider(geom: Geometry, crank: CrankState, s4: np.ndarray) -> LoopState:
    """Loop unknowns that point the rod from the crank pin toward the slider at ``s4``.

    The rotation part of the loop closes exactly; the rod length generally does
    not (unless ``s4`` is the solution).  Used for initial estimates.
    """
    f, k4 = slider_axis(geom)
    p2 = np.stack([geom.crank_length * np.cos(crank.theta), geom.crank_length * np.sin(crank.theta), crank.s], 1)
    p3 = f - s4[:, None] * k4
    rz = _rz(crank.theta)
    r_rod = _rod_frame((p3 - p2) / np.linalg.norm(p3 - p2, axis=1, keepdims=True))
    ball2 = np.swapaxes(rz, 1, 2) @ r_rod
    ball3 = np.swapaxes(r_rod, 1, 2) @ _rx(-geom.slider_twist - math.pi / 2)
    return LoopState(s4[:, None].copy(), np.stack([ball2, ball3], axis=1))


def planar_estimate(geom: Geometry, crank: CrankState) -> np.ndarray:
    """Plane-geometry estimate of ``S4`` (thesis section 2.6.2, extended to every crank angle).

    The mechanism is treated as the planar offset slider crank (``S1 = 0``, twist
    270° or 90°, whichever is nearer); where even that cannot assemble the rod is
    laid at right angles to the slider line.
    """
    a1, a2, a4 = geom.crank_length, geom.rod_length, geom.slider_offset
    side = 1.0 if math.sin(geom.slider_twist) < 0 else -1.0
    reach = a2**2 - (a1 * np.cos(crank.theta) + a4) ** 2
    return side * a1 * np.sin(crank.theta) + np.sqrt(np.maximum(reach, 0.0))


def _inputs(crank: CrankState) -> dict[str, np.ndarray]:
    return {"theta1": crank.theta, "S1": crank.s}


def _on_branch(geom: Geometry, crank: CrankState, s4: np.ndarray) -> np.ndarray:
    """``(P3 - P2)·k4 < 0`` (the assembly branch of the conventions)."""
    f, k4 = slider_axis(geom)
    p2 = np.stack([geom.crank_length * np.cos(crank.theta), geom.crank_length * np.sin(crank.theta), crank.s], 1)
    return (f - s4[:, None] * k4 - p2) @ k4 < 0


def _planar_reference(geom: Geometry) -> Geometry:
    twist = 270.0 if math.sin(geom.slider_twist) < 0 else 90.0
    return Geometry(geom.crank_length, geom.rod_length, geom.slider_offset, twist, 0.0)


def _blend(a: Geometry, b: Geometry, lam: float) -> Geometry:
    def mix(x: float, y: float) -> float:
        return (1 - lam) * x + lam * y

    return Geometry(a.crank_length, a.rod_length, mix(a.slider_offset, b.slider_offset),
                    mix(a.slider_twist_deg, b.slider_twist_deg), mix(a.crank_axial_shift, b.crank_axial_shift))


def _continuation(geom: Geometry, crank: CrankState) -> tuple[LoopState, np.ndarray]:
    """Close the loop by continuation in the geometry, from the planar mechanism to ``geom``.

    The axial position is blended too: ``S1(lam) = lam * S1``.  Returns the state
    and whether each position closed on the branch at the end.
    """
    start = _planar_reference(geom)
    state = state_from_slider(start, crank, planar_estimate(start, crank))
    ok = np.ones(len(crank), dtype=bool)
    for lam in np.linspace(0.0, 1.0, CONTINUATION_STEPS + 1):
        g = _blend(start, geom, float(lam))
        c = CrankState(crank.theta, lam * crank.s, crank.theta_dot, crank.s_dot, crank.theta_ddot, crank.s_ddot)
        res = solve_closure(build_loop(g), _inputs(c), state)
        ok &= (res.status == ClosureStatus.OK) & _on_branch(g, c, res.state.scalars[:, 0])
        state = res.state
    return state, ok


@dataclass(frozen=True)
class Analysis:
    """Everything the in-house solver computes for one case.

    ``status`` is an object array of status words (``docs/conventions.md``);
    ``iterations`` and ``closure_residual`` per position; ``motions`` the crank,
    rod and slider :class:`BodyMotion`; ``rates`` the loop :class:`Rates`;
    ``reactions`` the :class:`Reactions` (NaN where not ``ok``).
    """

    case: Case
    crank: CrankState
    s4: np.ndarray
    status: np.ndarray
    iterations: np.ndarray
    closure_residual: np.ndarray
    p2: np.ndarray
    p3: np.ndarray
    transmission: np.ndarray
    rates: Rates
    motions: tuple[BodyMotion, BodyMotion, BodyMotion]
    reactions: Reactions


def close_loop(geom: Geometry, crank: CrankState) -> tuple[LoopState, np.ndarray, np.ndarray, np.ndarray]:
    """Displacement analysis of every position: state, status words, iterations, residual."""
    loop = build_loop(geom)
    inputs = _inputs(crank)
    res = solve_closure(loop, inputs, state_from_slider(geom, crank, planar_estimate(geom, crank)))
    state, iters, residual = res.state, res.iterations.copy(), res.residual.copy()
    good = (res.status == ClosureStatus.OK) & _on_branch(geom, crank, state.scalars[:, 0])
    retry = np.flatnonzero(~good)
    status = np.full(len(crank), "ok", dtype=object)
    if retry.size:
        sub, sub_ok = _continuation(geom, crank.take(retry))
        state = state.put(retry[sub_ok], sub.take(np.flatnonzero(sub_ok)))
        closed = evaluate(loop, {k: v[retry] for k, v in inputs.items()}, state.take(retry))
        from dualmech.core.loop import closure_residual

        residual[retry] = closure_residual(closed, loop)
        failed = retry[~sub_ok]
        codes = res.status[failed]
        status[failed] = np.where(
            codes == ClosureStatus.NO_ASSEMBLY, "no_assembly",
            np.where(codes == ClosureStatus.OK, "branch_jump", "not_converged"),
        )
    return state, status, iters, residual


def analyze(case: Case, crank: CrankState | None = None) -> Analysis:
    """Displacement, velocity, acceleration and inverse dynamics of ``case`` at every position.

    Parameters
    ----------
    case : Case
    crank : CrankState, optional
        Crank states to analyse; default: the case's angles and motion.
    """
    geom = case.geometry
    crank = case.motion.state(geom.crank_axial_shift) if crank is None else crank
    loop = build_loop(geom)
    state, status, iters, residual = close_loop(geom, crank)
    chain = evaluate(loop, _inputs(crank), state)
    rates = solve_rates(chain, loop, {"theta1": crank.theta_dot, "S1": crank.s_dot},
                        {"theta1": crank.theta_ddot, "S1": crank.s_ddot})
    from dualmech.core.dual import origin

    p2, p3 = origin(chain.frames[0]), origin(chain.frames[1])
    u = (p3 - p2) / geom.rod_length
    hub = np.stack([np.zeros_like(crank.s), np.zeros_like(crank.s), crank.s], 1)
    transmission = np.cross(p2 - hub, u)[:, 2] / geom.crank_length
    frames = (
        (chain.frames[0].re, hub),
        (chain.frames[1].re, p2),
        (np.broadcast_to(np.eye(3), chain.frames[0].re.shape), p3),
    )
    bodies = (case.bodies.crank, case.bodies.rod, case.bodies.slider)
    motions = tuple(
        body_motion(b, r, o, rates.link_twist[i], rates.link_accel[i]) for i, (b, (r, o)) in enumerate(zip(bodies, frames))
    )
    _, k4 = slider_axis(geom)
    loads = case.loads
    with np.errstate(divide="ignore", invalid="ignore"):
        reactions = solve_reactions(bodies, motions, p2, p3, k4, loads.gravity,
                                    drive_torque=loads.drive_torque, slider_load=loads.slider_force)
    if loads.mode == "torque":
        status[(status == "ok") & (np.abs(transmission) < DEAD_CENTRE)] = "dead_centre"
    return Analysis(case, crank, state.scalars[:, 0], status, iters, residual, p2, p3, transmission, rates,
                    motions, reactions)


def no_assembly_ranges(theta_deg: np.ndarray, mask: np.ndarray) -> list[tuple[float, float]]:
    """Contiguous runs of ``mask`` as (first, last) crank angles in degrees."""
    runs, start = [], None
    for i, m in enumerate(mask):
        if m and start is None:
            start = i
        if start is not None and (not m or i == len(mask) - 1):
            end = i if m else i - 1
            runs.append((float(theta_deg[start]), float(theta_deg[end])))
            start = None
    return runs


def to_table(an: Analysis) -> ResultTable:
    """The common result table of an :class:`Analysis` (NaN where a row is not ``ok``)."""
    r = an.reactions
    cols = {
        "theta1_deg": np.degrees(an.crank.theta), "S1": an.crank.s, "S4": an.s4,
        "S4_dot": an.rates.q_dot[:, 0], "S4_ddot": an.rates.q_ddot[:, 0],
        "slider_load": r.slider_load, "drive_torque": r.drive_torque,
        "transmission": an.transmission, "residual": an.closure_residual,
    }
    for name, arr in (("j1_f", r.j1_force), ("j1_m", r.j1_moment), ("j2_f", r.j2), ("j3_f", r.j3),
                      ("j4_f", r.j4_force), ("j4_m", r.j4_moment)):
        for k, axis in enumerate("xyz"):
            cols[f"{name}{axis}"] = arr[:, k]
    cols = {c: np.array(cols[c], dtype=float) for c in NUMERIC_COLUMNS}
    kin_bad = ~np.isin(an.status, ["ok", "dead_centre"])
    for c in NUMERIC_COLUMNS:
        if c in ("theta1_deg", "S1", "transmission", "residual"):
            continue
        if c in ("S4", "S4_dot", "S4_ddot"):
            cols[c][kin_bad] = np.nan
        else:
            cols[c][an.status != "ok"] = np.nan
    cols["transmission"][kin_bad] = np.nan
    messages = []
    bad = an.status == "no_assembly"
    if bad.any():
        ranges = ", ".join(f"{a:g}..{b:g}" for a, b in no_assembly_ranges(cols["theta1_deg"], bad))
        messages.append(f"no_assembly: the rod cannot reach the slider line at crank angles {ranges} deg")
    meta = {"iterations": an.iterations, "dynamics_residual": r.residual, "messages": messages}
    return ResultTable("dualmech", an.case.name, cols, an.status.copy(), meta)


def solve_case(case: Case) -> ResultTable:
    """In-house engine: analyse every position of ``case`` and return the result table."""
    return to_table(analyze(case))
