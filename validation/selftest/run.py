"""Running every fault of a catalogue against the gate, and its report (command: dualmech.cli.selftest)."""

from __future__ import annotations

import concurrent.futures as cf
import shutil
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from dualmech.validation.rundir import locked, record_files
from dualmech.validation.selftest.catalogue import (
    Catalogue,
    Mutant,
    SelftestError,
    stale_reason,
)
from dualmech.validation.selftest.gate import GateRun, run_gate, stop_gates
from dualmech.validation.selftest.scratch import check_source, make_scratch, source_root


@dataclass(frozen=True)
class Outcome:
    """What happened to one mutant."""

    mutant: Mutant
    run: GateRun


@dataclass
class Report:
    """A whole selftest: the unmutated gate's run and every mutant's outcome."""

    pristine: GateRun
    outcomes: list[Outcome] = field(default_factory=list)
    seconds: float = 0.0

    @property
    def killed(self) -> int:
        return sum(o.run.killed for o in self.outcomes)

    @property
    def score(self) -> float:
        """Killed fraction in percent (0 for an empty catalogue)."""
        return 100.0 * self.killed / len(self.outcomes) if self.outcomes else 0.0

    @property
    def passed(self) -> bool:
        return self.pristine.verdict == "pass" and bool(self.outcomes) and self.killed == len(self.outcomes)


def run_selftest(
    catalogue: Catalogue,
    root: Path | None = None,
    *,
    jobs: int = 2,
    timeout: float = 600.0,
    only: tuple[str, ...] = (),
    progress: Callable[[Outcome], None] | None = None,
    keep: Path | None = None,
) -> Report:
    """Run every mutant of ``catalogue`` (or those named in ``only``) against the gate.

    Parameters
    ----------
    catalogue : Catalogue
    root : path, optional
        Source tree to copy (default :func:`source_root`); never modified.
    jobs : int
        Mutants gated side by side (each gate process runs one job).
    timeout : float
        Seconds each gate step (matrix, tests) may take.
    only : tuple of str
        Mutant ids to run (default all); an unknown id is a :class:`SelftestError`.
    progress : callable, optional
        Called with each :class:`Outcome` as it finishes.
    keep : path, optional
        Work directory to use and keep (scratch copies, runs, the baseline): new, empty or dualmech's,
        locked while the selftest runs (:mod:`~dualmech.validation.rundir`); default a temporary one.
    """
    root = check_source(source_root() if root is None else root)
    chosen = _chosen(catalogue, only, jobs, timeout)
    if keep:
        with locked(keep) as work:  # a dualmech folder, one selftest at a time
            return _run(catalogue, root, chosen, jobs, timeout, progress, work, True)
    work = Path(tempfile.mkdtemp(prefix="dualmech-selftest-"))
    try:
        return _run(catalogue, root, chosen, jobs, timeout, progress, work, False)
    finally:
        shutil.rmtree(work, ignore_errors=True)


def _run(catalogue: Catalogue, root: Path, chosen: list[Mutant], jobs: int, timeout: float,
         progress: Callable[[Outcome], None] | None, work: Path, keep: bool) -> Report:
    """:func:`run_selftest` in its work folder (kept if ``keep``)."""
    start = time.perf_counter()
    stop_gates(False)
    baseline = work / "baseline.json"
    source = make_scratch(root, work / "pristine")  # one snapshot: every mutant is a copy of it
    report = Report(run_gate(source, catalogue, None, baseline, timeout))
    if keep and baseline.is_file():
        record_files(work, [baseline.name])  # the kept folder is dualmech's (rundir.MARKERS)
    if report.pristine.verdict == "pass":
        def one(m: Mutant) -> Outcome:
            return _gate_mutant(m, source, work, catalogue, baseline, timeout, keep)

        pool = cf.ThreadPoolExecutor(max_workers=jobs)
        try:
            for fut in cf.as_completed([pool.submit(one, m) for m in chosen]):
                report.outcomes.append(fut.result())
                if progress is not None:
                    progress(report.outcomes[-1])
        except BaseException:  # interrupted: the gates running are killed, not waited for (minutes)
            pool.shutdown(wait=False, cancel_futures=True)
            stop_gates()
            raise
        pool.shutdown()
        order = {m.id: i for i, m in enumerate(chosen)}
        report.outcomes.sort(key=lambda o: order[o.mutant.id])
    report.seconds = time.perf_counter() - start
    return report


def _chosen(catalogue: Catalogue, only: tuple[str, ...], jobs: int, timeout: float) -> list[Mutant]:
    """The mutants to run (``only``, else all), after checking the run's settings (one-line errors)."""
    if jobs < 1:
        raise SelftestError(f"jobs: expected a number of processes >= 1, got {jobs}")
    if not timeout > 0:
        raise SelftestError(f"timeout: expected a positive number of seconds, got {timeout!r}")
    ids = {m.id for m in catalogue.mutants}
    unknown = [i for i in only if i not in ids]
    if unknown:
        raise SelftestError(f"only: {unknown[0]!r} is not a mutant of the catalogue")
    return [m for m in catalogue.mutants if not only or m.id in only]


def _gate_mutant(m: Mutant, source: Path, work: Path, catalogue: Catalogue, baseline: Path, timeout: float,
                 keep: bool) -> Outcome:
    """One mutant: a stale fault is an ERROR, else its scratch copy through the gate (kept if ``keep``)."""
    why = stale_reason(m, source)
    if why:
        return Outcome(m, GateRun("error", 0.0, why))
    scratch = make_scratch(source, work / f"mutant-{m.id}", m)
    first = m.fault_class == "comparison"
    outcome = Outcome(m, run_gate(scratch, catalogue, baseline, None, timeout, tests_first=first))
    if not keep:
        shutil.rmtree(scratch, ignore_errors=True)
    return outcome


def format_report(report: Report, jobs: int) -> str:
    """The table (mutant, class, killed by, seconds, why) and the score line."""
    p = report.pristine
    lines = [f"unmutated gate: {p.verdict.upper()} in {p.seconds:.1f} s ({p.detail})"]
    if p.verdict != "pass":
        lines.append("selftest: the gate fails without any fault, so no fault can prove anything; "
                     "fix that first")
        return "\n".join(lines)
    width = max([len(o.mutant.id) for o in report.outcomes] + [6])
    lines.append(f"{'mutant':{width}s}  {'class':12s}  {'killed by':10s}  {'s':>5s}  why")
    for o in report.outcomes:
        by = o.run.verdict if o.run.killed else ("ERROR" if o.run.verdict == "error" else "SURVIVED")
        lines.append(f"{o.mutant.id:{width}s}  {o.mutant.fault_class:12s}  {by:10s}  {o.run.seconds:5.1f}  "
                     f"{o.run.detail[:120]}")
    n = len(report.outcomes)
    timeouts = sum(o.run.verdict == "timeout" for o in report.outcomes)
    extra = f", {timeouts} of them by timeout" if timeouts else ""
    lines.append(f"mutation score: {report.killed}/{n} killed ({report.score:.1f} %){extra}; "
                 f"{report.seconds:.0f} s with {jobs} jobs")
    return "\n".join(lines)
