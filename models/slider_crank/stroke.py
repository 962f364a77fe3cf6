"""Sweeps of the in-house solver over a revolution: dead centres, the stroke and its table.

:func:`dead_centres` finds the crank angles where the transmission factor vanishes
(batched bisection); :func:`stroke_of` the stroke (max S4 - min S4) of each case with its
extremes refined by Newton on dS4/dtheta1; :func:`stroke_table` the stroke of the thesis's
worked example over a4 x alpha4 x S1 (thesis section 3.1, issue 2); :func:`assembly_limit_s1`
the largest S1 at which the planar-twist mechanism still assembles everywhere.  The thesis
findings (``models/slider_crank/findings.py``) read them.

Every sweep runs the compiled solver (:func:`~dualmech.models.slider_crank.kernel.solve_cases`, its result
tables): the thesis findings of a report solve about 40,000 positions here.
"""

from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np

from dualmech.core.motion import CrankState
from dualmech.core.status import RATES_GIVEN, Status, is_status
from dualmech.core.table import ResultTable
from dualmech.models.case import Case, load_case
from dualmech.models.slider_crank.kernel import solve_cases

#: Grid of the stroke table (thesis section 3.1 and issue 2).
STROKE_OFFSETS = (0.0, 10.0, 20.0, 30.0)
STROKE_TWISTS = (232.0, 270.0, 310.0)
STROKE_SHIFTS = (0.0, 3.0, 3.5, 6.0, 9.0)


def _fixed_crank(theta: np.ndarray, s1: float) -> CrankState:
    """Crank states with unit speed and no acceleration: then S4_dot = dS4/dtheta1,
    S4_ddot = d2S4/dtheta1^2."""
    n = theta.shape[0]
    return CrankState(theta, np.full(n, s1), np.ones(n), np.zeros(n), np.zeros(n), np.zeros(n))


def dead_centres(cases: list[Case], iterations: int = 48) -> list[np.ndarray]:
    """Crank angles (deg) where the transmission factor vanishes, per case, by batched bisection.

    Brackets come from sign changes of the in-house transmission on the case's
    grid; each bisection step is one batched in-house analysis of all brackets.
    """
    lo_parts, hi_parts, owner_parts, exact = [], [], [], []
    cranks = [c.own_crank_states() for c in cases]
    for i, (crank, table) in enumerate(zip(cranks, solve_cases(cases, cranks=cranks))):
        t, th = table.columns["transmission"], crank.theta
        exact.append(np.degrees(th[t == 0.0]))
        k = np.flatnonzero((t != 0.0) & (t * np.roll(t, -1) < 0.0))  # a sign change to the next position
        step = th[1] - th[0] if th.shape[0] > 1 else 0.0
        nxt = np.append(th[1:], th[-1] + step)  # the bracket closing the revolution: one step past the grid
        lo_parts.append(th[k])
        hi_parts.append(nxt[k])
        owner_parts.append(np.full(k.shape[0], i))
    lo, hi = np.concatenate(lo_parts), np.concatenate(hi_parts)
    owner = np.concatenate(owner_parts).astype(int)
    if lo.size:
        t_lo = _transmission_at(cases, owner, lo)
        for _ in range(iterations):
            mid = 0.5 * (lo + hi)
            t_mid = _transmission_at(cases, owner, mid)
            left = np.sign(t_mid) == np.sign(t_lo)
            lo, t_lo = np.where(left, mid, lo), np.where(left, t_mid, t_lo)
            hi = np.where(left, hi, mid)
    out = []
    for i in range(len(cases)):
        out.append(np.sort(np.concatenate([np.degrees(0.5 * (lo + hi))[owner == i] % 360.0, exact[i]])))
    return out


def _transmission_at(cases: list[Case], owner: np.ndarray, theta: np.ndarray) -> np.ndarray:
    groups = [np.flatnonzero(owner == i) for i in range(len(cases))]
    used = [i for i, g in enumerate(groups) if g.size]
    tables = _at_fixed_cranks([cases[i] for i in used], [theta[groups[i]] for i in used])
    out = np.empty_like(theta)
    for i, table in zip(used, tables):
        out[groups[i]] = table.columns["transmission"]
    return out


def stroke_of(cases: list[Case], newton_steps: int = 6) -> list[dict[str, Any]]:
    """Stroke (max S4 - min S4 over a revolution) of each case, extremes refined by Newton on dS4/dtheta1.

    Cases whose rod cannot reach the slider line somewhere on the revolution get
    ``assembles = False`` and no stroke.
    """
    grid = [c.with_values({"motion.angles_deg": {"start": 0.0, "stop": 360.0, "step": 1.0}}) for c in cases]
    rows, todo = [], []
    cranks = [c.own_crank_states() for c in grid]
    for case, crank, table in zip(cases, cranks, solve_cases(grid, cranks=cranks)):
        ok = is_status(table.status, *RATES_GIVEN)
        s4 = table.columns["S4"]
        row: dict[str, Any] = {
            "a4": case.geometry.slider_offset, "alpha4_deg": case.geometry.slider_twist_deg,
            "S1": case.geometry.crank_axial_shift, "assembles": bool(ok.all()),
            "no_assembly_positions": int(is_status(table.status, Status.NO_ASSEMBLY).sum()),
            "stroke": None, "s4_min": None, "s4_max": None, "theta_min_deg": None, "theta_max_deg": None,
        }
        rows.append(row)
        if ok.all():
            todo.append((row, case, crank.theta[[np.argmin(s4), np.argmax(s4)]]))
    if not todo:
        return rows
    theta = np.stack([t for _, _, t in todo])
    todo_cases = [c for _, c, _ in todo]
    for _ in range(newton_steps):
        sub = _at_fixed_cranks(todo_cases, theta)
        d1 = np.stack([t.columns["S4_dot"] for t in sub])  # unit crank speed: dS4/dtheta1
        d2 = np.stack([t.columns["S4_ddot"] for t in sub])
        theta = theta - d1 / d2
    for i, ((row, _, _), t) in enumerate(zip(todo, _at_fixed_cranks(todo_cases, theta))):
        s4 = t.columns["S4"]
        row.update(s4_min=float(s4[0]), s4_max=float(s4[1]), stroke=float(s4[1] - s4[0]),
                   theta_min_deg=float(np.degrees(theta[i, 0]) % 360.0),
                   theta_max_deg=float(np.degrees(theta[i, 1]) % 360.0))
    return rows


def _at_fixed_cranks(cases: list[Case], theta: Sequence[np.ndarray]) -> list[ResultTable]:
    """The result table of ``cases[i]`` at the crank angles ``theta[i]`` (rad), unit speed, no acceleration
    (S4_dot, S4_ddot are then dS4/dtheta1 and its derivative)."""
    return solve_cases(cases, cranks=[_fixed_crank(theta[i], c.geometry.crank_axial_shift)
                                      for i, c in enumerate(cases)])


def stroke_table(base: Case | None = None) -> list[dict[str, Any]]:
    """Stroke for a4 in {0, 10, 20, 30} x alpha4 in {232, 270, 310} x S1 in {0, 3, 3.5, 6, 9} (thesis
    example).

    Returns one dict per combination: ``a4``, ``alpha4_deg``, ``S1``, ``assembles``,
    ``no_assembly_positions``, ``stroke``, ``s4_min``, ``s4_max``, ``theta_min_deg``,
    ``theta_max_deg`` (lengths in inches; ``stroke`` None where the mechanism
    cannot assemble over the whole revolution).
    """
    base = load_case("thesis/ideal") if base is None else base
    cases = [base.with_values({"geometry.slider_offset": a4, "geometry.slider_twist_deg": tw,
                               "geometry.crank_axial_shift": s1})
             for tw in STROKE_TWISTS for a4 in STROKE_OFFSETS for s1 in STROKE_SHIFTS]
    return stroke_of(cases)


def assembly_limit_s1(case: Case) -> float:
    """Largest constant S1 at which the rod still reaches the slider line at every crank angle (alpha4 = 270).

    The distance from P2 to the slider line is :math:`\\sqrt{(a_1\\cos\\theta_1 + a_4)^2 + S_1^2}`,
    largest at :math:`\\theta_1 = 0`; it must not exceed :math:`a_2`.
    """
    g = case.geometry
    return math.sqrt(max(g.rod_length**2 - (g.crank_length + abs(g.slider_offset)) ** 2, 0.0))
