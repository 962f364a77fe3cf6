"""The comparison of a run: every case by the gate of its kind, into one :class:`Comparison`.

Whatever the kind, a case's engines either answered (a table), raised (the first line of the error: a failing
``engine`` check), or are missing from the results (``incomplete``: the run is unfinished); a reference that
failed or did not run leaves every judge ``not compared``.  The answered tables are then compared by the
case's kind: a slider crank's by :func:`~dualmech.validation.compare.checks.compare_slider_crank` (its
columns, load mode, status rules, condition factors, joint lock and odd one out), every other kind's by its
own table spec (:func:`~dualmech.validation.compare.tables.compare_table_case`: the RSSR, RCCC and loop
tables).  So a matrix may mix kinds, and one verdict, one report and one baseline cover them all.
"""

from __future__ import annotations

import numpy as np

from dualmech.core.status import Status, is_status
from dualmech.core.table import ColumnTable
from dualmech.validation.compare.checks import compare_slider_crank, fail, first_line
from dualmech.validation.compare.differences import status_memo, stroke
from dualmech.validation.compare.pairs import pair_table
from dualmech.validation.compare.results import ENGINE, Check, Comparison, RowDifferences
from dualmech.validation.compare.tables import compare_table_case
from dualmech.validation.matrix import Matrix, MatrixCase, ResolvedTolerance

#: The tolerance of an engine check: it must run.
ENGINE_RUNS = ResolvedTolerance("exact", 0.0, "the engine must run")


def compare_run(matrix: Matrix, results: dict[str, dict[str, ColumnTable | str]]) -> Comparison:
    """All checks of a run.

    Parameters
    ----------
    matrix : Matrix
        Its cases, of any kinds.
    results : dict
        Case id -> engine -> its table, or the error message (str) when the engine raised.  A case or
        engine missing from ``results`` gives failing ``incomplete`` checks (an unfinished run is never a
        pass).
    """
    with status_memo():  # each table's status masks computed once, not once per quantity
        checks: list[Check] = []
        strokes: dict[str, dict[str, float]] = {}
        dead: dict[str, dict[str, int]] = {}
        errors: dict[str, dict[str, str]] = {}
        rows: dict[str, dict[str, RowDifferences]] = {}
        pairs: dict[tuple[str, str], list[tuple[str, Check]]] = {}
        for mc in matrix.cases:
            per_engine = results.get(mc.id, {})
            errors[mc.id] = {e: v for e, v in per_engine.items() if isinstance(v, str)}
            tables = {e: per_engine[e] for e in matrix.engines_of(mc)
                      if isinstance(per_engine.get(e), ColumnTable)}
            slider_crank = mc.is_slider_crank
            strokes[mc.id] = {e: stroke(t) for e, t in tables.items()} if slider_crank else {}
            dead[mc.id] = {e: int(np.sum(is_status(t.status, Status.DEAD_CENTRE))) for e, t in tables.items()}
            checks += _engine_checks(matrix, mc, per_engine, errors[mc.id], tables)
            if matrix.reference not in tables:
                continue
            compare = compare_slider_crank if slider_crank else compare_table_case
            checks += compare(matrix, mc, tables, rows.setdefault(mc.id, {}), pairs)
    return Comparison(tuple(checks), strokes, dead, errors, {c: r for c, r in rows.items() if r},
                      pair_table(pairs, matrix.engines, matrix.reference))


def _engine_checks(matrix: Matrix, mc: MatrixCase, per_engine: dict, errors: dict[str, str],
                   tables: dict[str, ColumnTable]) -> list[Check]:
    """The failing ``engine`` checks of case ``mc``: its engines that did not run (``incomplete``) or raised,
    and, where the reference gave no table, every judge that did (``not compared``)."""
    checks = []
    for e in matrix.engines_of(mc):
        if e not in per_engine:
            checks.append(fail(mc.id, e, ENGINE, ENGINE_RUNS, "not run (the run is unfinished)",
                               incomplete=True))
        elif e in errors:
            checks.append(fail(mc.id, e, ENGINE, ENGINE_RUNS, first_line(errors[e])))
    if matrix.reference not in tables:
        why = "did not run" if matrix.reference not in per_engine else "failed"
        checks += [fail(mc.id, e, ENGINE, ENGINE_RUNS, f"not compared: the reference {why}",
                        incomplete=why == "did not run") for e in matrix.judges if e in tables]
    return checks
