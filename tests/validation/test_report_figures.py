"""The report's figures (validation/report/figures.py, plots.py, interactive.py): made once each, in the run's
workers, in plan order, nothing cut off; the static ones (PNG) only those the Markdown report shows."""

from __future__ import annotations

import concurrent.futures as cf
from collections.abc import Callable, Iterator
from dataclasses import replace

import numpy as np
import pytest

from dualmech.validation.compare import compare_run
from dualmech.validation.matrix import load_matrix
from dualmech.validation.report import canvas, derived, figures, plots
from dualmech.validation.report.sections import balancing_spec
from dualmech.validation.run import executors

from .conftest import SMALL, fake_results


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
    assert {s.job[0] for s in plan} == set(figures._RENDER_ORDER)
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
    from dualmech.validation.matrix import load_matrix

    from .conftest import fake_results

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
    from dualmech.validation.matrix import Matrix, load_matrix
    from dualmech.validation.report import derived
    from dualmech.validation.report.render import ReportError, write_report
    from dualmech.validation.run.runner import run_matrix

    from .test_validate import FAKE_REGISTRY

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


def _png_width(png: bytes) -> int:
    return int.from_bytes(png[16:20], "big")  # the IHDR chunk's width


def _crops_and_closes() -> tuple[int, int, bool]:
    """(tight width, untight width, pyplot still holds the figures) of a figure with a label beyond it."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    widths = []
    for tight in (True, False):
        fig = plt.figure(figsize=(4.0, 3.0))
        fig.add_subplot().plot([0.0, 1.0])
        fig.text(1.2, 0.5, "beyond the right edge")
        widths.append(_png_width(canvas.fig_to_png(fig, tight=tight)))
    return widths[0], widths[1], bool(plt.get_fignums())


def test_other_reports_keep_their_cropped_figures():
    """Why: the report's own figures are no longer cropped (that drew them twice); the linkage report's
    pyplot figures still are by default, and are still closed."""
    tight, untight, open_figures = _crops_and_closes()
    assert untight == 4 * canvas.DPI and tight > untight
    assert not open_figures


def test_a_crop_that_is_ignored_is_seen(monkeypatch):
    """The fault the test above must see: ``bbox_inches`` dropped whatever the caller asks."""
    from matplotlib.figure import Figure

    real = Figure.savefig
    monkeypatch.setattr(Figure, "savefig", lambda self, *a, bbox_inches=None, pad_inches=None, **k:
                        real(self, *a, **k))
    tight, untight, _ = _crops_and_closes()
    assert tight == untight


def _without_values(matrix, results, column: str = "j2_fx") -> dict:
    """``results`` with ``column`` NaN in every torque-mode table (a panel with no value to set its range)."""
    torque = {mc.id for mc in matrix.cases if mc.mode == "torque"}
    nan = {column: np.full(len(next(iter(results.values()))["dualmech"]), np.nan)}
    return {cid: {e: replace(t, columns={**t.columns, **nan}) if cid in torque else t for e, t in per.items()}
            for cid, per in results.items()}


def _static_specs(matrix, results) -> list:
    """The report's figures that have a static (PNG) drawing, in plan order."""
    return [s for s in _specs(matrix, results) if figures._FIGURE_FUNCTIONS[s.job[0]][0] is not None]


def _draw(spec) -> bytes:
    """The PNG of ``spec``'s figure (its static drawing alone: the interactive one is not under test here)."""
    name, args = spec.job
    with canvas.drawing():
        return figures._FIGURE_FUNCTIONS[name][0](*args)


def _reused(matrix, results) -> Iterator[bytes]:
    """Every figure drawn in plan order and then in reverse (listed in plan order) on the figures this process
    keeps per kind, one at a time: a check that fails at the first figure that differs draws no more."""
    specs = _static_specs(matrix, results)
    canvas._SKELETONS.clear()
    try:
        yield from (_draw(s) for s in specs)
        backward = [_draw(s) for s in reversed(specs)]
        assert len(canvas._SKELETONS) < len(specs)  # kinds were shared: the check compares reuses
        yield from reversed(backward)
    finally:
        canvas._SKELETONS.clear()


def _new(matrix, results) -> list[bytes]:
    """Every figure drawn on a new figure, for plan order and for the reverse order (as :func:`_reused`)."""
    new = []
    for s in _static_specs(matrix, results):
        canvas._SKELETONS.clear()
        new.append(_draw(s))
    canvas._SKELETONS.clear()
    return new + new


@pytest.fixture(scope="module")
def new_figures(tmp_path_factory) -> Callable[[str], list[bytes]]:
    """``data`` -> :func:`_new` of the ``SMALL`` matrix's results as solved or with a panel without values,
    drawn once per module: a new figure is drawn by the same code whatever fault below is put in the reuse
    of figures (``canvas._empty`` and ``canvas._autoscale_y`` run on reuse only; a new axis's locator is
    never an empty one, so a flat panel's locator kept changes nothing on a new figure)."""
    path = tmp_path_factory.mktemp("small") / "small.toml"
    path.write_text(SMALL)
    matrix = load_matrix(path)
    drawn: dict[str, list[bytes]] = {}

    def new(data: str) -> list[bytes]:
        if data not in drawn:
            drawn[data] = _new(matrix, _data(matrix, fake_results(matrix), data))
        return drawn[data]

    return new


def _data(matrix, results, data: str) -> dict:
    return results if data == "as solved" else _without_values(matrix, results)


@pytest.mark.parametrize("data", ["as solved", "a panel without values"])
def test_a_reused_figure_draws_what_a_new_one_draws(matrix, results, new_figures, data):
    """Why: a process draws each figure on the one it kept from the last figure of the same kind (the axes,
    ticks and labels are made once), its data replaced; whatever was drawn there before (another sweep's
    curves and limits, a flat panel without ticks, legends) must leave no trace. Both orders: the small
    matrix's joint-3 figure has a flat panel in force mode, not in torque mode; without values, joint 2's
    first panel autoscales in torque mode and has set limits in force mode.  Faults seen: the lines kept for
    the next figure (canvas.kept_line) left visible; a panel without values autoscaled on them."""
    assert list(_reused(matrix, _data(matrix, results, data))) == new_figures(data)


@pytest.mark.parametrize("fault", ["data kept", "ticks of a flat panel kept", "limits kept"])
def test_a_reused_figure_with_traces_is_seen(matrix, results, new_figures, monkeypatch, fault):
    """The faults the test above must see: the last figure's data left in place; a panel's locator left as
    the flat panel before it set it (no ticks); the y limits of the last figure kept where none are set."""
    data = "as solved"
    if fault == "data kept":
        monkeypatch.setattr(canvas, "_empty", lambda fig: None)
    elif fault == "ticks of a flat panel kept":
        from matplotlib.axis import Axis
        from matplotlib.ticker import FixedLocator

        real = Axis.set_major_locator

        def kept_flat(self, locator):
            now = self.get_major_locator()
            if not (isinstance(now, FixedLocator) and len(now.locs) == 0):
                real(self, locator)

        monkeypatch.setattr(Axis, "set_major_locator", kept_flat)
    else:
        monkeypatch.setattr(canvas, "_autoscale_y", lambda ax: None)
        data = "a panel without values"
    new = new_figures(data)
    assert any(a != b for a, b in zip(_reused(matrix, _data(matrix, results, data)), new, strict=True))


def test_figures_are_drawn_under_the_report_settings_only(monkeypatch):
    """Every report figure is made and drawn under canvas.FIGURE_RC (glyphs not hinted), and the process's
    own matplotlib settings are as they were after it."""
    import matplotlib

    seen = []
    monkeypatch.setitem(figures._FIGURE_FUNCTIONS, "probe",
                        (lambda: seen.append({k: matplotlib.rcParams[k] for k in canvas.FIGURE_RC}) or b"",
                         lambda: "{}"))
    before = {k: matplotlib.rcParams[k] for k in canvas.FIGURE_RC}
    assert figures._render(("probe", ()), static=True) == (b"", "{}")
    assert seen == [canvas.FIGURE_RC]
    assert {k: matplotlib.rcParams[k] for k in canvas.FIGURE_RC} == before != canvas.FIGURE_RC


def test_the_first_figures_are_drawn_while_the_run_is_compared(small, tmp_path, monkeypatch):
    """Why: this process compares the run (0.3 s of the main job) and solves the balancing section while the
    workers would otherwise wait; a report given a function that makes the comparison calls it once its
    first figures are in the workers.  Fault seen: the comparison made before the figures start."""
    from dualmech.validation.matrix import load_matrix
    from dualmech.validation.report.render import write_report
    from dualmech.validation.run.runner import load_results, run_matrix

    from .test_validate import FAKE_REGISTRY

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
    from dualmech.validation.matrix import load_matrix
    from dualmech.validation.report.render import write_report
    from dualmech.validation.run.runner import run_matrix
    from dualmech.validation.rundir import created_files

    from .test_validate import FAKE_REGISTRY

    run_matrix(load_matrix(small), tmp_path / "run", jobs=1, registry=FAKE_REGISTRY)
    monkeypatch.chdir(tmp_path)
    first = write_report(tmp_path / "run", "reports/small", jobs=1)
    monkeypatch.setattr(figures, "STATIC_SWEEP_FIGURES", frozenset())
    second = write_report(tmp_path / "run", "reports/small", jobs=1)
    gone = {p.name for p in first.figures} - {p.name for p in second.figures}
    assert gone and not any((tmp_path / "reports/small/figures" / name).exists() for name in gone)
    assert all(not name.startswith("reports/") for name in created_files(tmp_path / "reports/small"))
