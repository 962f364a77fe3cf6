"""A generated judge run over an RSSR or RCCC case: crude starts probed, runs restarted past gaps.

**Gaps and restarts** (:func:`judge_case`): the driver every engine of the RSSR and RCCC shares
(:func:`~dualmech.models.linkages.restarts.run_past_gaps`, with the reach of the case's geometry:
:func:`~dualmech.validation.judges.presets.starts.rssr_reach`,
:func:`~dualmech.validation.judges.presets.starts.rccc_reach`); a judge's run at a row starts from a crude
start of its own there, never from the in-house engine's estimate.

**Probes** (:func:`crude_start`): a crude start is tried on its row alone.  A judge that solves each pose on
its own (Pinocchio, rigid MuJoCo) is its own probe; a judge that integrates through its rows (Exudyn) has no
span of rows to integrate over there, and is probed by its own closure alone (``pose_only``: the probe's
table gives the pose and the words, no rates or reactions).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from dualmech.core.status import is_status
from dualmech.models.linkages import rccc, rssr
from dualmech.models.linkages.rccc_case import RcccCase
from dualmech.models.linkages.readback import rccc_columns, rssr_columns
from dualmech.models.linkages.restarts import ACCEPTED, Run, run_past_gaps
from dualmech.models.linkages.rssr_case import RssrCase
from dualmech.models.loop.description import LoopMechanism
from dualmech.models.loop.presets import rccc_table, rssr_table
from dualmech.models.tables import LinkageTable, TableSpec
from dualmech.validation.judges.presets import starts

#: Starts (:func:`~dualmech.validation.judges.presets.starts.scan_starts`) tried at a row before the judge's
#: run from there is taken as it is.
MAX_CRUDE_STARTS = 4

Judge = Callable[[LoopMechanism], LinkageTable]


def judge_case(case: RssrCase | RcccCase, engine: str, judge: Judge, probe: Judge | None = None,
               not_given: tuple[str, ...] = ()) -> LinkageTable:
    """An RSSR or RCCC ``case`` judged by ``judge`` (a generated judge's table of a loop table), as the
    mechanism's own table of engine ``engine`` (module docstring); ``probe``: the judge's closure alone,
    which tries the crude starts (``None``: ``judge`` itself); ``not_given``: the mechanism's columns the
    judge does not give (the Exudyn judge's ``dynamics_residual``: it has no least squares).

    At a row to start from (:func:`~dualmech.models.linkages.restarts.run_past_gaps`), each crude start
    (:data:`MAX_CRUDE_STARTS` at most) is tried on that row alone until one answers on the branch; the judge
    then runs from there to the last row, and its answers are taken where no run answered on the branch
    before.  With none on the branch the row keeps the first start's answer and the next row is tried (so a
    judge that fails everywhere costs a few solves a row).  ``meta``: ``restarts``, the rows a run started
    from, and ``iterations`` per row (of the run that answered it) where the judge counts them.
    """
    table, reach, columns_of, spec, _, _ = kind_parts(case)
    mechanism, theta1 = table(case), np.radians(case.motion.angles_deg)

    def run_from(k: int) -> Run:
        good, accepted, first = crude_start(case, mechanism, k, probe or judge, probe is not None)
        if not accepted:
            return Run(first, started=False)
        return Run(columns_of(case, judge(starts.with_start(mechanism, good, k)), not_given))

    rows = run_past_gaps(np.degrees(theta1), rssr.assembles(reach(case, theta1)), spec, run_from)
    meta = {"iterations": rows.iterations} if rows.counted else {}
    return LinkageTable(engine, case.name, rows.columns, rows.status, {**meta, "restarts": rows.restarts})


def kind_parts(case: RssrCase | RcccCase
               ) -> tuple[Callable, Callable, Callable, TableSpec, Callable, Callable]:
    """The table, reach, column reader, spec, crude start angles and crude start of ``case``'s kind (the
    starts looked up in :mod:`~dualmech.validation.judges.presets.starts` at each call)."""
    if isinstance(case, RssrCase):
        return (rssr_table, starts.rssr_reach, rssr_columns, rssr.SPEC, starts.rssr_start_angles,
                starts.rssr_start)
    return rccc_table, starts.rccc_reach, rccc_columns, rccc.SPEC, starts.rccc_start_angles, starts.rccc_start


def crude_start(case: RssrCase | RcccCase, mechanism: LoopMechanism, k: int, judge: Judge,
                pose_only: bool = False) -> tuple[tuple, bool, LinkageTable]:
    """The first of the crude starts at row ``k`` (:data:`MAX_CRUDE_STARTS` at most:
    :func:`~dualmech.validation.judges.presets.starts.rssr_start`,
    :func:`~dualmech.validation.judges.presets.starts.rccc_start`) from which ``judge`` answers that row
    alone on the case's branch, ``True`` and that answer (the mechanism's one-row table); with none on the
    branch, the first start, ``False`` and its answer.  ``pose_only``: ``judge`` gives the pose and the
    words alone (a closure: module docstring), no rates or reactions."""
    _, _, columns_of, spec, angles, start = kind_parts(case)
    theta1 = float(np.radians(case.motion.angles_deg[k]))
    not_given = spec.rates + spec.reactions if pose_only else ()
    first = None
    for theta4 in angles(case, theta1)[:MAX_CRUDE_STARTS]:
        pose = start(case, theta1, theta4)
        answer = columns_of(case, judge(starts.with_start(mechanism, pose, k, k + 1)), not_given)
        if is_status(answer.status, *ACCEPTED)[0]:
            return pose, True, answer
        first = (pose, False, answer) if first is None else first
    return first
