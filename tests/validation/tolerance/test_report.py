"""The tolerance report's figures (validation/tolerance/report.py): drawn once with margins set from their
labels, nothing cut off; the same PNG bytes whether a worker process draws them or this one."""

import numpy as np
import pytest

import dualmech.validation.tolerance.report as report
from dualmech.validation.tolerance.report import FigureDrawing, draw_figures, figure_jobs
from tests.validation.worker_exits import exit_code

#: The longest keys a SPEC may vary (docs/conventions.md, "Tolerance analysis").
LONG_KEYS = ["geometry.crank_axial_shift", "geometry.slider_twist_deg", "motion.axial_amplitude",
             "bodies.weight_density", "bodies.slider.mass"]


def _heavy_tail(n=5000, seed=0):
    """Peaks spanning seven decades (a log axis) and counts in the thousands."""
    return np.exp(np.random.default_rng(seed).normal(8.0, 2.5, n))


def _plots():
    values = _heavy_tail()
    shares = {k: 1.0 / len(LONG_KEYS) for k in LONG_KEYS}
    nominal, p99 = float(np.median(values)), float(np.quantile(values, 0.99))
    return [report.histogram_plot("peak_j1_moment", values, nominal, p99, "lbf·in"),
            report.histogram_plot("stroke", np.random.default_rng(1).normal(24.0, 2.0, 200_000), 24.0, 28.0,
                                  "in"),
            report.tornado_plot("peak_slider_load", LONG_KEYS, shares, shares),
            report.tornado_plot("stroke", LONG_KEYS[:1], None, {LONG_KEYS[0]: 1.0})]


def _cut_off(fig):
    """How far (inches) anything drawn reaches outside the figure (0 if nothing does)."""
    fig.canvas.draw()
    box = fig.get_tightbbox(fig.canvas.get_renderer())
    width, height = fig.get_size_inches()
    report._pyplot().close(fig)
    return max(0.0, -box.x0, -box.y0, box.x1 - width, box.y1 - height)


def test_every_label_is_inside_its_figure():
    assert [_cut_off(fig) for fig in _plots()] == [0.0, 0.0, 0.0, 0.0]


def test_the_label_check_sees_a_margin_too_small(monkeypatch):
    """Deliberate fault: histograms without a left margin (the counts and the y label off the figure)."""
    monkeypatch.setattr(report, "HIST_MARGINS", {**report.HIST_MARGINS, "left": 0.02})
    assert _cut_off(_plots()[0]) > 0.1


def _summary():
    names = ["stroke", "peak_j1_force"]
    keys = LONG_KEYS[:2]
    return {"nominal": {n: 1.0 for n in names}, "outputs": {n: {"p99": 2.0} for n in names}, "keys": keys,
            "contribution": {n: {k: 0.5 for k in keys} for n in names},
            "linear_share": {n: {keys[0]: 0.9, keys[1]: None} for n in names}}


def _samples(scale=1.0):
    rng = np.random.default_rng(4)
    return {"status": np.array(["ok"] * 300 + ["partial"] * 20, dtype=object),
            "stroke": scale * rng.normal(24.0, 2.0, 320), "peak_j1_force": scale * _heavy_tail(320, 5)}


def test_the_worker_process_draws_the_same_figures_as_this_one():
    drawing = FigureDrawing(parallel=True)
    try:
        drawing.warm()
        drawing.start(_summary(), _samples())
        drawn = drawing.collect()
    finally:
        drawing.close()
    here = draw_figures(figure_jobs(_summary(), _samples()))
    assert [f.key for f in drawn] == ["hist-stroke", "hist-peak_j1_force", "tornado-stroke",
                                      "tornado-peak_j1_force"]
    assert [f.png for f in drawn] == [f.png for f in here]
    # the comparison sees a difference in the samples drawn (its deliberate fault)
    other = draw_figures(figure_jobs(_summary(), _samples(scale=1.05)))  # 0.1 %: the same pixels
    assert [f.png for f in drawn][:2] != [f.png for f in other][:2]


def test_a_drawing_never_started_or_collected_is_refused_and_its_worker_ended():
    drawing = FigureDrawing(parallel=True)
    with pytest.raises(RuntimeError, match="before start"):
        drawing.collect()
    drawing.warm()
    processes = list(drawing._pool._processes.values()) if drawing._pool._processes else []
    drawing.close()  # the study stopped before its figures were collected: the worker is ended at once
    assert processes
    for proc in processes:  # ended by close (a signal), not after finishing its import of matplotlib
        code = exit_code(proc, timeout=30)
        assert code is not None and code < 0, code


def test_a_histogram_says_its_output_and_unit_on_its_x_axis():
    fig = report.histogram_plot("peak_j1_moment", _heavy_tail(200), 3000.0, 9000.0, "lbf·in")
    assert fig.axes[0].get_xlabel() == "peak_j1_moment [lbf·in]"
    report._pyplot().close(fig)
