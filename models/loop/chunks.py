"""A long loop table's in-house answer chunk by chunk, in drive order, for a file that is written as it grows.

The continuation of :func:`~dualmech.models.loop.engine.analyze_loop` follows its branch from one pose to
the next, so a chunk of positions is analysed from the last pose before it on the branch: the last earlier
row that closed on it (``ok`` or ``dead_centre``) with a regular pose (not at a joint lock, where the sign
that labels the branch is rounding), prepended to the chunk as a row of its own and dropped from its table.
Past a gap (rows that do not close) that row lies before the gap, as the whole run closes the rows after a
gap from the pose before it.  The start of the first chunk is the whole drive's
(:func:`~dualmech.models.loop.engine.find_start`), and that chunk reaches past its position.  A chunk's
rows differ from the whole run's by rounding only (its stations are its own); their words are the same.
Past a gap whose end is an assembly limit (a singular pose: its sign is rounding) the rows after it may be
closed on other assemblies than the whole run's, each run's stations closing them from the pose before the
gap in their own order (``docs/conventions.md``, "Past a gap": continuity with the start is lost there).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Iterator, NamedTuple

import numpy as np

from dualmech.core.loop import LoopState
from dualmech.core.status import Status, is_status
from dualmech.models.loop.description import LoopMechanism
from dualmech.models.loop.engine import LoopAnalysis, analyze_loop, find_start, regular
from dualmech.models.loop.mobility import check_mobility
from dualmech.models.loop.table import analysis_table
from dualmech.models.loop.translate import drive_state, to_loop
from dualmech.models.tables import LinkageTable


class Chunk(NamedTuple):
    """One chunk's analysis and how many of its first rows are not the chunk's (the pose it started from)."""

    analysis: LoopAnalysis
    skip: int


def iter_analyses(mechanism: LoopMechanism, size: int) -> Iterator[Chunk]:
    """The in-house analyses of ``mechanism``'s drive positions, ``size`` at a time (the first chunk reaches
    past the start's position), in order (module docstring); :func:`chunk_table` makes each a table."""
    check_mobility(mechanism)
    positions = np.asarray(mechanism.drive.positions, dtype=float)
    n = positions.size
    pose, at = find_start(mechanism, to_loop(mechanism), drive_state(mechanism))
    end = min(n, max(size, at + 1))
    an = analyze_loop(_over(mechanism, positions[:end]), pose, at)
    yield Chunk(an, 0)
    last = _last_on_branch(an, 0)
    while end < n:
        rows = np.arange(end, min(n, end + size))
        if last is None:  # no row on the branch with a regular pose yet: a start of its own (searched)
            an = analyze_loop(_over(mechanism, positions[rows]))
            yield Chunk(an, 0)
            last = _last_on_branch(an, 0)
        else:
            value, state = last
            an = analyze_loop(_over(mechanism, np.concatenate([[value], positions[rows]])), state, 0)
            yield Chunk(an, 1)
            last = _last_on_branch(an, 1) or last
        end = rows[-1] + 1


def chunk_table(chunk: Chunk) -> LinkageTable:
    """The in-house table of a chunk's own rows (:func:`~dualmech.models.loop.table.analysis_table`); its
    meta's per-row arrays cut to them, its messages (of the chunk's gaps) left out."""
    table = analysis_table(chunk.analysis)
    if not chunk.skip:
        return table
    rows = slice(chunk.skip, None)
    meta = {k: v[rows] if isinstance(v, np.ndarray) else v for k, v in table.meta.items() if k != "messages"}
    return LinkageTable(table.engine, table.case, {c: v[rows] for c, v in table.columns.items()},
                        table.status[rows], meta)


def iter_tables(mechanism: LoopMechanism, size: int) -> Iterator[LinkageTable]:
    """The tables of :func:`iter_analyses`, in order."""
    return (chunk_table(chunk) for chunk in iter_analyses(mechanism, size))


def _over(mechanism: LoopMechanism, positions: np.ndarray) -> LoopMechanism:
    """``mechanism`` driven over ``positions`` only."""
    return replace(mechanism, drive=replace(mechanism.drive, positions=positions))


def _last_on_branch(an: LoopAnalysis, first: int) -> tuple[float, LoopState] | None:
    """The drive position and pose of ``an``'s last row from ``first`` on that closed on the branch with a
    regular pose, or ``None``."""
    on = np.flatnonzero(is_status(an.status, Status.OK, Status.DEAD_CENTRE))
    for i in on[on >= first][::-1]:
        if regular(an, int(i)):
            return float(an.mechanism.drive.positions[i]), an.state.take(slice(int(i), int(i) + 1))
    return None
