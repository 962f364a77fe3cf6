"""Which figures a report draws, and drawing them in processes.

:func:`figure_specs` plans every figure of a run (what to draw and from which tables);
:func:`start_figures` starts making them in the run's worker processes, those that need the results only
first, and :meth:`PendingFigures.add_judged` those that need the comparison (:func:`render_figures`: all, and
waits for them).  Every figure is made interactive (:mod:`~dualmech.validation.report.interactive`, for the
HTML page); those the Markdown report shows (:attr:`FigureSpec.static`: :data:`STATIC_SWEEP_FIGURES`, the heat
maps, the balancing plot) are also drawn as PNG (:mod:`~dualmech.validation.report.plots`).  Rasterising is
most of a report's cost, so the others are not drawn at all.  A case without sweeps (of a kind with a table
spec, planned by :mod:`dualmech.validation.report.tables`) has its engine-overlay figure (kind ``"case"``,
:mod:`~dualmech.validation.report.overlay`), drawn the same way.
"""

from __future__ import annotations

import concurrent.futures as cf
import re
from typing import Any, NamedTuple

from dualmech.core.table import REACTION_COLUMNS, ResultTable
from dualmech.validation.compare import STROKE, Comparison
from dualmech.validation.matrix import Matrix
from dualmech.validation.progress import ProgressCallback
from dualmech.validation.report import interactive
from dualmech.validation.report.canvas import drawing
from dualmech.validation.report.overlay import overlay_figure, overlay_plot
from dualmech.validation.report.plots import (
    HEATMAP_CAPTION,
    Figure,
    heatmap_arrays,
    heatmap_figure,
    shaking_force_figure,
    sweep_figure,
)
from dualmech.validation.run.executors import shared_pool, worker_died

#: Figures of each sweep and load mode: (key, title, columns, panel grid (rows, cols)).
SWEEP_FIGURES: tuple[tuple[str, str, tuple[str, ...], tuple[int, int]], ...] = (
    ("S4", "slider displacement S4", ("S4",), (1, 1)),
    (
        "joint1",
        "joint 1 (ground on crank): force and moment about O",
        ("j1_fx", "j1_fy", "j1_fz", "j1_mx", "j1_my", "j1_mz"),
        (2, 3),
    ),
    ("joint2", "joint 2 (crank on rod): force", ("j2_fx", "j2_fy", "j2_fz"), (1, 3)),
    ("joint3", "joint 3 (rod on slider): force", ("j3_fx", "j3_fy", "j3_fz"), (1, 3)),
    (
        "joint4",
        "joint 4 (ground on slider): force and moment about P3",
        ("j4_fx", "j4_fy", "j4_fz", "j4_mx", "j4_my", "j4_mz"),
        (2, 3),
    ),
    ("loads", "slider load and drive torque", ("slider_load", "drive_torque"), (1, 2)),
)


#: The sweep figures also drawn as PNG for the Markdown report, as (key of SWEEP_FIGURES, load mode): the
#: slider load and drive torque of each sweep in drive-torque mode, the thesis's headline result (the torque
#: a drive must give); every sweep figure is in the HTML report, interactive.
STATIC_SWEEP_FIGURES = frozenset({("loads", "torque")})


class FigureSpec(NamedTuple):
    """One planned figure."""

    key: str  # file stem under figures/ (and the HTML element's id)
    section: str  # "sweep", "difference", "heatmap", "balancing" or "case"
    group: str  # the sweep's name, or the judge's
    title: str
    caption: str
    job: tuple[str, tuple]  # (kind: a key of _FIGURE_FUNCTIONS, its arguments)
    static: bool = False  # also drawn as PNG (for the Markdown report)


def figure_specs(matrix: Matrix, results: dict, comparison: Comparison) -> list[FigureSpec]:
    """Every figure of the report: the sweeps', then each judge's difference plot, then its heat map."""
    return [
        *_sweep_specs(matrix, results),
        *_difference_specs(matrix, comparison),
        *_heatmap_specs(matrix, comparison),
    ]


def _sweep_specs(matrix: Matrix, results: dict) -> list[FigureSpec]:
    """The :data:`SWEEP_FIGURES` of every sweep and load mode that has any result."""
    specs = []
    units = next((mc.raw.get("units", "consistent") for mc in matrix.cases if mc.is_slider_crank),
                 "consistent")
    for sw in matrix.sweeps:
        for mode, ids in sw.case_ids.items():
            cases = []
            for cid in ids:
                per = {e: t for e, t in results.get(cid, {}).items() if isinstance(t, ResultTable)}
                label = matrix.case_by_id(cid).labels.get(sw.name, cid)
                cases.append((label, per))
            if not any(cases_per for _, cases_per in cases):
                continue
            for key, what, cols, grid in SWEEP_FIGURES:
                title = f"{what}: {sw.name} sweep, {mode} mode"
                caption = (
                    f"{sw.label}; {mode} mode. Lines: {matrix.reference}; markers: "
                    f"{', '.join(matrix.judges)}. Dotted verticals: dead centres; "
                    "triangles: values beyond the axis."
                )
                job = ("sweep", (title, cols, grid, cases, matrix.reference, matrix.judges, mode == "torque",
                                 units))
                specs.append(FigureSpec(_file_key(f"{sw.name}-{mode}-{key}"), "sweep", sw.name, title,
                                        caption, job, (key, mode) in STATIC_SWEEP_FIGURES))
    return specs


def _difference_specs(matrix: Matrix, comparison: Comparison) -> list[FigureSpec]:
    """Per judge: the worst relative difference over kinematics and over reactions, row by row (the gate's
    own, :attr:`~dualmech.validation.compare.Comparison.row_differences`)."""
    specs: list[FigureSpec] = []
    kin_q = tuple(q for q in matrix.quantities if q not in REACTION_COLUMNS)
    rea_q = tuple(q for q in matrix.quantities if q in REACTION_COLUMNS)
    for e in matrix.judges:
        rows: dict[str, list] = {m: [] for m in matrix.modes}
        for mc in matrix.cases:
            differences = comparison.row_differences.get(mc.id, {}).get(e)
            if differences is not None and mc.is_slider_crank:  # another kind's: its own figure
                rows[mc.mode].append((mc.id, *differences))
        rows = {m: r for m, r in rows.items() if r}
        if rows:
            tols = matrix.tolerances[e]
            kt = min((tols[q].value for q in kin_q), default=float("nan"))
            rt = min((tols[q].value for q in rea_q), default=float("nan"))
            specs.append(FigureSpec(
                _file_key(f"difference-{e}"),
                "difference",
                e,
                f"{e}: relative difference against {matrix.reference}",
                "Worst relative difference r over the compared columns at each crank position "
                "(log scale); dashed: the tolerance. Gaps: rows not compared (dead centres, "
                "unassembled).",
                ("difference", (e, rows, (kt, rt))),
            ))
    return specs


def _heatmap_specs(matrix: Matrix, comparison: Comparison) -> list[FigureSpec]:
    """Per judge: the heat map of its ratio to tolerance per case and quantity of the matrix."""
    specs: list[FigureSpec] = []
    for e in matrix.judges:
        ids = [mc.id for mc in matrix.cases if mc.is_slider_crank and comparison.for_engine(mc.id, e)]
        if ids:
            specs.append(heatmap_spec(comparison, e, ids, list(matrix.quantities) + [STROKE]))
    return specs


def heatmap_spec(comparison: Comparison, engine: str, cases: list[str], quantities: list[str],
                 key: str | None = None) -> FigureSpec:
    """The heat map of judge ``engine``: its ratio to tolerance per case and quantity (with the worst relative
    difference and the tolerance, for the interactive figure's hover), and its failures; its file stem
    ``key`` (default ``heatmap-<engine>``)."""
    ratios, failed, max_rel, tolerance = heatmap_arrays(comparison, engine, cases, quantities)
    return FigureSpec(
        _file_key(key or f"heatmap-{engine}"),
        "heatmap",
        engine,
        f"{engine}: agreement per case and quantity",
        HEATMAP_CAPTION,
        ("heatmap", (engine, cases, quantities, ratios, failed, max_rel, tolerance)),
        static=True,
    )


def _file_key(text: str) -> str:
    """A figure file stem that needs no escaping in URLs or Markdown."""
    return re.sub(r"[^A-Za-z0-9.-]", "-", text)


#: Per kind of figure: the function drawing it as PNG (None: interactive only), the one making it interactive.
_FIGURE_FUNCTIONS = {
    "sweep": (sweep_figure, interactive.sweep_plot),
    "difference": (None, interactive.difference_plot),
    "heatmap": (heatmap_figure, interactive.heatmap_plot),
    "balancing": (shaking_force_figure, interactive.shaking_force_plot),
    "case": (overlay_figure, overlay_plot),
}
#: Kinds of figure from the slowest to make to the fastest.
_RENDER_ORDER = ("balancing", "heatmap", "case", "difference", "sweep")


def _render(job: tuple[str, tuple], static: bool = False) -> tuple[bytes | None, str]:
    """The figure of ``job``: its PNG if ``static`` (else None), and its interactive figure's JSON text."""
    name, args = job
    draw, plot = _FIGURE_FUNCTIONS[name]
    png = None
    if static:
        with drawing():
            png = draw(*args)
    return png, plot(*args)


class PendingFigures:
    """The figures of a report, planned and started in two stages (:func:`start_figures`, then
    :meth:`add_judged`); :meth:`collect` waits for them.

    ``specs`` is the plan, in the report's order: the sweep figures, each judge's difference plot, each
    judge's heat map, the other sections' figures.  With a pool, figures are drawn in its workers in the
    order they are started; without one (``jobs = 1``), by :meth:`collect`, in this process.
    """

    def __init__(self, jobs: int = 1) -> None:
        self._pool = shared_pool(jobs) if jobs > 1 else None
        self.specs: list[FigureSpec] = []
        self._rendered: list[Any] = []  # per spec: its future once started, else its drawing job
        self._held: list[int] = []

    def add(self, specs: list[FigureSpec], start: int | None = None) -> None:
        """Add ``specs`` to the plan; start the first ``start`` of them (default all), the slowest kind first,
        and hold the others for :meth:`start_held`."""
        first = len(self.specs)
        self.specs += specs
        self._rendered += [(spec.job, spec.static) for spec in specs]
        end = first + (len(specs) if start is None else start)
        self._start(list(range(first, end)))
        self._held += range(end, len(self.specs))

    def add_judged(self, matrix: Matrix, comparison: Comparison, extra: tuple[FigureSpec, ...] = ()) -> None:
        """Plan and start the figures that need the comparison (each judge's difference plot and heat map)
        and the ``extra`` ones of other sections, then the sweep figures held."""
        self.add([*_difference_specs(matrix, comparison), *_heatmap_specs(matrix, comparison), *extra])
        self.start_held()

    def start_held(self) -> None:
        """Start the figures held by :meth:`add`."""
        held, self._held = self._held, []
        self._start(held)

    def _start(self, indices: list[int]) -> None:
        if self._pool is None:
            return
        for i in sorted(indices, key=lambda i: _RENDER_ORDER.index(self.specs[i].job[0])):  # stable
            self._rendered[i] = self._pool.submit(_render, *self._rendered[i])

    def collect(self, progress: ProgressCallback | None = None) -> list[Figure]:
        """Every figure in plan order (held ones started first); ``progress(done, total, key)`` after each."""
        made: list[tuple[bytes | None, str]] = []
        try:
            self.start_held()
            for spec, job in zip(self.specs, self._rendered):
                made.append(job.result() if isinstance(job, cf.Future) else _render(*job))
                if progress is not None:
                    progress(len(made), len(self.specs), spec.key)
        except cf.process.BrokenProcessPool as err:  # a worker killed: one line, exit 4 (cli.errors)
            raise worker_died(self._pool, err, lambda pid: " while drawing the report's figures") from None
        return [Figure(*spec[:5], png, plot) for spec, (png, plot) in zip(self.specs, made)]

    def cancel(self) -> None:
        """Drop the figures not started yet (the report failed elsewhere)."""
        self._held = []
        for job in self._rendered:
            if isinstance(job, cf.Future):
                job.cancel()


def start_figures(matrix: Matrix, results: dict, jobs: int = 1) -> PendingFigures:
    """Plan the report's sweep figures (they need the results only) and start drawing those of the
    matrix's first sweep in the ``jobs`` workers of the shared pool (the run's own:
    :func:`~dualmech.validation.run.executors.shared_pool`); :meth:`PendingFigures.add_judged` adds the rest
    once the run is compared.

    The first sweep's figures keep the workers busy while this process compares the run (the thesis
    matrix: 12 figures, ~0.8 s of the two workers, against ~0.4 s to compare and to solve the balancing
    section); the other sweeps' wait, so that the slowest kinds, which need the comparison, are not drawn
    last, with one worker idle.
    """
    pending = PendingFigures(jobs)
    specs = _sweep_specs(matrix, results)
    pending.add(specs, start=sum(spec.group == specs[0].group for spec in specs) if specs else 0)
    return pending


def render_figures(
    matrix: Matrix,
    results: dict,
    comparison: Comparison,
    jobs: int = 1,
    progress: ProgressCallback | None = None,
) -> list[Figure]:
    """Every figure of the report, rendered in ``jobs`` processes.

    ``progress(done, total, key)`` is called after each figure.
    """
    pending = start_figures(matrix, results, jobs)
    pending.add_judged(matrix, comparison)
    return pending.collect(progress)
