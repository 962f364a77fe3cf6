"""A linkage run: every case of a :class:`~dualmech.validation.linkages.matrix.LinkageMatrix` on every engine
that solves it, by the matrix runner (:func:`~dualmech.validation.run.runner.run_matrix`: a process pool, each
result stored in the run folder as it finishes, ``resume``), then compared by the gate
(:mod:`~dualmech.validation.linkages.gate`): every judge with the reference table, row by row.
"""

from __future__ import annotations

from contextlib import nullcontext
from dataclasses import dataclass
from pathlib import Path
from tempfile import TemporaryDirectory

import numpy as np

from dualmech.core.status import Status, is_status
from dualmech.models.kinds import SLIDER_CRANK, kind_of
from dualmech.models.linkages import linkage_case, table_spec
from dualmech.models.linkages.table import LinkageTable
from dualmech.validation.compare import Check, Comparison, Verdict
from dualmech.validation.compare.baseline import run_summary
from dualmech.validation.compare.pairs import case_pairs, column_group, looser, pair_table
from dualmech.validation.linkages.gate import (
    engine_check,
    judge_checks,
    judge_tolerances,
    reference_check,
    reference_values,
)
from dualmech.validation.linkages.matrix import LinkageEntry, LinkageMatrix
from dualmech.validation.matrix import Matrix, MatrixCase
from dualmech.validation.progress import ProgressCallback
from dualmech.validation.run.runner import load_entries, run_matrix, timings
from dualmech.validation.rundir import write_file


@dataclass(frozen=True)
class LinkageRun:
    """A compared linkage run.

    Attributes
    ----------
    matrix : LinkageMatrix
    tables : dict
        Case id -> engine -> its table, or the error text of an engine that raised.
    comparison : Comparison
        Every check; ``dead_centres`` case -> engine -> rows; ``errors`` case -> engine -> message.
    ratios : dict
        Case id -> judge -> ``(key, kinematic ratio, reaction ratio)`` per row (the key: the input value,
        :attr:`~dualmech.models.linkages.table.TableSpec.key`), each ``(n,)``: the
        worst ``r_i`` over its tolerance (NaN where nothing was compared).
    seconds : dict
        Case id -> engine -> wall time of its solve (s).
    """

    matrix: LinkageMatrix
    tables: dict[str, dict[str, LinkageTable | str]]
    comparison: Comparison
    ratios: dict[str, dict[str, tuple[np.ndarray, ...]]]
    seconds: dict[str, dict[str, float]]

    @property
    def verdict(self) -> Verdict:
        """``PASS``, ``FAIL`` or ``INCOMPLETE`` (:attr:`Comparison.verdict`)."""
        return self.comparison.verdict

    def baseline(self) -> dict:
        """The baseline of this run (:func:`~dualmech.validation.compare.baseline.run_summary`; the reference
        values of each case's table by its spec: :func:`~dualmech.validation.linkages.gate.reference_values`),
        for ``--write-baseline`` and ``--baseline``."""
        references = {}
        for entry in self.matrix.cases:
            table = self.tables.get(entry.id, {}).get(self.matrix.reference)
            references[entry.id] = (None if table is None or isinstance(table, str)
                                    else reference_values(table, table_spec(entry.kind, entry.case)))
        return run_summary(self.matrix.name, self.matrix.reference, self.matrix.engines, references,
                           self.comparison)

    def worst(self) -> dict[str, Check]:
        """Per judge, its check of the largest ratio to tolerance over every case (a failing one first)."""
        out: dict[str, Check] = {}
        for c in self.comparison.checks:
            if c.engine == self.matrix.reference:
                continue
            best = out.get(c.engine)
            if best is None or (not c.passed, c.ratio) > (not best.passed, best.ratio):
                out[c.engine] = c
        return out


def as_run_matrix(matrix: LinkageMatrix) -> Matrix:
    """The matrix the runner runs: every case's table as written (``raw``) and the engines that solve it
    (:meth:`~dualmech.validation.linkages.matrix.LinkageMatrix.engines_of`); a linkage matrix has no
    sweeps, load modes or per-quantity tolerances of the slider crank's kind (its gate takes them from each
    kind's table spec)."""
    cases = tuple(MatrixCase(e.id, e.data, "", {}, (), {}, False, None, matrix.engines_of(e))
                  for e in matrix.cases)
    return Matrix(matrix.name, matrix.description, matrix.source, matrix.reference, matrix.engines, (), (),
                  cases, (), {}, {})


def stored_linkage_matrix(matrix: Matrix) -> LinkageMatrix | None:
    """The linkage matrix a stored run of ``matrix`` (its ``run.json``) was made from, its cases read again
    from their stored tables; ``None`` for a run of slider-crank cases."""
    if all(kind_of(mc.raw) == SLIDER_CRANK for mc in matrix.cases):
        return None
    entries = tuple(LinkageEntry(mc.id, matrix.source, kind_of(mc.raw), linkage_case(mc.raw), mc.raw)
                    for mc in matrix.cases)
    return LinkageMatrix(matrix.name, matrix.description, matrix.source, matrix.engines, matrix.reference,
                         entries)


def run_linkages(matrix: LinkageMatrix, outdir: str | Path | None = None, *, jobs: int = 1,
                 resume: bool = False, scheduler: str | None = None,
                 progress: ProgressCallback | None = None) -> LinkageRun:
    """Solve every case of ``matrix`` on its engines, storing each result in ``outdir`` as it finishes (a
    folder of its own when ``None``, removed after), and compare each judge with the reference.

    ``jobs``, ``resume``, ``scheduler`` and ``progress`` are
    :func:`~dualmech.validation.run.runner.run_matrix`'s.
    """
    runnable = as_run_matrix(matrix)
    with TemporaryDirectory(prefix="dualmech-linkages-") if outdir is None else nullcontext(outdir) as folder:
        outcome = run_matrix(runnable, folder, jobs=jobs, resume=resume, scheduler=scheduler,
                             progress=progress)
        seconds = timings(load_entries(Path(folder), runnable))
    tables: dict[str, dict[str, LinkageTable | str]] = {e.id: dict(outcome.results.get(e.id, {}))
                                                         for e in matrix.cases}
    ratios: dict[str, dict[str, tuple[np.ndarray, ...]]] = {}
    checks: list[Check] = []
    pairs: dict[tuple[str, str], list[tuple[str, Check]]] = {}
    for entry in matrix.cases:
        ratios[entry.id] = {}
        checks += _compare_case(matrix, entry, tables[entry.id], ratios[entry.id], pairs)
    errors = {cid: {e: t for e, t in per.items() if isinstance(t, str)} for cid, per in tables.items()}
    dead = {cid: {e: int(is_status(t.status, Status.DEAD_CENTRE).sum()) for e, t in per.items()
                  if not isinstance(t, str)} for cid, per in tables.items()}
    comparison = Comparison(tuple(checks), {}, dead, errors,
                            pairs=pair_table(pairs, matrix.engines, matrix.reference))
    return LinkageRun(matrix, tables, comparison, ratios,
                      {e.id: seconds.get(e.id, {}) for e in matrix.cases})


def _compare_case(matrix: LinkageMatrix, entry: LinkageEntry, tables: dict[str, LinkageTable | str],
                  ratios: dict[str, tuple[np.ndarray, ...]],
                  pairs: dict[tuple[str, str], list[tuple[str, Check]]]) -> list[Check]:
    """The checks of one case: the reference's own, then every judge's (engine, status, columns); each pair
    of engines that answered it added to ``pairs`` (:func:`~dualmech.validation.compare.pairs.case_pairs`:
    two judges by the gate's :func:`~dualmech.validation.linkages.gate.judge_checks`, at the looser of their
    tolerances)."""
    name = matrix.reference
    reference = tables[name]
    judges = [e for e in tables if e != name]
    if isinstance(reference, str):
        return [engine_check(entry.id, name, reference)] + [
            engine_check(entry.id, e, f"not compared: the reference {name} failed") for e in judges]
    spec = table_spec(entry.kind, entry.case)
    checks = [reference_check(entry.id, reference, spec)]
    for e in judges:
        table = tables[e]
        if isinstance(table, str):
            checks.append(engine_check(entry.id, e, table))
            continue
        found, rows = judge_checks(entry.id, reference, table, spec)
        checks += found
        if rows is not None:
            ratios[e] = rows
    answered = {e: t for e, t in tables.items() if not isinstance(t, str)}
    case_pairs([e for e in matrix.engines if e in answered], name, checks,
               lambda one, other: [reference_check(entry.id, answered[one], spec), *judge_checks(
                   entry.id, answered[one], answered[other], spec,
                   looser(judge_tolerances(one), judge_tolerances(other)))[0]],
               lambda column: column_group(column, spec.pose, spec.rates), pairs)
    return checks


def write_tables(run: LinkageRun, outdir: Path) -> list[Path]:
    """Every engine's table of every case as ``tables/<case>/<engine>.csv`` (full precision)."""
    return [write_file(outdir, f"tables/{case_id}/{engine}.csv", table.to_csv(), record=False)
            for case_id, per in run.tables.items() for engine, table in per.items()
            if not isinstance(table, str)]
