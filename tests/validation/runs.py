"""Running a matrix in a test: :func:`run_cases` runs and compares it in a folder of its own, removed
after."""

from __future__ import annotations

from pathlib import Path
from tempfile import TemporaryDirectory

from dualmech.validation.compare import Check
from dualmech.validation.matrix import Matrix
from dualmech.validation.report.figures import FigureSpec
from dualmech.validation.report.tables import figure_specs, table_specs, worst_checks
from dualmech.verbs import ValidationRun, run_and_compare


def run_cases(matrix: Matrix, jobs: int = 1) -> ValidationRun:
    """``matrix`` run on its engines and compared (the comparison made before its folder is removed)."""
    with TemporaryDirectory(prefix="dualmech-test-run-") as folder:
        run = run_and_compare(matrix, Path(folder) / "run", jobs=jobs)
        run.comparison  # noqa: B018 -- made now, while the run's folder exists
    return run


def worst(run: ValidationRun) -> dict[str, Check]:
    """Per judge, its check of the largest ratio to tolerance over the run (a failing one first)."""
    return worst_checks(run.matrix, run.comparison)


def table_figures(run: ValidationRun) -> list[FigureSpec]:
    """The figures of ``run``'s cases of kinds other than the slider crank
    (:func:`~dualmech.validation.report.tables.figure_specs`)."""
    return figure_specs(run.matrix, run.results, run.comparison, table_specs(run.matrix))
