"""``validate`` of a linkage matrix (RSSR, RCCC, loop tables): the run on the matrix runner (:mod:`.run`),
compared by the linkage gate, as a :class:`LinkageValidation` with the face of the slider crank's run (its
report: :mod:`.report`); and ``report`` of a stored linkage run.  The package face's
:func:`dualmech.verbs.run_and_compare` and :func:`dualmech.verbs.report_run` call these, for
``dualmech validate`` and ``dualmech report`` as for :func:`dualmech.validate`."""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from dualmech.validation.compare import Comparison, Verdict
from dualmech.validation.compare.junit import write_junit
from dualmech.validation.linkages.matrix import LinkageMatrix
from dualmech.validation.linkages.report import console_table, verdict_lines, write_linkage_report
from dualmech.validation.linkages.run import LinkageRun, as_run_matrix, run_linkages, stored_linkage_matrix
from dualmech.validation.progress import ProgressCallback
from dualmech.validation.report.render import ReportFiles
from dualmech.validation.run.runner import load_run, run_versions


@dataclass(frozen=True)
class LinkageValidation:
    """A compared linkage run in its folder, with the face of the slider crank's
    :class:`~dualmech.verbs.ValidationRun` (``dualmech validate`` and :func:`dualmech.validate` use either
    alike): ``verdict``, ``comparison``, ``results`` and the run's report, baseline, JUnit and console
    summary.  ``seconds``: solving and comparing."""

    matrix: LinkageMatrix
    outdir: Path
    run: LinkageRun
    seconds: float

    @property
    def verdict(self) -> Verdict:
        """``PASS``, ``FAIL`` or ``INCOMPLETE``."""
        return self.run.verdict

    @property
    def comparison(self) -> Comparison:
        """Every check of every judge against the reference."""
        return self.run.comparison

    @property
    def results(self) -> dict:
        """Case id -> engine -> its table, or the error text of an engine that raised."""
        return self.run.tables

    tables = results

    def write_report(self, report_dir: str | Path | None = None, jobs: int = 1, *,
                     progress: ProgressCallback | None = None, findings: Any = None) -> ReportFiles:
        """Write the report into ``report_dir`` (default the run folder): the slider crank's
        (:mod:`.report`), its figures drawn in ``jobs`` processes, ``progress(done, total, key)`` after each;
        ``findings`` (the thesis's) has no meaning here."""
        return write_linkage_report(self.run, self.outdir, Path(report_dir or self.outdir), jobs=jobs,
                                    progress=progress)

    def baseline(self) -> dict:
        """This run's baseline summary (:meth:`~dualmech.validation.linkages.run.LinkageRun.baseline`)."""
        return self.run.baseline()

    def write_junit(self, path: str | Path, regressions: Sequence[Any] = ()) -> None:
        """The JUnit XML of this run: one test per case and engine that solves it."""
        write_junit(path, as_run_matrix(self.matrix), self.comparison, self.run.seconds,
                    regressions=list(regressions), versions=run_versions(self.outdir))

    def console_summary(self, how: str, markdown: str) -> list[Any]:
        """What ``dualmech validate`` prints: the table (one row per case) and the verdict."""
        m = self.matrix
        title = (f"{m.name}: {len(m.cases)} linkage cases, engines {', '.join(m.engines)} — "
                 f"solved and compared in {self.seconds:.1f} s ({how})")
        return [console_table(self.run, title), *verdict_lines(self.run, markdown)]


def validate_linkage_matrix(matrix: LinkageMatrix, outdir: Path, *, jobs: int = 1, resume: bool = False,
                            scheduler: str | None = None,
                            progress: ProgressCallback | None = None) -> LinkageValidation:
    """Run and compare ``matrix`` into ``outdir`` (each result stored as it finishes; ``jobs``, ``resume``,
    ``scheduler`` and ``progress`` as :func:`~dualmech.validation.run.runner.run_matrix`'s)."""
    start = time.perf_counter()
    run = run_linkages(matrix, outdir, jobs=jobs, resume=resume, scheduler=scheduler, progress=progress)
    return LinkageValidation(matrix, Path(outdir), run, time.perf_counter() - start)


def report_linkage_run(rundir: str | Path, outdir: str | Path | None = None) -> ReportFiles | None:
    """``dualmech report`` of a stored linkage run: its results compared again and its report written (to
    ``outdir``, default the run folder); ``None`` for a run of slider-crank cases (for the slider crank's
    report).  A result missing from the folder is run now (as ``--resume`` would)."""

    matrix = stored_linkage_matrix(load_run(Path(rundir))[0])
    if matrix is None:
        return None
    return validate_linkage_matrix(matrix, Path(rundir), resume=True).write_report(outdir)
