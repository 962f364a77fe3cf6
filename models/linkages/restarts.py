"""An engine's runs over the rows of an RSSR or RCCC case, restarted past gaps in assembly.

Every engine of the RSSR and the RCCC follows the case's branch along its rows by continuation (the in-house
loop engine, the generated judges).  Rows where the case's geometry does not reach (the coupler misses the
output crank's circle, the RCCC's cones about ``z2`` and ``z4`` miss: the reach ratio ``rho`` of
``docs/conventions.md``, "RSSR", "RCCC", :func:`~dualmech.models.linkages.rssr.assembles`) are
``no_assembly``; an engine runs from the first row that reaches, and again from every later row that reaches
but that no run has answered on the branch (past a gap, where continuity is lost; next to an assembly limit,
where a continuation may cross to the other branch).  :func:`run_past_gaps` is that driver; how a run is
started at a row is the engine's (``run_from``): the in-house engine from its own estimate there
(:mod:`dualmech.models.loop.preset_engine`), a judge from a crude start of its own, probed on the row first
(:mod:`dualmech.validation.judges.presets.run`).  It loops over the runs, never over the rows.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from dualmech.core.status import Status, is_status
from dualmech.models.tables import LinkageTable, TableSpec

#: The mechanism's words of a row answered on the case's branch: no restart there.
ACCEPTED = (Status.OK.value, Status.DEAD_CENTRE.value, Status.ASSEMBLY_LIMIT.value)


@dataclass(frozen=True)
class Run:
    """One run's answer from row ``k`` on: ``table`` the mechanism's table of the rows ``k``,
    ``k + 1``, ... (as many as it has); ``started`` whether the run began on the case's branch (its rows
    are then taken wherever no earlier run answered them on the branch; else only row ``k`` is, as it is)."""

    table: LinkageTable
    started: bool = True


@dataclass(frozen=True)
class Rows:
    """The rows of a case gathered from its runs: ``columns`` (the spec's, each ``(n,)``), ``status``
    ``(n,)`` words, ``iterations`` ``(n,)`` (of the run that answered each row; ``counted``: whether any run
    reported them) and ``restarts`` (the rows, 0-based, a run on the branch started from)."""

    columns: dict[str, np.ndarray]
    status: np.ndarray
    iterations: np.ndarray
    counted: bool
    restarts: np.ndarray


def run_past_gaps(theta1_deg: np.ndarray, reaches: np.ndarray, spec: TableSpec,
                  run_from: Callable[[int], Run]) -> Rows:
    """Every row of a case (crank angles ``theta1_deg`` ``(n,)``, deg; ``reaches`` ``(n,)`` whether its
    geometry reaches there) from the runs ``run_from(k)`` (module docstring).

    The first row that reaches and that no run has answered on the branch (:data:`ACCEPTED`), after the last
    row a run started from, starts the next run; a run that did not start on the branch gives that row alone.
    Rows that do not reach are ``no_assembly``; a reaching row no run answered keeps its run's word
    (``not_converged`` if none).
    """
    n = theta1_deg.shape[0]
    cols = {c: np.full(n, np.nan) for c in spec.columns}
    cols[spec.key] = np.asarray(theta1_deg, dtype=float).copy()
    status = np.full(n, Status.NOT_CONVERGED.value, dtype=object)
    status[~reaches] = Status.NO_ASSEMBLY.value
    iterations, restarts, counted, last = np.zeros(n, dtype=int), [], False, -1
    while True:
        pending = np.flatnonzero(reaches & ~is_status(status, *ACCEPTED))
        pending = pending[pending > last]
        if pending.size == 0:
            break
        k = last = int(pending[0])
        run = run_from(k)
        span = len(run.table) if run.started else 1
        rows = k + np.flatnonzero(reaches[k:k + span] & ~is_status(status[k:k + span], *ACCEPTED))
        restarts += [k] if run.started else []
        for c in spec.columns:
            cols[c][rows] = run.table[c][rows - k]
        status[rows] = run.table.status[rows - k]
        if "iterations" in run.table.meta:
            iterations[rows], counted = np.asarray(run.table.meta["iterations"])[rows - k], True
    return Rows(cols, status, iterations, counted, np.array(restarts, dtype=int))
