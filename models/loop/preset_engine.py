"""The in-house engine of the RSSR and the RCCC: the loop engine on their preset tables.

An RSSR or RCCC case is its joint table (:func:`~dualmech.models.loop.presets.rssr_table`,
:func:`~dualmech.models.loop.presets.rccc_table`), solved by the one in-house loop engine
(:func:`~dualmech.models.loop.engine.analyze_loop`, compiled) and read back as the mechanism's own table
(:mod:`dualmech.models.linkages.readback`; ``docs/conventions.md``, "RSSR", "RCCC").  The rows are run as
the judges' are (:func:`~dualmech.models.linkages.restarts.run_past_gaps`): from the first row whose geometry
reaches, and again past every gap and wherever the continuation left the case's branch, each run to the end
of its reaching rows, started from the mechanism's own estimate at its first row (the RSSR's closed-form
output angle :func:`~dualmech.models.linkages.rssr.closed_form_phi`, the RCCC's spherical estimate
:func:`~dualmech.models.linkages.rccc.spherical_estimate`: :func:`~dualmech.models.loop.presets.rssr_start`,
:func:`~dualmech.models.loop.presets.rccc_start`), whose reach ratios also decide ``no_assembly``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from dualmech.core.closure import ClosureStatus, solve_closure
from dualmech.core.loop import LoopState
from dualmech.core.status import Status
from dualmech.models.linkages import rccc, rssr
from dualmech.models.linkages.rccc_case import RcccCase
from dualmech.models.linkages.readback import rccc_columns, rssr_columns
from dualmech.models.linkages.restarts import Run, run_past_gaps
from dualmech.models.linkages.rssr_case import RssrCase
from dualmech.models.loop.columns import coordinate_names, effort_names, wrench_columns
from dualmech.models.loop.description import LoopMechanism
from dualmech.models.loop.engine import LoopAnalysis, analyze_loop
from dualmech.models.loop.presets import rccc_start, rccc_table, rows, rssr_start, rssr_table
from dualmech.models.loop.table import ENGINE, analysis_columns
from dualmech.models.loop.translate import drive_state, to_loop
from dualmech.models.tables import LinkageTable, TableSpec


@dataclass(frozen=True)
class Preset:
    """What the engine needs of a kind: its ``table`` and its own ``start`` at a row (case, row -> pose),
    its ``reach`` ratio at crank angles (case, rad ``(n,)`` -> ``(n,)``; ``|rho| > 1``: no assembly), the
    ``readback`` of a loop table's answer, the table's ``spec``, the length its ``residual`` is over (case
    -> length) and what its ``no_assembly`` message says."""

    table: Callable[[RssrCase | RcccCase], LoopMechanism]
    start: Callable[[RssrCase | RcccCase, int], LoopState]
    reach: Callable[[RssrCase | RcccCase, np.ndarray], np.ndarray]
    readback: Callable[[RssrCase | RcccCase, LinkageTable], LinkageTable]
    spec: TableSpec
    length: Callable[[RssrCase | RcccCase], float]
    why: str


RSSR = Preset(rssr_table, rssr_start, lambda case, theta: rssr.closed_form_phi(case.geometry, theta, 1)[1],
              rssr_columns, rssr.SPEC, lambda case: case.geometry.a2,
              "the coupler cannot reach the output crank")
RCCC = Preset(rccc_table, rccc_start,
              lambda case, theta: rccc.spherical_estimate(case.geometry, theta, 1)[1],
              rccc_columns, rccc.SPEC, lambda case: case.geometry.size,
              "the axes' cones about z2 and z4 do not meet")


def answer(an: LoopAnalysis, length: float) -> LinkageTable:
    """The loop engine's answer as a loop table's columns
    (:func:`~dualmech.models.loop.table.analysis_columns` and ``theta1_deg``), its words unsettled (the
    mechanism's rules settle them: the loop table's own ``dead_centre`` is not the mechanism's), its
    ``residual`` over ``length`` (the mechanism's scale, not the table's largest length);
    ``meta["iterations"]``."""
    cols = analysis_columns(an)
    cols["theta1_deg"] = np.degrees(an.mechanism.drive.positions)
    cols["residual"] = cols["residual"] * (an.mechanism.length / length)
    return LinkageTable(ENGINE, an.mechanism.name, cols, an.status, {"iterations": np.asarray(an.iterations)})


def pose_only(mechanism: LoopMechanism, start: LoopState, length: float) -> LinkageTable:
    """The first row of ``mechanism`` closed from ``start`` alone
    (:func:`~dualmech.core.closure.solve_closure`, which stops without raising), as :func:`answer` gives
    it: the pose and the words (``ok`` closed, else ``not_converged``), no rates or reactions (NaN).  A run
    whose start does not close at its first row (a row at an edge of assembly, where the closure stops a
    little short of its tolerance: the mechanism's rules may call it ``assembly_limit``) answers that row so,
    alone."""
    loop = to_loop(mechanism)
    values = drive_state(mechanism).take(slice(0, 1)).values
    closed = solve_closure(loop, values, start)
    names = [f"{c}{suffix}" for c in coordinate_names(mechanism) for suffix in ("", "_dot", "_ddot")]
    names += [f"effort_{e}" for e in effort_names(mechanism)] + ["dynamics_residual"]
    cols = {c: np.full(1, np.nan) for c in names}
    cols.update(wrench_columns(np.full((1, len(mechanism.joints), 3), np.nan),
                               np.full((1, len(mechanism.joints), 3), np.nan)))
    cols.update({name: closed.state.scalars[:, j] for j, name in enumerate(loop.unknowns) if name in cols})
    cols.update({name: value for name, value in values.items() if name in cols})
    cols["theta1_deg"] = np.degrees(mechanism.drive.positions[:1])
    cols["residual"] = closed.residual * (mechanism.length / length)
    word = Status.OK.value if closed.status[0] == ClosureStatus.OK else Status.NOT_CONVERGED.value
    return LinkageTable(ENGINE, mechanism.name, cols, np.array([word], dtype=object),
                        {"iterations": np.asarray(closed.iterations)})


def solve_preset(case: RssrCase | RcccCase, preset: Preset) -> LinkageTable:
    """Every crank position of ``case`` by the loop engine on its preset table (module docstring).
    ``meta``: ``iterations`` (the closure's, per row, of the run that answered it), ``messages`` (the
    ``no_assembly`` crank angle ranges), ``branch``."""
    mechanism, theta1 = preset.table(case), np.radians(case.motion.angles_deg)
    reaches = rssr.assembles(preset.reach(case, theta1))
    length = preset.length(case)

    def run_from(k: int) -> Run:
        gaps = np.flatnonzero(~reaches[k:])
        stop = k + int(gaps[0]) if gaps.size else None
        start = preset.start(case, k)
        first = pose_only(rows(mechanism, k, k + 1), start, length)
        if first.status[0] != Status.OK.value:
            return Run(preset.readback(case, first))
        return Run(preset.readback(case, answer(analyze_loop(rows(mechanism, k, stop), start), length)))

    got = run_past_gaps(np.degrees(theta1), reaches, preset.spec, run_from)
    messages = rssr.no_assembly_messages(got.columns["theta1_deg"], got.status, preset.why)
    return LinkageTable(ENGINE, case.name, got.columns, got.status,
                        {"iterations": got.iterations, "messages": messages, "branch": case.branch})


def solve_rssr(case: RssrCase) -> LinkageTable:
    """The in-house engine's table of an RSSR case (:func:`solve_preset`)."""
    return solve_preset(case, RSSR)


def solve_rccc(case: RcccCase) -> LinkageTable:
    """The in-house engine's table of an RCCC case (:func:`solve_preset`)."""
    return solve_preset(case, RCCC)
