"""The in-house engine's answer on a loop table as the linkages' result table (``docs/conventions.md``,
"Loop tables"): :func:`analysis_table` of an :func:`~dualmech.models.loop.engine.analyze_loop` answer, and
:func:`solve_loop_table`, the ``dualmech`` engine of ``[mechanism] kind = "loop"`` in the linkages' registry
(:mod:`dualmech.validation.engines`).  The columns are :mod:`~dualmech.models.loop.columns`'s, the
ones every judge of a loop table gives.
"""

from __future__ import annotations

import numpy as np

from dualmech.core.status import Status, is_status
from dualmech.models.angle_ranges import format_angle_ranges, no_assembly_ranges
from dualmech.models.loop.columns import coordinate_names, effort_names, loop_spec, loop_table, wrench_columns
from dualmech.models.loop.description import LoopMechanism
from dualmech.models.loop.engine import LoopAnalysis, analyze_loop
from dualmech.models.tables import LinkageTable, TableSpec

#: The registry name of the in-house engine.
ENGINE = "dualmech"


def analysis_columns(an: LoopAnalysis) -> dict[str, np.ndarray]:
    """Every column of :func:`~dualmech.models.loop.columns.column_names` and the residuals of ``an``, each
    ``(n,)``: joint coordinates with their rates, efforts, joint wrenches (world axes, moments about each
    joint's point), the closure residual and the Newton-Euler least squares' relative residual."""
    cols: dict[str, np.ndarray] = {}
    for name in coordinate_names(an.mechanism):
        coordinate = name.rstrip("0123456789")
        value, rate, accel = an.coordinate(int(name[len(coordinate):]) - 1, coordinate)
        cols.update({name: value, f"{name}_dot": rate, f"{name}_ddot": accel})
    w = an.wrenches
    cols.update({f"effort_{e}": w.efforts[e] for e in effort_names(an.mechanism)})
    cols.update(wrench_columns(w.force, w.moment), residual=an.residual, dynamics_residual=w.residual)
    return cols


def analysis_table(an: LoopAnalysis) -> LinkageTable:
    """The in-house table of ``an`` (settled by its status words; ``meta["iterations"]``: the closure's
    iterations per position; ``meta["messages"]``: where the loop does not close, :func:`gap_messages`)."""
    table = loop_table(ENGINE, an.mechanism, analysis_columns(an), an.status,
                       {"iterations": np.asarray(an.iterations)})
    table.meta["messages"] = gap_messages(table, loop_spec(an.mechanism))
    return table


#: What :func:`gap_messages` says of the rows of each word, after ``"<word>: "``.
GAP_WORDS: tuple[tuple[Status, str], ...] = (
    (Status.NO_ASSEMBLY, "the loop does not close"),
    (Status.BRANCH_JUMP, "the branch followed from the start has ended: the loop closes only on another "
                         "assembly"),
)


def gap_messages(table: LinkageTable, spec: TableSpec) -> list[str]:
    """A message per word of :data:`GAP_WORDS` naming the drive positions (``"a..b"`` runs of the table's
    key) of its rows, or none."""
    name, unit = spec.key_label
    out = []
    for word, says in GAP_WORDS:
        ranges = no_assembly_ranges(table.columns[spec.key], is_status(table.status, word))
        if ranges:
            out.append(f"{word.value}: {says} at {name} = {format_angle_ranges(ranges)}"
                       + (f" {unit}" if unit else " (the case's length unit)"))
    return out


def solve_loop_table(mechanism: LoopMechanism) -> LinkageTable:
    """Every drive position of ``mechanism`` by the in-house engine (:func:`analysis_table` of
    :func:`~dualmech.models.loop.engine.analyze_loop`)."""
    return analysis_table(analyze_loop(mechanism))
