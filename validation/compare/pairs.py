"""Every pair of engines, measured as the gate measures a judge against the reference (the report's pair
table).

The gate holds each judge to the reference.  The pair table shows, per column group, how closely every
*pair* of engines agrees over a run's cases, so that a reader sees formulations that share no code agree
with each other, not only each with the in-house engine.  A pair of two judges is measured by the gate's own
checks of its kind (the slider crank's :func:`~dualmech.validation.compare.checks.compare_case`, the
other kinds' :func:`~dualmech.validation.compare.tables.judge_checks`) with the engine earlier in the matrix's
order in the reference's place: its scale ``s_g`` (the case's own peak, as that engine gives it), its
condition factor, the same row matching, status rules and per-row laws, and the looser of the two judges'
tolerances (:func:`looser`), beside its own ``status`` check (the reference's, :func:`case_pairs`).  A pair
with the reference is the gate's own checks of the judge.  The slider crank's per-row laws (near a joint
lock, the conditioning of a row) are the case's, measured on the reference: a case whose reference failed
is compared by no pair, as by no judge.

The pair of two judges is informative, not a verdict (its
:attr:`~dualmech.validation.compare.results.Pair.verdict` is false): each judge is held to the reference
already, and two judges that each pass may differ by up to the sum of their tolerances, more than the looser
one; a pair beyond it is a lead to read, the gate's checks say whether a judge fails.
"""

from __future__ import annotations

from itertools import combinations
from typing import Callable, Sequence

from dualmech.validation.compare.results import (
    ENGINE,
    POSE_COLUMNS,
    RATE_COLUMNS,
    STATUS,
    STROKE,
    Check,
    Pair,
)
from dualmech.validation.matrix import ResolvedTolerance

#: The column groups of the pair table, in the table's order: the pose, its rates (and the transmission),
#: the joints' force and moment components, the scalar efforts (the drive's and the loads': ``drive_torque``,
#: ``slider_load``, a loop table's ``effort_*``), and the slider crank's stroke.
GROUPS: tuple[str, ...] = ("coordinates", "rates", "forces", "moments", "efforts", STROKE)

#: A case's checks of ``other`` with ``one`` in the reference's place, from ``(one, other)``.
Measure = Callable[[str, str], list[Check]]
#: A column's group (:data:`GROUPS`), from its name.
GroupOf = Callable[[str], str]


def looser(one: dict[str, ResolvedTolerance], other: dict[str, ResolvedTolerance]
           ) -> dict[str, ResolvedTolerance]:
    """Per quantity (column, stroke, status band, joint-lock cap), the larger of two judges' tolerances:
    each is an allowance, so the larger value is the looser; a quantity only one judge has keeps its own."""
    out = dict(other) | dict(one)
    for q in one.keys() & other.keys():
        out[q] = other[q] if other[q].value > one[q].value else one[q]
    return out


def column_group(column: str, pose: Sequence[str], rates: Sequence[str]) -> str:
    """The group (:data:`GROUPS`) of a compared ``column`` of a table whose pose and rate columns are
    ``pose`` and ``rates``: a joint's ``<joint>_f{x,y,z}`` is a force, ``<joint>_m{x,y,z}`` a moment, any
    other reaction a scalar effort."""
    if column == STROKE:
        return STROKE
    if column in pose:
        return "coordinates"
    if column in rates:
        return "rates"
    joint, _, component = column.rpartition("_")
    if joint and len(component) == 2 and component[0] in "fm" and component[1] in "xyz":
        return "forces" if component[0] == "f" else "moments"
    return "efforts"


def slider_crank_group(column: str) -> str:
    """:func:`column_group` of a slider crank's compared column."""
    return column_group(column, POSE_COLUMNS, RATE_COLUMNS)


def case_pairs(engines: Sequence[str], reference: str, gate: Sequence[Check], measure: Measure,
               group_of: GroupOf, into: dict[tuple[str, str], list[tuple[str, Check]]]) -> None:
    """Add one case's checks of every pair of ``engines`` (those that answered it, in the matrix's order) to
    ``into`` (pair -> ``(group, check)``, ``status`` the status checks' group): the ``gate``'s checks for
    each pair with the ``reference`` (the judge's, and the reference's own ``status`` check: a status check
    leaves the rows where its reference failed to that one), ``measure(one, other)`` for each pair of
    judges (the same two: ``one``'s own, then ``other``'s with ``one`` in the reference's place)."""
    judges = [e for e in engines if e != reference]
    for check in gate:
        for judge in judges if check.engine == reference and check.quantity == STATUS else [check.engine]:
            if judge in judges:
                _add(into, (reference, judge), check, group_of)
    for one, other in combinations(judges, 2):
        for check in measure(one, other):
            _add(into, (one, other), check, group_of)


def _add(into: dict[tuple[str, str], list[tuple[str, Check]]], pair: tuple[str, str], check: Check,
         group_of: GroupOf) -> None:
    """``check`` under ``pair`` with its group; an ``engine`` check (the engine did not run) is none."""
    if check.quantity != ENGINE:
        group = STATUS if check.quantity == STATUS else group_of(check.quantity)
        into.setdefault(pair, []).append((group, check))


def pair_table(pairs: dict[tuple[str, str], list[tuple[str, Check]]], engines: Sequence[str],
               reference: str) -> tuple[Pair, ...]:
    """The :class:`Pair` of every pair in ``pairs`` (:func:`case_pairs`), ordered by ``engines``."""
    order = {e: i for i, e in enumerate(engines)}
    out = []
    for (one, other), grouped in sorted(pairs.items(), key=lambda kv: (order[kv[0][0]], order[kv[0][1]])):
        status = [c for g, c in grouped if g == STATUS]
        cells = {g: max((c for h, c in grouped if h == g), key=_severity) for g in GROUPS
                 if any(h == g for h, _ in grouped)}
        out.append(Pair(one, other, one == reference, cells, len({c.case for c in status}),
                        sum(c.n_mismatch for c in status)))
    return tuple(out)


def _severity(check: Check) -> tuple[bool, float]:
    """A failing check first, then the larger ratio to tolerance (``inf`` for a failure without a number)."""
    return (not check.passed, check.ratio)
