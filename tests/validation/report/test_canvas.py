"""The report's canvas (validation/report/canvas.py): figures drawn under the report's own settings, the
linkage report's pyplot figures cropped and closed, and each figure drawn on the one a process keeps per
kind exactly as on a new one."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import replace

import numpy as np
import pytest

from dualmech.validation.compare import compare_run
from dualmech.validation.matrix import load_matrix
from dualmech.validation.report import canvas, figures
from tests.validation.conftest import SMALL, fake_results


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
    specs = figures.figure_specs(matrix, results, compare_run(matrix, results))
    return [s for s in specs if figures._FIGURE_FUNCTIONS[s.job[0]][0] is not None]


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
