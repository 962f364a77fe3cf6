"""The public Python API's verbs: :func:`solve` one case on one engine, :func:`validate` a matrix,
:func:`tolerance_study` a case under manufacturing tolerances.

They are the face :mod:`dualmech` re-exports (``api/__init__.py``)::

    import dualmech
    case = dualmech.load_case("thesis/a4-30-s1-3")           # a TOML path or a preset name
    table = dualmech.solve(case, engine="pinocchio")          # a ResultTable
    run = dualmech.validate("thesis/a4-30-s1-3", outdir="runs/x")  # .verdict, .comparison

``solve`` lives here, on the top floor, because three of its four engines (the judges: Pinocchio,
MuJoCo rigid, MuJoCo simulation) are drivers in ``validation/``, and their one registry is
:data:`~dualmech.validation.engines.ENGINES`.  Every verb checks its arguments as the command line does
(type, range) and raises a one-line ``TypeError`` or ``ValueError`` naming the argument.
``validate`` is the body of ``dualmech validate`` without its console: the command calls
:func:`open_run` and :func:`run_and_compare`, then prints, writes JUnit, baseline and report.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING, Any

from dualmech.core.table import ResultTable
from dualmech.models.case import Case
from dualmech.models.catalogue import load_mechanism
from dualmech.models.inputs import show
from dualmech.models.kinds import KIND_HOMES, SIM_OPTIONS, SLIDER_CRANK, kind_of, resolve
from dualmech.models.plausibility import warn_implausible
from dualmech.validation.arguments import MAX_JOBS, as_case, as_spec, engine_names, whole_number
from dualmech.validation.engines import ENGINES, solve_checked

if TYPE_CHECKING:
    import numpy as np

    from dualmech.models.tolerance.spec import Spec
    from dualmech.validation.compare import Comparison, Verdict
    from dualmech.validation.matrix import Matrix
    from dualmech.validation.progress import ProgressCallback, ProgressTasks
    from dualmech.validation.report.render import ReportFiles
    from dualmech.validation.run.runner import RunOutcome


def solve(case: Case | str | os.PathLike | dict, *, engine: str = "dualmech") -> ResultTable:
    """Solve ``case`` over its crank positions with one engine.

    Parameters
    ----------
    case : Case, str, os.PathLike or dict
        A :class:`~dualmech.models.case.Case` (lengths in the case's units, angles in degrees), a case
        TOML file, a preset name (:func:`~dualmech.models.case.preset_names`) or a case table; the RSSR,
        the RCCC and loop tables (``"rssr"``, ``"rccc"``, ``"rscr"``, or a case whose ``[mechanism] kind``
        names one) give their :class:`~dualmech.models.tables.LinkageTable`.
    engine : str
        ``"dualmech"`` (in-house), ``"pinocchio"``, ``"mujoco"`` (rigid), ``"mujoco-sim"`` (a driven
        simulation) or ``"exudyn"`` (hard constraints); each judge imports its library at first use.

    Returns
    -------
    ResultTable
        One row per crank position, ``n`` rows; every column of ``docs/conventions.md``
        ("Output columns"), each ``(n,)``; ``.to_numpy()``, ``.to_pandas()``, ``.to_polars()``.

    Raises
    ------
    TypeError, ValueError
        One line: ``case`` is not a case (or its file or table is invalid: the key, the value and what
        would be valid), ``engine`` is not one of :data:`~dualmech.validation.engines.ENGINES`.

    Warns
    -----
    ImplausibleUnitsWarning
        A link, body mass or inertia of ``case`` is implausible for its ``units`` (lengths in mm under
        ``m-kg-s``, say): :mod:`dualmech.models.plausibility`.
    """
    if not isinstance(engine, str):
        raise TypeError(f"engine: expected an engine name (valid: {', '.join(ENGINES)}), got {show(engine)}")
    checked = load_mechanism(case)
    warn_implausible(checked)
    return solve_checked(engine, checked)


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

    def write_report(self, report_dir: str | Path | None = None, jobs: int = 1, *,
                     progress: ProgressCallback | None = None,
                     findings: Callable[[], list[dict]] | None = None) -> ReportFiles:
        """Write the HTML/Markdown report of this run (default: into :attr:`outdir`), as ``dualmech report``.

        ``jobs`` processes draw the figures while this one compares; ``progress`` shows them; ``findings``
        the thesis's in-house sections if already being solved
        (:func:`~dualmech.validation.report.derived.findings_ahead`).  Returns the files written (paths,
        verdict, seconds).
        """
        from dualmech.validation.report.render import write_report

        return write_report(self.outdir, report_dir, jobs=jobs, comparison=lambda: self.comparison,
                            results=self.results, progress=progress, findings=findings)

    def baseline(self) -> dict:
        """This run's baseline summary (``--write-baseline``, ``--baseline``:
        :func:`~dualmech.validation.compare.baseline.baseline_summary`)."""
        from dualmech.validation.compare.baseline import baseline_summary

        return baseline_summary(self.matrix, self.comparison, self.results)

    def write_junit(self, path: str | Path, regressions: Sequence[Any] = ()) -> None:
        """The JUnit XML of this run (one test per case and engine, each with its time), ``regressions``
        failing the tests they concern."""
        from dualmech.validation.compare.junit import write_junit
        from dualmech.validation.run.runner import load_entries, run_versions, timings

        write_junit(path, self.matrix, self.comparison, timings(load_entries(self.outdir, self.matrix)),
                    regressions=list(regressions), versions=run_versions(self.outdir))

    def console_summary(self, how: str, markdown: str) -> list[Any]:
        """What ``dualmech validate`` prints (rich renderables, :mod:`dualmech.validation.report.console`):
        the table titled with the run's size, time and ``how`` it ran, a design's own lines, the verdict
        (the failures beyond those shown: see ``markdown``)."""
        from dualmech.validation.report.console import design_lines, summary_table, verdict_lines

        m, o = self.matrix, self.outcome
        title = (f"{m.name}: {len(m.cases)} cases, engines {', '.join(m.engines)} — "
                 f"solved in {o.seconds:.1f} s ({how}; {o.ran} run, {o.skipped} resumed)")
        return [summary_table(m, self.comparison, title), *design_lines(m, self.results),
                *verdict_lines(m, self.comparison, markdown)]


def open_run(source: str | Path | Case | None, outdir: str | Path | None,
             engines: Sequence[str] = ()) -> tuple[Matrix, Path]:
    """The matrix of ``source`` (on ``engines`` if given) and its checked output folder.

    ``source``: a matrix file or bundled name (``None``: the thesis's study), a case file or a bundled case
    of any kind (a one-design matrix), as :func:`~dualmech.validation.matrix.sources.load_matrix` reads it
    (``docs/matrix-format.md``).  ``outdir`` defaults to ``runs/<matrix name>``.  Raises a one-line
    ``ValueError`` on a bad source, engine or folder.
    """
    from dualmech.validation.matrix import load_matrix
    from dualmech.validation.rundir import check_output_folder

    if source is not None and not isinstance(source, (str, os.PathLike, Case)):
        raise TypeError(f"source: expected a matrix or case file, a bundled name or a dualmech.Case, "
                        f"got {show(source)}")
    if outdir is not None and not isinstance(outdir, (str, os.PathLike)):
        raise TypeError(f"outdir: expected a folder path, got {show(outdir)}")
    matrix = load_matrix(source)
    matrix = matrix.with_engines(tuple(engines)) if engines else matrix
    return matrix, check_output_folder(Path(outdir) if outdir else Path("runs") / matrix.name)


def run_and_compare(matrix: Matrix, outdir: Path, *, jobs: int | None = None, resume: bool = False,
                    scheduler: str | None = None, progress: ProgressCallback | None = None) -> ValidationRun:
    """Run every case of ``matrix`` (of any kinds) on its engines into ``outdir``; the run compares the
    judges with the reference, each case by its kind's gate, at the first use of its
    :attr:`~ValidationRun.comparison`.

    The arguments are those of :func:`~dualmech.validation.run.runner.run_matrix`.
    """
    from dualmech.validation.run.runner import run_matrix

    outcome = run_matrix(matrix, outdir, jobs=jobs, resume=resume, scheduler=scheduler, progress=progress)
    return ValidationRun(matrix, outdir, outcome)


def simulate(case: Any, duration: float, **options: Any) -> Any:
    """Forward dynamics of ``case``: its input's equation of motion integrated under given loads.

    Parameters
    ----------
    case : a case of any kind, str, os.PathLike or dict
        As :func:`solve` takes it: a slider crank
        (:func:`dualmech.models.slider_crank.forward_dynamics.simulate`,
        :class:`~dualmech.models.simulation.Simulation`), an RSSR, RCCC
        (:func:`dualmech.models.loop.preset_dynamics.simulate`) or loop table
        (:func:`dualmech.models.loop.forward_dynamics.simulate`), by its kind
        (:data:`~dualmech.models.kinds.KIND_HOMES`).
    duration : float
        The end time, seconds.
    **options
        :data:`~dualmech.models.kinds.SIM_OPTIONS` (``torque``, ``psi0``, ``psidot0``, ``damping``,
        ``samples``, ...) and the kind's own (the slider crank's ``slider_load``, ``slider_damping``).

    Raises
    ------
    TypeError, ValueError
        One line: ``case`` is not a case, an option the kind does not take (only the slider crank has a
        slider), or an invalid value.
    """
    checked = load_mechanism(case)
    warn_implausible(checked)
    kind = kind_of(checked)
    home = KIND_HOMES[kind]
    valid = (*SIM_OPTIONS, *home.sim_options)
    for name, value in options.items():
        if name not in valid:
            why = "has no slider" if name in KIND_HOMES[SLIDER_CRANK].sim_options else "does not take it"
            raise ValueError(f"{name}: a {kind} case {why} (valid options: {', '.join(valid)})")
    return resolve(home.simulator)(checked, duration, **options)


def validate(source: str | Path | Case | None = None, outdir: str | Path | None = None, *,
             engines: Sequence[str] | str = (), jobs: int | None = None, resume: bool = False,
             scheduler: str | None = None) -> ValidationRun:
    """Run and compare a validation matrix, as ``dualmech validate`` does (without its console output).

    Parameters
    ----------
    source : str, pathlib.Path or Case, optional
        A matrix TOML file or bundled matrix name (default ``thesis-1991``), or one design (then judged
        by every engine): a case TOML file, a preset name or a :class:`~dualmech.models.case.Case`.
    outdir : str or pathlib.Path, optional
        Run directory (new, empty, or an earlier dualmech run); default ``runs/<matrix name>``.
    engines : sequence of str or str, optional
        Run only these engines (the reference among them), as a list or one comma-separated string;
        default the matrix's.
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
        ``.write_report()`` renders it, ``.baseline()``, ``.write_junit()``; a run of any kinds
        (``"linkages"``, ``"rssr"``, a loop table, a matrix mixing kinds) alike.
    """
    if jobs is not None:
        whole_number("jobs", jobs, 1, MAX_JOBS)
    if not isinstance(resume, bool):
        raise TypeError(f"resume: expected True or False, got {show(resume)}")
    matrix, folder = open_run(source, outdir, engine_names(engines))
    return run_and_compare(matrix, folder, jobs=jobs, resume=resume, scheduler=scheduler)


def report_run(rundir: str | Path, outdir: str | Path | None = None, *, jobs: int = 1) -> ReportFiles:
    """Write the report of the run stored in ``rundir`` (into ``outdir``, default the run folder), as
    ``dualmech report`` does, for a run of any kinds (``jobs`` processes draw the figures).  Returns the
    files written (``.html``, ``.markdown``, ``.figures``, ``.verdict``, ``.seconds``)."""
    from dualmech.validation.report.render import write_report

    return write_report(rundir, outdir, jobs=jobs)


@dataclass(frozen=True)
class ToleranceStudy:
    """A finished tolerance study, as :func:`tolerance_study` returns it.

    Attributes
    ----------
    outdir : pathlib.Path
        The study folder: ``summary.json``, ``samples.csv``/``.parquet``, the report.
    summary : dict
        ``summary.json``'s content (``docs/conventions.md``, "Tolerance analysis").
    x : numpy.ndarray or None
        The sampled key values ``(n, k)`` (``None`` for ``method="linear"``).
    samples : dict or None
        Output name -> ``(n,)`` values of the sampled designs, and their ``status``.
    files : list of str
        The report's files, relative to :attr:`outdir`.
    """

    outdir: Path
    summary: dict
    x: np.ndarray | None
    samples: dict[str, np.ndarray] | None
    files: list[str]

    @property
    def passed(self) -> bool:
        """Every judge's spot check agreed, and the exact sensitivities agree with central differences of
        the solver (``dualmech tolerance`` exits 1 otherwise)."""
        check = self.summary["sensitivity_check"]
        return all(s["passed"] for s in self.summary["judges"]) and (check is None or check["passed"])


def tolerance_study(case: Case | str | os.PathLike | dict, spec: Spec | str | os.PathLike | dict, *,
                    n: int = 1000, seed: int = 0, method: str = "both",
                    outdir: str | os.PathLike = "runs/tolerance", jobs: int = 1, scheduler: str | None = None,
                    judge_samples: int = 5, progress: ProgressTasks | None = None) -> ToleranceStudy:
    """Tolerance study of ``case``: Monte Carlo of ``spec`` and exact sensitivities, judged and reported, as
    ``dualmech tolerance`` does (without its console).

    Parameters
    ----------
    case : Case, str, os.PathLike or dict
        The nominal design of any kind: a case file, bundled name or table, or a slider-crank Case.
    spec : Spec, str, os.PathLike or dict
        The tolerance SPEC: a distribution per varied case key (``docs/conventions.md``, "Tolerance
        analysis"), as a file or its table.
    n, seed : int
        Monte Carlo designs (>= 1) and the seed of their samples (>= 0; the same seed gives the same samples).
    method : str
        ``"mc"``, ``"linear"`` (exact sensitivities only) or ``"both"``.
    outdir : str or os.PathLike
        The study folder (new, empty, or an earlier study of the same inputs, which resumes).
    jobs, scheduler : processes solving chunks of designs (>= 1), or a Dask scheduler address.
    judge_samples : int
        Sampled designs re-solved by Pinocchio and MuJoCo rigid (>= 0).
    progress : callable, optional
        Shows the Monte Carlo chunks and the spot checks as they are done
        (:data:`~dualmech.validation.run.runner.ProgressTasks`; the command line's display).

    Returns
    -------
    ToleranceStudy
        ``.summary``, ``.samples``, ``.files``, ``.passed``.
    """
    from dualmech.models.tolerance.plan import record_of
    from dualmech.models.tolerance.study import StudyInput
    from dualmech.validation.rundir import locked
    from dualmech.validation.tolerance.report import FigureDrawing, write_tolerance_report
    from dualmech.validation.tolerance.study import run_study

    nominal = as_case(case)
    warn_implausible(record_of(nominal))
    spec = as_spec(spec)
    if not isinstance(outdir, (str, os.PathLike)):
        raise TypeError(f"outdir: expected a folder path, got {show(outdir)}")
    # n's range (1 to MAX_DESIGNS) is the study's own check
    study = StudyInput(nominal, spec, whole_number("n", n, 0), whole_number("seed", seed, 0))
    jobs = whole_number("jobs", jobs, 1, MAX_JOBS)
    judge_samples = whole_number("judge_samples", judge_samples, 0)
    # the figures are drawn by a worker process while this one runs the judges' spot checks; started
    # first, it imports its libraries while this process solves
    drawing = FigureDrawing(parallel=judge_samples > 0)
    drawing.warm()
    try:
        with locked(outdir):  # one lock for the study and its report: a second study is refused
            summary, x, samples = run_study(study, method, Path(outdir), jobs, scheduler, judge_samples,
                                            drawing, tasks=progress)
            files = write_tolerance_report(Path(outdir), summary, x, samples, drawing)
    finally:
        drawing.close()
    return ToleranceStudy(Path(outdir), summary, x, samples, files)
