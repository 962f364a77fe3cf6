"""The public Python API's two verbs: :func:`solve` one case on one engine, :func:`validate` a matrix.

Both are re-exported by :mod:`dualmech.validation`; :func:`solve` also by :mod:`dualmech.models`
(lazily, at first access), beside :func:`~dualmech.models.case.load_case`::

    case = dualmech.models.load_case("thesis/a4-30-s1-3")          # a TOML path or a preset name
    table = dualmech.models.solve(case, engine="pinocchio")         # a ResultTable
    run = dualmech.validation.validate("thesis/a4-30-s1-3", outdir="runs/x")  # .verdict, .comparison

``solve`` lives here, on the top floor, because three of its four engines (the judges: Pinocchio,
MuJoCo rigid, MuJoCo simulation) are drivers in ``validation/``, and their one registry is
:data:`~dualmech.validation.engines.ENGINES`; ``core/`` and ``models/`` may not import upwards
(``tests/test_layout.py``), so ``dualmech.models.solve`` is a lazy alias of this function, not a second
lookup.  ``validate`` is the body of ``dualmech validate`` without its console: the command calls
:func:`open_run` and :func:`run_and_compare`, then prints, writes JUnit, baseline and report.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING

from dualmech.core.table import ResultTable
from dualmech.models.case import Case
from dualmech.models.plausibility import warn_implausible
from dualmech.validation.engines import run_engine

if TYPE_CHECKING:
    from dualmech.validation.compare import Comparison, Verdict
    from dualmech.validation.linkages.report import LinkageReport
    from dualmech.validation.linkages.run import LinkageRun
    from dualmech.validation.matrix import Matrix
    from dualmech.validation.report.render import ReportFiles
    from dualmech.validation.runner import ProgressCallback, RunOutcome


def solve(case: Case, engine: str = "dualmech") -> ResultTable:
    """Solve ``case`` over its crank positions with one engine.

    Parameters
    ----------
    case : Case
        From :func:`dualmech.models.load_case` (lengths in the case's units, angles in degrees).
    engine : str
        ``"dualmech"`` (the in-house dual-number solver), ``"pinocchio"``, ``"mujoco"`` (rigid) or
        ``"mujoco-sim"`` (a driven simulation); the judges import their library on first use.

    Returns
    -------
    ResultTable
        One row per crank position, ``n`` rows; every column of ``docs/conventions.md``
        ("Output columns"), each ``(n,)``; ``.to_numpy()``, ``.to_pandas()``, ``.to_polars()``.

    Raises
    ------
    ValueError
        ``engine`` is not one of :data:`~dualmech.validation.engines.ENGINES` (one line).

    Warns
    -----
    ImplausibleUnitsWarning
        A link, body mass or inertia of ``case`` is implausible for its ``units`` (lengths in mm under
        ``m-kg-s``, say): :mod:`dualmech.models.plausibility`.
    """
    warn_implausible(case)
    return run_engine(engine, case)


@dataclass(frozen=True)
class ValidationRun:
    """One compared run of a matrix, as :func:`validate` returns it.

    Attributes
    ----------
    matrix : Matrix
        The expanded matrix that ran (cases, engines, reference, tolerances).
    outdir : pathlib.Path
        The run directory: one result file per case, ``run.json``.
    outcome : RunOutcome
        ``results`` (case id -> engine -> :class:`ResultTable` or error text), tasks run and resumed, seconds.
    comparison : Comparison
        Every check against the reference (a property, made at its first use).
    """

    matrix: Matrix
    outdir: Path
    outcome: RunOutcome

    @cached_property
    def comparison(self) -> Comparison:
        """Every check (case x judge x quantity) against the reference, with strokes and dead-centre counts;
        made at its first use (``dualmech validate`` starts drawing the report's figures first)."""
        from dualmech.validation.compare import compare_run

        return compare_run(self.matrix, self.outcome.results)

    @property
    def verdict(self) -> Verdict:
        """``PASS``, ``FAIL`` or ``INCOMPLETE`` (``dualmech validate`` exits 0, 1, 3)."""
        return self.comparison.verdict

    @property
    def results(self) -> dict[str, dict[str, ResultTable | str]]:
        """Case id -> engine -> table (or the error text of an engine that raised)."""
        return self.outcome.results

    def write_report(self, report_dir: str | Path | None = None, jobs: int = 1) -> ReportFiles:
        """Write the HTML/Markdown report of this run (default: into :attr:`outdir`), as ``dualmech report``.

        ``jobs`` processes draw the figures; returns the files written (paths, verdict, seconds).
        """
        from dualmech.validation.report import write_report

        return write_report(self.outdir, report_dir, jobs=jobs, comparison=lambda: self.comparison,
                            results=self.results)


def open_run(source: str | Path | None, outdir: str | Path | None,
             engines: Sequence[str] = ()) -> tuple[Matrix, Path]:
    """The matrix of ``source`` (on ``engines`` if given) and its checked output folder.

    ``source``: a matrix file or bundled name (``None``: the thesis's study), a case file or a
    case preset (a one-design matrix).  ``outdir`` defaults to ``runs/<matrix name>``.
    Raises a one-line ``ValueError`` on a bad source, engine or folder.
    """
    from dualmech.validation.matrix import load_matrix
    from dualmech.validation.rundir import check_output_folder

    matrix = load_matrix(source)
    if engines:
        matrix = matrix.with_engines(tuple(engines))
    return matrix, check_output_folder(Path(outdir) if outdir else Path("runs") / matrix.name)


def run_and_compare(matrix: Matrix, outdir: Path, *, jobs: int | None = None, resume: bool = False,
                    scheduler: str | None = None, progress: ProgressCallback | None = None) -> ValidationRun:
    """Run every case of ``matrix`` on its engines into ``outdir``; the run compares the judges with the
    reference at the first use of its :attr:`~ValidationRun.comparison`.

    The arguments are those of :func:`~dualmech.validation.runner.run_matrix`.
    """
    from dualmech.validation.runner import run_matrix

    outcome = run_matrix(matrix, outdir, jobs=jobs, resume=resume, scheduler=scheduler, progress=progress)
    return ValidationRun(matrix, outdir, outcome)


def validate(source: str | Path | None = None, outdir: str | Path | None = None, *,
             engines: Sequence[str] = (), jobs: int | None = None, resume: bool = False,
             scheduler: str | None = None) -> ValidationRun:
    """Run and compare a validation matrix, as ``dualmech validate`` does (without its console output).

    Parameters
    ----------
    source : str or pathlib.Path, optional
        A matrix TOML file or bundled matrix name (default ``thesis-1991``), or a case TOML file or
        preset name (then one design, judged by every engine).
    outdir : str or pathlib.Path, optional
        Run directory (new, empty, or an earlier dualmech run); default ``runs/<matrix name>``.
    engines : sequence of str, optional
        Run only these engines (the reference among them); default the matrix's.
    jobs : int, optional
        Worker processes (default all cores; 1 runs in this process).
    resume : bool
        Keep the finished cases stored in ``outdir``.
    scheduler : str, optional
        A Dask distributed scheduler address (``tcp://host:port``), instead of ``jobs``.

    Returns
    -------
    ValidationRun
        ``.verdict`` (``PASS``/``FAIL``/``INCOMPLETE``), ``.comparison``, ``.results``;
        ``.write_report()`` renders it.
    """
    matrix, folder = open_run(source, outdir, engines)
    return run_and_compare(matrix, folder, jobs=jobs, resume=resume, scheduler=scheduler)


def run_linkage_validation(source: str | Path = "linkages", outdir: str | Path | None = None,
                           engines: Sequence[str] = ()) -> tuple[LinkageRun, LinkageReport, float]:
    """``dualmech validate`` of the other linkages: solve, compare, write the report; the run, its files and
    the seconds spent solving and comparing (the command line prints them)."""
    import time

    from dualmech.validation.linkages.matrix import load_linkage_matrix
    from dualmech.validation.linkages.report import write_linkage_report
    from dualmech.validation.linkages.run import run_linkages
    from dualmech.validation.rundir import check_output_folder

    matrix = load_linkage_matrix(source)
    matrix = matrix.with_engines(tuple(engines)) if engines else matrix
    folder = check_output_folder(Path(outdir) if outdir else Path("runs") / matrix.name)
    start = time.perf_counter()
    run = run_linkages(matrix)
    seconds = time.perf_counter() - start
    return run, write_linkage_report(run, folder, seconds), seconds


def validate_linkages(source: str | Path = "linkages", outdir: str | Path | None = None, *,
                      engines: Sequence[str] = ()) -> LinkageRun:
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

    Returns
    -------
    LinkageRun
        ``.verdict`` (``PASS``/``FAIL``/``INCOMPLETE``), ``.comparison``, ``.tables`` (case -> engine ->
        its :class:`~dualmech.models.linkages.table.LinkageTable`), ``.worst()`` per judge.
    """
    return run_linkage_validation(source, outdir, engines)[0]
