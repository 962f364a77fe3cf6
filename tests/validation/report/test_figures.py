"""The report's figures (validation/report/figures.py, plots.py, interactive.py): made once each, in the run's
workers, in plan order, nothing cut off; the static ones (PNG) only those the Markdown report shows."""

from __future__ import annotations

import concurrent.futures as cf

import pytest

from dualmech.validation.compare import compare_run
from dualmech.validation.matrix import load_matrix
from dualmech.validation.report import derived, figures, plots
from dualmech.validation.report.sections import balancing_spec
from dualmech.validation.run import executors
from tests.validation.conftest import fake_results


def _specs(matrix, results):
    return figures.figure_specs(matrix, results, compare_run(matrix, results))


def _drawn_in(jobs, matrix, results, comparison, extra=()):
    """Every figure of the report, drawn by ``jobs`` processes, in its two stages."""
    pending = figures.start_figures(matrix, results, jobs)
    pending.add_judged(matrix, comparison, extra)
    return pending.collect()


def test_figures_drawn_in_workers_come_back_in_plan_order(matrix, results):
    """Why: the figures are now handed to the run's workers slowest kind first and collected while this
    process computes the other sections; the report must list them in the plan's order, each the same PNG
    as drawn here."""
    comparison = compare_run(matrix, results)
    extra = (balancing_spec(derived.balancing(matrix)),)  # the balancing section's figure, drawn with them
    here = _drawn_in(1, matrix, results, comparison, extra)
    try:
        there = _drawn_in(2, matrix, results, comparison, extra)
    finally:
        executors.end_shared_pool()
    plan = [*figures.figure_specs(matrix, results, comparison), *extra]
    assert [f.key for f in here] == [s.key for s in plan]
    # every kind of figure but the engine overlay of a case without sweeps (a linkage's:
    # tests/validation/report/test_linkage_report.py)
    assert {s.job[0] for s in plan} == set(figures._RENDER_ORDER) - {"case"}
    assert [f.key for f in there] == [f.key for f in here]
    assert [f.png for f in there] == [f.png for f in here]
    assert [f.plot for f in there] == [f.plot for f in here]
    assert [f.png is not None for f in here] == [s.static for s in plan] and any(s.static for s in plan)


def test_figures_collected_as_they_finish_are_seen(matrix, results, monkeypatch):
    """The fault the test above must see: the figures listed in the order the workers finished them."""
    comparison = compare_run(matrix, results)

    def as_finished(self, progress=None):
        futures = {job: spec for spec, job in zip(self.specs, self._rendered)}
        return [plots.Figure(*futures[f][:5], *f.result()) for f in cf.as_completed(futures)]

    monkeypatch.setattr(figures.PendingFigures, "collect", as_finished)
    try:
        there = _drawn_in(2, matrix, results, comparison)
    finally:
        executors.end_shared_pool()
    assert [f.key for f in there] != [s[0] for s in figures.figure_specs(matrix, results, comparison)]


class _RecordingPool:
    """A stand-in for the shared pool: records what is submitted, and draws nothing."""

    def __init__(self) -> None:
        self.submitted: list[str] = []

    def submit(self, func, job, static):
        self.submitted.append(job[1][0] if job[0] == "sweep" else job[0])  # a sweep figure by its title
        future = cf.Future()
        future.set_result((b"" if static else None, "{}"))
        return future


def test_figures_are_started_first_sweep_then_slowest_kinds_then_the_other_sweeps(small, monkeypatch):
    """Why: the first sweep's figures (they need the results only) keep the workers busy while the run is
    compared; the slowest kinds, which need the comparison, then go before the other sweeps' figures, so that
    they are not drawn last with one worker idle.  Fault seen: the held sweeps started before the judged
    figures (their order in the plan)."""


    small.write_text(small.read_text() + '''
[[sweep]]
name = "S1"
fixed = { "geometry.slider_offset" = 30.0 }
grid = { "geometry.crank_axial_shift" = [3.0, 6.0] }
''')
    matrix = load_matrix(small)
    results = fake_results(matrix)
    pool = _RecordingPool()
    monkeypatch.setattr(figures, "shared_pool", lambda jobs: pool)
    pending = figures.start_figures(matrix, results, jobs=2)
    first = list(pool.submitted)
    extra = (balancing_spec(derived.balancing(matrix)),)
    pending.add_judged(matrix, compare_run(matrix, results), extra)
    assert first and all(": a4 sweep" in title for title in first)
    n_sweeps = len(figures.SWEEP_FIGURES) * len(matrix.sweeps) * len(matrix.modes)
    assert len(first) == n_sweeps // 2
    judged = pool.submitted[len(first):len(first) + 1 + 2 * len(matrix.judges)]
    assert judged == ["balancing", *["heatmap"] * len(matrix.judges), *["difference"] * len(matrix.judges)]
    rest = pool.submitted[len(first) + len(judged):]
    assert len(rest) == n_sweeps // 2 and all(": S1 sweep" in title for title in rest)
    assert [f.key for f in pending.collect()] == [s[0] for s in pending.specs]


def _undrawn_tick_labels(fig) -> set[int]:
    """Labels of ticks outside their axis's view: not drawn (matplotlib < 3.9 keeps them, placed beyond
    the axes, e.g. the 1e-16 below a log axis that starts at 1e-15)."""
    out = set()
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            lo, hi = sorted(axis.get_view_interval())
            for tick in axis.get_major_ticks() + axis.get_minor_ticks():
                loc = tick.get_loc()
                if loc is None or not lo - 1e-9 * abs(lo) <= loc <= hi + 1e-9 * abs(hi):
                    out.update({id(tick.label1), id(tick.label2)})
    return out


def _cut_off(fig) -> list[str]:
    """Visible texts of a drawn figure that reach beyond its canvas (by more than a pixel)."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    width, height = fig.canvas.get_width_height()
    undrawn = _undrawn_tick_labels(fig)
    out = []
    for text in fig.findobj(lambda a: hasattr(a, "get_text") and hasattr(a, "get_window_extent")):
        if not text.get_visible() or not text.get_text() or id(text) in undrawn:
            continue
        box = text.get_window_extent(renderer)
        if box.x0 < -1 or box.y0 < -1 or box.x1 > width + 1 or box.y1 > height + 1:
            out.append(text.get_text())
    return out


def _drawn(matrix, results, monkeypatch) -> dict:
    """One figure of each kind that is drawn as PNG, as matplotlib figures."""
    kept = {}
    monkeypatch.setattr(plots, "fig_to_png", lambda fig, **kwargs: kept.setdefault("fig", fig) and b"")
    out = {}
    specs = [*_specs(matrix, results), balancing_spec(derived.balancing(matrix))]
    for spec in specs:
        kind = spec.job[0]
        if kind not in out and figures._FIGURE_FUNCTIONS[kind][0] is not None:
            kept.clear()
            figures._render(spec.job, static=True)
            out[kind] = kept["fig"]
    return out


def test_no_text_is_cut_off(matrix, results, monkeypatch):
    """Why: figures are saved whole (no tight bounding box: it drew each figure twice), so their fixed
    margins must hold every title, label, tick label and legend entry."""
    drawn = _drawn(matrix, results, monkeypatch)
    assert set(drawn) == {"sweep", "heatmap", "balancing"}
    for kind, fig in drawn.items():
        assert not _cut_off(fig), kind


@pytest.mark.parametrize("margin", ["left", "bottom"])
def test_a_margin_too_small_is_seen(matrix, results, monkeypatch, margin):
    """The fault the test above must see: a figure whose margin leaves its labels outside the canvas."""
    from matplotlib.figure import Figure

    real = Figure.subplots_adjust

    def no_margin(self, *args, **kwargs):
        real(self, *args, **{**kwargs, margin: 0.0})

    monkeypatch.setattr(Figure, "subplots_adjust", no_margin)
    drawn = _drawn(matrix, results, monkeypatch)
    drawn.pop("balancing")  # a polar plot sits in the middle of its figure: no margin holds its labels
    assert all(_cut_off(fig) for fig in drawn.values())


def _record_started(monkeypatch) -> list:
    """The :class:`~figures.PendingFigures` that ``write_report`` starts from now on, as it starts them."""
    started = []
    real = figures.start_figures

    def start(*args, **kwargs):
        started.append(real(*args, **kwargs))
        return started[-1]

    monkeypatch.setattr("dualmech.validation.report.render.start_figures", start)
    return started


def _failed_report(small, tmp_path, monkeypatch) -> list:
    """A report whose findings section (the last before the figures are collected; a thesis matrix's) fails
    while the workers draw its figures; its figure jobs."""
    from dualmech.validation.matrix import Matrix
    from dualmech.validation.report import derived
    from dualmech.validation.report.render import ReportError, write_report
    from dualmech.validation.run.runner import run_matrix
    from tests.validation.test_validate import FAKE_REGISTRY

    run_matrix(load_matrix(small), tmp_path / "run", jobs=1, registry=FAKE_REGISTRY)
    started = _record_started(monkeypatch)

    def broken():
        raise RuntimeError("findings broke")

    monkeypatch.setattr(Matrix, "of_thesis", property(lambda self: True))
    monkeypatch.setattr(derived, "findings", broken)
    try:
        with pytest.raises(ReportError, match="findings"):
            write_report(tmp_path / "run", None, jobs=2)
        jobs = list(started[0]._rendered)
        cf.wait([j for j in jobs if not j.cancelled()], timeout=60)
    finally:
        executors.end_shared_pool()
    return jobs


def test_a_failed_report_drops_the_figures_not_started(small, tmp_path, monkeypatch):
    """Why: the figures are drawn while this process builds the other sections; when one of those fails,
    the workers must not go on drawing a report that will not be written."""
    jobs = _failed_report(small, tmp_path, monkeypatch)
    assert len(jobs) > 4 and any(j.cancelled() for j in jobs)


def test_a_failed_report_that_draws_on_is_seen(small, tmp_path, monkeypatch):
    """The fault the test above must see: the figures left to draw after the failure."""
    monkeypatch.setattr(figures.PendingFigures, "cancel", lambda self: None)
    jobs = _failed_report(small, tmp_path, monkeypatch)
    assert not any(j.cancelled() for j in jobs)


def test_the_first_figures_are_drawn_while_the_run_is_compared(small, tmp_path, monkeypatch):
    """Why: this process compares the run (0.3 s of the main job) and solves the balancing section while the
    workers would otherwise wait; a report given a function that makes the comparison calls it once its
    first figures are in the workers.  Fault seen: the comparison made before the figures start."""
    from dualmech.validation.report.render import write_report
    from dualmech.validation.run.runner import load_results, run_matrix
    from tests.validation.test_validate import FAKE_REGISTRY

    matrix = load_matrix(small)
    run_matrix(matrix, tmp_path / "run", jobs=1, registry=FAKE_REGISTRY)
    results = load_results(tmp_path / "run", matrix)
    started, seen = _record_started(monkeypatch), []

    def compare():
        seen.append(sum(isinstance(job, cf.Future) for job in started[0]._rendered) if started else 0)
        return compare_run(matrix, results)

    try:
        files = write_report(tmp_path / "run", None, jobs=2, comparison=compare)
    finally:
        executors.end_shared_pool()
    assert seen and seen[0] == len(figures.SWEEP_FIGURES) * len(matrix.modes)  # the (first) sweep's
    assert files.verdict == "PASS" and len(files.figures) == sum(s.static for s in started[0].specs)


def test_a_report_in_a_relative_folder_removes_the_figures_it_no_longer_draws(small, tmp_path, monkeypatch):
    """Why: ``--report-dir reports/thesis-1991`` (a relative folder) listed its files in the manifest by their
    path from the working folder, so a later report, drawing fewer PNGs, could not see its own old figures
    as stale, and left them."""
    from dualmech.validation.report.render import write_report
    from dualmech.validation.run.runner import run_matrix
    from dualmech.validation.rundir import created_files
    from tests.validation.test_validate import FAKE_REGISTRY

    run_matrix(load_matrix(small), tmp_path / "run", jobs=1, registry=FAKE_REGISTRY)
    monkeypatch.chdir(tmp_path)
    first = write_report(tmp_path / "run", "reports/small", jobs=1)
    monkeypatch.setattr(figures, "STATIC_SWEEP_FIGURES", frozenset())
    second = write_report(tmp_path / "run", "reports/small", jobs=1)
    gone = {p.name for p in first.figures} - {p.name for p in second.figures}
    assert gone and not any((tmp_path / "reports/small/figures" / name).exists() for name in gone)
    assert all(not name.startswith("reports/") for name in created_files(tmp_path / "reports/small"))
