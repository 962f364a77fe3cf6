"""``validate`` of a linkage case or matrix (RSSR, RCCC, loop tables), end to end: the matrix, the run on the
matrix runner (:mod:`.run`), the comparison and the report (:mod:`.report`) in the run folder; and ``report``
of a stored linkage run.  The command line (``dualmech validate``, ``dualmech report``) and the package
face's :func:`dualmech.verbs.validate` call these."""

from __future__ import annotations

import time
from collections.abc import Sequence
from pathlib import Path

from dualmech.validation.linkages.matrix import load_linkage_matrix
from dualmech.validation.linkages.report import LinkageReport, write_linkage_report
from dualmech.validation.linkages.run import LinkageRun, run_linkages, stored_linkage_matrix
from dualmech.validation.progress import ProgressCallback
from dualmech.validation.run.runner import load_run
from dualmech.validation.rundir import check_output_folder


def run_linkage_validation(source: str | Path = "linkages", outdir: str | Path | None = None,
                           engines: Sequence[str] = (), *, jobs: int = 1, resume: bool = False,
                           scheduler: str | None = None, report_dir: str | Path | None = None,
                           progress: ProgressCallback | None = None
                           ) -> tuple[LinkageRun, LinkageReport, float]:
    """``dualmech validate`` of the other linkages: solve (each result stored in the run folder as it
    finishes; ``jobs``, ``resume``, ``scheduler`` and ``progress`` as
    :func:`~dualmech.validation.run.runner.run_matrix`'s), compare, write the report (into ``report_dir``,
    default the run folder); the run, its files and the seconds spent solving and comparing (the command
    line prints them)."""

    matrix = load_linkage_matrix(source)
    matrix = matrix.with_engines(tuple(engines)) if engines else matrix
    folder = check_output_folder(Path(outdir) if outdir else Path("runs") / matrix.name)
    report = check_output_folder(Path(report_dir)) if report_dir else folder
    start = time.perf_counter()
    run = run_linkages(matrix, folder, jobs=jobs, resume=resume, scheduler=scheduler, progress=progress)
    seconds = time.perf_counter() - start
    return run, write_linkage_report(run, report, seconds), seconds


def report_linkage_run(rundir: str | Path, outdir: str | Path | None = None
                       ) -> tuple[LinkageRun, LinkageReport, float] | None:
    """``dualmech report`` of a stored linkage run: its results compared again and its report written (to
    ``outdir``, default the run folder); ``None`` for a run of slider-crank cases (for the slider crank's
    report).  A result missing from the folder is run now (as ``--resume`` would)."""

    matrix = stored_linkage_matrix(load_run(Path(rundir))[0])
    if matrix is None:
        return None
    start = time.perf_counter()
    run = run_linkages(matrix, rundir, resume=True)
    seconds = time.perf_counter() - start
    return run, write_linkage_report(run, Path(outdir or rundir), seconds), seconds


def validate_linkages(source: str | Path = "linkages", outdir: str | Path | None = None, *,
                      engines: Sequence[str] = (), jobs: int = 1, resume: bool = False,
                      scheduler: str | None = None) -> LinkageRun:
    """Validate the RSSR and RCCC linkages as ``dualmech validate linkages`` does (without its console).

    Parameters
    ----------
    source : str or pathlib.Path
        ``"linkages"`` (the bundled linkage matrix), ``"rssr"``, ``"rccc"``, a linkage case file or a
        linkage matrix file (``docs/matrix-format.md``, "Linkage matrices").
    outdir : str or pathlib.Path, optional
        Run directory for ``summary.json`` and the report (new, empty, or an earlier dualmech run);
        default ``runs/<matrix name>``.
    engines : sequence of str, optional
        Run only these engines (the reference, ``dualmech``, among them).
    jobs, resume, scheduler
        As :func:`~dualmech.validation.run.runner.run_matrix`'s.

    Returns
    -------
    LinkageRun
        ``.verdict`` (``PASS``/``FAIL``/``INCOMPLETE``), ``.comparison``, ``.tables`` (case -> engine ->
        its :class:`~dualmech.models.linkages.table.LinkageTable`), ``.worst()`` per judge.
    """
    return run_linkage_validation(source, outdir, engines, jobs=jobs, resume=resume, scheduler=scheduler)[0]
