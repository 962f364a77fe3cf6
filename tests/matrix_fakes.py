"""Stand-in engines for the validation-matrix tests (never shipped, never registered).

The machinery under test (matrix, runner, comparison, reports) must not depend on
the real engines' speed or availability, so these tests plug these functions in
through ``run_matrix(..., registry=...)`` (or a patched registry).  The
kinematics are the closed-form test oracle of the conventions (S4 and its exact
rates); the reactions are synthetic but behave like real ones: in drive-torque
mode they grow like ``1/t`` and are NaN (``dead_centre``) where ``|t| < 1e-9``.
"""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Callable

import numpy as np

from dualmech.core.table import REACTION_COLUMNS, ResultTable
from dualmech.models.case import Case


def _closed_form(case: Case) -> dict[str, np.ndarray]:
    """S4, its rates and the transmission from the closed form (conventions doc), shape (n,)."""
    g = case.geometry
    st = case.motion.state(g.crank_axial_shift)
    a1, a2, a4, al = g.crank_length, g.rod_length, g.slider_offset, g.slider_twist
    k4 = np.array([0.0, np.sin(al), np.cos(al)])
    c, s = np.cos(st.theta), np.sin(st.theta)
    p2 = np.stack([a1 * c, a1 * s, st.s], axis=-1)
    f = np.array([-a4, 0.0, 0.0])
    d = p2 - f
    kd = d @ k4
    disc = kd**2 - np.sum(d * d, axis=-1) + a2**2
    s4 = -kd + np.sqrt(disc)
    p3 = f - s4[:, None] * k4
    r = p3 - p2  # rod vector, (n, 3)
    w, wd = st.theta_dot, st.theta_ddot
    dp2 = np.stack([-a1 * s * w, a1 * c * w, st.s_dot], axis=-1)
    ddp2 = np.stack([-a1 * (c * w**2 + s * wd), a1 * (-s * w**2 + c * wd), st.s_ddot], axis=-1)
    rk = r @ k4
    s4_dot = -np.sum(r * dp2, axis=-1) / rk
    dr = -s4_dot[:, None] * k4 - dp2
    s4_ddot = (np.sum(dr * dr, axis=-1) - np.sum(r * ddp2, axis=-1)) / rk
    u = r / a2
    arm = p2 - np.stack([np.zeros_like(st.s), np.zeros_like(st.s), st.s], axis=-1)
    t = np.cross(arm, u)[:, 2] / a1
    return {"theta1_deg": case.motion.angles_deg.astype(float), "S1": st.s, "S4": s4,
            "S4_dot": s4_dot, "S4_ddot": s4_ddot, "transmission": t, "residual": np.zeros_like(s4),
            "closure_condition": np.abs(rk) / a2}


def _table(case: Case, engine: str, noise: float = 0.0, phase: float = 0.0) -> ResultTable:
    cols = _closed_form(case)
    theta = np.radians(cols["theta1_deg"])
    t = cols["transmission"]
    torque_mode = case.loads.mode == "torque"
    load = case.loads.drive_torque if torque_mode else case.loads.slider_force
    with np.errstate(divide="ignore", invalid="ignore"):
        base = load / (case.geometry.crank_length * t) if torque_mode else np.full_like(t, load)
    status = np.full(t.shape, "ok", dtype=object)
    dead = torque_mode & (np.abs(t) < 1e-9)
    status[dead] = "dead_centre"
    for k, name in enumerate(REACTION_COLUMNS):
        col = base * (np.cos((k + 1) * theta) + 0.5 + 0.1 * k)
        cols[name] = np.where(dead, np.nan, col)
    for name in ("S4", "S4_dot", "S4_ddot", *REACTION_COLUMNS):
        cols[name] = cols[name] * (1.0 + noise * np.sin(7 * theta + phase))
    return ResultTable(engine, case.name, cols, status, {"version": "fake-1", "pid": os.getpid()})


def solve_case(case: Case) -> ResultTable:
    """The stand-in reference: exact kinematics, synthetic reactions."""
    return _table(case, "dualmech")


def solve_case_judge(case: Case) -> ResultTable:
    """A judge that agrees to ~1e-13 (round-off-like, deterministic)."""
    return _table(case, "pinocchio", noise=1e-13, phase=0.3)


def solve_case_judge_b(case: Case) -> ResultTable:
    """A second judge, agreeing to ~1e-11."""
    return _table(case, "mujoco", noise=1e-11, phase=1.1)


def solve_case_broken(case: Case) -> ResultTable:
    """A judge with one reaction perturbed by 1e-3 of its value: must fail ``j3_fy``."""
    table = _table(case, "mujoco", noise=1e-13)
    table.columns["j3_fy"] = table.columns["j3_fy"] * (1.0 + 1e-3)
    return table


def solve_case_slow(case: Case) -> ResultTable:
    """The reference, slowed down so that a run can be interrupted halfway."""
    time.sleep(float(os.environ.get("MATRIX_FAKES_DELAY", "0.4")))
    return solve_case(case)


def solve_case_raises(case: Case) -> ResultTable:
    """An engine that crashes."""
    raise RuntimeError(f"engine exploded on {case.name}")


def _marked(engine: str, solve: Callable[[Case], ResultTable]) -> Callable[[Case], ResultTable]:
    """``solve`` slowed down, leaving a file ``<case>--<engine>`` in ``$MATRIX_FAKES_MARKS`` when it is
    done."""

    def run(case: Case) -> ResultTable:
        time.sleep(float(os.environ.get("MATRIX_FAKES_DELAY", "0.4")))
        table = solve(case)
        (Path(os.environ["MATRIX_FAKES_MARKS"]) / f"{case.name}--{engine}").touch()
        return table

    return run


solve_case_marked_dualmech = _marked("dualmech", solve_case)
solve_case_marked_pinocchio = _marked("pinocchio", solve_case_judge)
solve_case_marked_mujoco = _marked("mujoco", solve_case_judge_b)
