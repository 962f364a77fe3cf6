"""The Exudyn judge on a slider crank case: the case as its joint table, judged from a crude start of the
judge's own, read back as the slider crank's result table (``docs/conventions.md``, "Output columns").

**Table and start.**  The case becomes its table (:func:`~dualmech.models.loop.presets.slider_crank_table`:
every joint variant, the sinusoidal ``S1`` of a cylindrical crank, a given drive torque or slider load),
started at the first row that reaches (``rho <= a2 (1 + ASSEMBLY_REACH)``, ``rho`` the distance from ``P2``
to the slider line) from a crude pose on the conventions' branch (:func:`crude_s4`: the slider a rod's
length beyond the foot of the perpendicular from ``P2``, the rod aimed at it by
:func:`~dualmech.models.loop.presets.slider_crank_start`), never from the in-house answer; the judge closes
the loop from there by its own continuation.  Past a gap (a row that does not reach) continuity is lost,
and a run starts again, from a crude start there, at the first row that reaches.

**Columns** (the joint wrenches of the table, world axes: ``docs/conventions.md``, "Loop tables"): ``j1`` is
joint 1's wrench (its point the world origin ``O``); ``j2``, ``j3`` joints 2 and 3's (the rod's end ``P3``
is joint 3's point; with a ball its moment is 0); ``j4`` minus joint 4's (on the ground from the slider;
its point is ``P3``, the slider frame's origin); ``slider_load = k4·j4_f``, ``drive_torque = j1_mz``;
``S1`` the case's own crank states; ``S4`` and its rates the judge's ``s4``.  The transmission and the
closure condition are computed from the judge's pose (``P2`` from the prescribed crank, ``P3 = F - S4
k4``); ``residual`` is the judge's closure residual (over the table's length) rescaled to ``a2``.

**Status words**: the slider crank's rules (``docs/conventions.md``, "Edges of assembly"), on the judge's
own closure: :func:`~dualmech.core.assembly.edge_status`, then in torque mode ``dead_centre`` where ``|t|
< DEAD_CENTRE_TRANSMISSION`` or where the judge itself could not balance the given torque (its own
``dead_centre``), then ``joint_lock`` with a universal joint (:func:`~dualmech.core.status.flag_joint_lock`).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from dualmech.core.assembly import edge_status, foot_s4, reach
from dualmech.core.status import Status, flag_joint_lock, is_status, settle
from dualmech.core.table import REACTION_COLUMNS, ResultTable
from dualmech.core.thresholds import ASSEMBLY_LIMIT_CONDITION, ASSEMBLY_REACH, DEAD_CENTRE_TRANSMISSION
from dualmech.models.angle_ranges import status_messages
from dualmech.models.case import Case
from dualmech.models.loop.presets import slider_crank_start, slider_crank_table, started
from dualmech.validation.judges.exudyn_loop.table import ENGINE, solve_table

#: The judge's words of a closed, answered row.
ANSWERED = (Status.OK.value, Status.DEAD_CENTRE.value)


def crank_pins(case: Case) -> tuple[np.ndarray, np.ndarray]:
    """``P2`` and the crank's origin ``(0, 0, S1)``, each ``(n, 3)`` (world), at the case's rows."""
    state = case.own_crank_states()
    a1 = case.geometry.crank_length
    origin = np.stack([np.zeros_like(state.s), np.zeros_like(state.s), state.s], 1)
    turn = np.stack([np.cos(state.theta), np.sin(state.theta), np.zeros_like(state.s)], 1)
    return origin + a1 * turn, origin


def crude_s4(case: Case, at: int) -> float:
    """A crude ``S4`` at row ``at`` on the conventions' branch (``(P3 - P2)·k4 < 0``): the foot of the
    perpendicular from ``P2`` on the slider line moved by the rod's length ``a2`` toward larger ``S4``."""
    g = case.geometry
    p2 = crank_pins(case)[0][at]
    return float(foot_s4(p2, g.foot, g.k4)[0]) + g.rod_length


def solve_case(case: Case) -> ResultTable:
    """The ``exudyn`` engine of a slider crank case (module docstring).  ``meta``: ``restarts`` (the rows,
    0-based, a run started from) and ``messages`` (the rows where the rod cannot reach the slider line)."""
    g = case.geometry
    p2, origin = crank_pins(case)
    n = p2.shape[0]
    reaches = reach(p2, g.foot, g.k4, g.rod_length) <= 1.0 + ASSEMBLY_REACH.value
    mechanism = slider_crank_table(case)
    names = ("s4", "s4_dot", "s4_ddot", "residual") + tuple(
        f"joint{j}_{kind}{axis}" for j in range(1, 5) for kind in "fm" for axis in "xyz")
    got = {name: np.full(n, np.nan) for name in names}
    words = np.full(n, Status.NO_ASSEMBLY.value, dtype=object)
    restarts = []
    for k in np.flatnonzero(reaches & ~np.r_[False, reaches[:-1]]):  # the first row of each reaching run
        rows = k + np.arange(n - k)
        start = started(mechanism, slider_crank_start(case, crude_s4(case, k), at=k))
        run = solve_table(replace(start, drive=replace(start.drive, positions=start.drive.positions[k:])))
        restarts.append(int(k))
        take = rows[reaches[k:] & ~is_status(words[k:], *ANSWERED)]
        for name in got:
            got[name][take] = run[name][take - k]
        words[take] = run.status[take - k]
    got["residual"] *= mechanism.length
    return _table(case, got, words, p2, origin, np.array(restarts, dtype=int))


def _table(case: Case, got: dict[str, np.ndarray], words: np.ndarray, p2: np.ndarray, origin: np.ndarray,
           restarts: np.ndarray) -> ResultTable:
    """The slider crank's result table of the judge's columns ``got`` and words (module docstring)."""
    g = case.geometry
    closed = is_status(words, *ANSWERED)
    s4 = got["s4"]
    p3 = g.foot - s4[:, None] * g.k4
    u = (p3 - p2) / np.linalg.norm(p3 - p2, axis=1)[:, None]
    condition = np.abs(u @ g.k4)
    with np.errstate(invalid="ignore"):
        rho = np.where(closed, np.sqrt(1.0 - np.minimum(condition, 1.0) ** 2),
                       reach(p2, g.foot, g.k4, g.rod_length))
    status, condition = edge_status(words, closed, rho, condition, ASSEMBLY_REACH.value,
                                    ASSEMBLY_LIMIT_CONDITION.value)
    limit = (status == Status.ASSEMBLY_LIMIT.value) & ~closed
    s4 = np.where(limit, foot_s4(p2, g.foot, g.k4), s4)
    arm = p2 - origin
    transmission = (arm[:, 0] * u[:, 1] - arm[:, 1] * u[:, 0]) / g.crank_length
    if case.loads.mode == "torque":
        dead = is_status(status, Status.OK) & (np.abs(transmission) < DEAD_CENTRE_TRANSMISSION.value)
        status[dead] = Status.DEAD_CENTRE.value
    wrench = {j: {kind: np.stack([got[f"joint{j}_{kind}{a}"] for a in "xyz"], 1) for kind in "fm"}
              for j in range(1, 5)}
    j4_force, j4_moment = -wrench[4]["f"], -wrench[4]["m"]
    cols = {"theta1_deg": np.asarray(case.motion.angles_deg, float).copy(), "S1": origin[:, 2].copy(),
            "S4": s4, "S4_dot": got["s4_dot"], "S4_ddot": got["s4_ddot"]}
    for name, vector in (("j1_f", wrench[1]["f"]), ("j1_m", wrench[1]["m"]), ("j2_f", wrench[2]["f"]),
                         ("j3_f", wrench[3]["f"]), ("j3_m", wrench[3]["m"]), ("j4_f", j4_force),
                         ("j4_m", j4_moment)):
        cols.update({f"{name}{a}": vector[:, i] for i, a in enumerate("xyz")})
    cols.update(slider_load=j4_force @ g.k4, drive_torque=cols["j1_mz"].copy(), transmission=transmission,
                residual=got["residual"] / g.rod_length, closure_condition=condition)
    cols = {name: np.array(values, dtype=float) for name, values in cols.items()}
    words = settle(cols, flag_joint_lock(status, condition, case.joints.universal), REACTION_COLUMNS)
    messages = status_messages(cols["theta1_deg"], words == Status.NO_ASSEMBLY.value)
    return ResultTable(ENGINE, case.name, cols, words, {"restarts": restarts, "messages": messages})
