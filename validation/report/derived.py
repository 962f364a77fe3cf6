"""The report's numbers beyond the stored tables and the comparison, computed here: the report formats.

* :func:`balancing`: shaking force and moment before and after force balancing (Sinatra–Angeles) for
  the matrix's base case and the last case of each sweep, solved in-house;
* :func:`findings`: the thesis's printed findings with verdicts, from the model package.

:func:`dualmech.validation.report.render.write_report` calls each once per report, as a section whose
failure fails the report.  The per-row relative differences its difference figures draw are the
gate's own, kept by :func:`dualmech.validation.compare.compare_run`
(:attr:`~dualmech.validation.compare.Comparison.row_differences`).
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from importlib import import_module
from typing import Any, Callable

import numpy as np

from dualmech.validation.matrix import Matrix

#: The model package's function that lists the thesis's printed findings with verdicts.
FINDINGS_FUNCTION = "dualmech.models.slider_crank.findings:thesis_findings"


@dataclass(frozen=True)
class Balancing:
    """The balancing section's numbers.

    ``rows``: per picked case, ``case`` (matrix id), the peak shaking force and moment over the cycle
    (``force_before``, ``force_after``, ``moment_before``, ``moment_after``; NaN for a case that
    assembles nowhere) and ``ratio`` = force_after / force_before (``None`` at rest).  ``drawn``:
    the matrix id of the first picked case that assembles (``None`` if none does), with its case
    ``name`` and ``units`` and its shaking ``forces`` ``(m, 3)`` at the assembled positions,
    original then balanced.
    """

    rows: list[dict]
    drawn: str | None = None
    name: str = ""
    units: str = ""
    forces: tuple[np.ndarray, np.ndarray] | None = None


def balancing(matrix: Matrix) -> Balancing:
    """Shaking force before and after force balancing for the base case and each sweep's last case (of the
    slider-crank cases: ``matrix`` has one at least)."""
    from dualmech.models.slider_crank.balancing import assembled_force, balanced_case, shaking

    sliders = [c for c in matrix.cases if c.is_slider_crank]
    base = next((c for c in sliders if c.is_base), sliders[0])
    picks = [base] + [
        next(c for c in matrix.cases if c.id == s.case_ids[base.mode][-1])
        for s in matrix.sweeps
        if s.case_ids.get(base.mode)
    ]
    picks = list({mc.id: mc for mc in picks}.values())  # the base case may also end a sweep
    rows, solved = [], []
    for mc in picks:
        case = mc.case()
        before, after = shaking(case), shaking(balanced_case(case))
        peak = {
            name: _peak_norm(getattr(s, attr))
            for name, s, attr in (
                ("force_before", before, "force"),
                ("force_after", after, "force"),
                ("moment_before", before, "moment"),
                ("moment_after", after, "moment"),
            )
        }
        ratio = peak["force_after"] / peak["force_before"] if peak["force_before"] > 0 else None  # at rest
        rows.append({"case": mc.id, **peak, "ratio": ratio})
        solved.append((mc.id, case, before, after))
    drawn = next((s for s, row in zip(solved, rows) if np.isfinite(row["force_before"])), None)
    if drawn is None:
        return Balancing(rows)
    case_id, case, before, after = drawn
    return Balancing(rows, case_id, case.name, case.units, (assembled_force(before), assembled_force(after)))


def _peak_norm(vectors: np.ndarray) -> float:
    """Largest Euclidean norm over the rows of ``vectors`` (shape ``(n, 3)``) that are finite; NaN if none."""
    norms = np.linalg.norm(vectors, axis=1)
    norms = norms[np.isfinite(norms)]
    return float(norms.max()) if norms.size else float("nan")


def findings_ahead(matrix: Matrix) -> Callable[[], list[dict]] | None:
    """Start solving the thesis's findings (:func:`findings`) in a background thread now, for a thesis
    matrix; return the function that waits for them (it raises what they raised), else ``None``.

    The findings need no judge's result: solved while the run's workers solve (this process mostly waits
    on them then), they leave the report, which comes after, ~1 s shorter.  A daemon thread: an
    interrupted run does not wait for it.
    """
    if not matrix.of_thesis:
        return None
    done: dict[str, Any] = {}

    def solve() -> None:
        try:
            done["rows"] = findings()
        except BaseException as err:  # handed to the caller of the result
            done["error"] = err

    worker = threading.Thread(target=solve, name="dualmech-findings", daemon=True)
    worker.start()

    def result() -> list[dict]:
        worker.join()
        if "error" in done:
            raise done["error"]
        return done["rows"]

    return result


def findings() -> list[dict]:
    """The thesis's printed findings with verdicts, from the model package (a failure fails the report)."""
    module, func = FINDINGS_FUNCTION.split(":")
    rows = getattr(import_module(module), func)()
    return [
        {
            "finding": str(r.get("finding", "")),
            "verdict": str(r.get("verdict", "")),
            "evidence": str(r.get("evidence", "")),
        }
        for r in rows
    ]
