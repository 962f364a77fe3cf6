"""The report's figures as matplotlib objects: made bare (Agg, no pyplot), kept per kind for the next
figure of that kind, and encoded as PNG bytes.

:func:`skeleton` is what makes the report's figures cheap: a figure's axes, ticks, titles and labels cost
more to make than its data, and a report draws the same kinds of figure many times (the thesis report:
six kinds of sweep figure, six of each), so each process makes them once per kind and replaces the data;
:func:`kept_line` keeps a sweep figure's curves too, and gives them the next figure's data.
"""

from __future__ import annotations

import io
import weakref
from collections.abc import Hashable
from typing import Any, Callable

import numpy as np

#: Resolution of every report figure (dots per inch).
DPI = 80
#: Settings every report figure is drawn under (:func:`drawing`): glyphs not hinted.  Text is most of a
#: report figure's cost, and FreeType's hinting of each glyph at each draw a tenth of the whole (the thesis
#: report's 42 figures: 6.26 -> 5.48 s of CPU, one process, warm); at 80 dpi the text looks the same.
FIGURE_RC = {"text.hinting": "no_hinting"}
#: zlib level of the PNG files (Pillow's default is 6): the same pixels, encoded in ~35 % less time for ~4 %
#: more bytes (the thesis report's 43 figures: 0.92 -> 0.59 s of CPU, 4.26 -> 4.42 MB).
PNG_COMPRESS_LEVEL = 1


def drawing() -> Any:
    """A context in which report figures are made and drawn: matplotlib's settings with :data:`FIGURE_RC`
    (rather than set for the whole process, which may draw other figures)."""
    from matplotlib import rc_context

    return rc_context(FIGURE_RC)


def new_figure(figsize: tuple[float, float]) -> Any:
    """A bare Agg figure (no pyplot: no figure manager to create and close; the caller keeps no reference)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure as MplFigure

    fig = MplFigure(figsize=figsize, dpi=DPI)
    FigureCanvasAgg(fig)
    return fig


#: This process's report figures kept for the next figure of the same kind (:func:`skeleton`).
_SKELETONS: dict[tuple, Any] = {}


def skeleton(key: tuple, figsize: tuple[float, float], build: Callable[[Any], None]) -> Any:
    """A figure of ``figsize`` inches, ``build(fig)`` applied and no data in it.

    ``build`` makes what depends on ``key`` alone (axes, panel titles, axis labels, ticks, scales); it runs
    at the first figure of ``key`` in this process, and the next one gets the same figure back, its data
    removed (:func:`_empty`): the axes and their tick machinery, most of a figure's cost to make, are made
    once per kind instead of once per figure.  The caller sets everything else each time (data, limits of
    autoscaled axes, legends, suptitle, margins).
    """
    fig = _SKELETONS.get(key)
    if fig is None:
        fig = _SKELETONS[key] = new_figure(figsize)
        build(fig)
    else:
        _empty(fig)
        fig.set_size_inches(figsize)  # the last figure of the kind may have been of another size
    return fig


#: Per axes of a skeleton, its lines kept for the next figure of the kind (:func:`kept_line`), by slot.
_KEPT: "weakref.WeakKeyDictionary[Any, dict[Hashable, Any]]" = weakref.WeakKeyDictionary()
#: The label of a kept line that the current figure does not use: hidden, and left out of legends.
_UNUSED = "_unused"


def kept_line(ax: Any, slot: Hashable, x: np.ndarray, y: np.ndarray, **props: Any) -> Any:
    """A line of ``ax`` through ``(x, y)`` with the Line2D properties ``props``: made by ``ax.plot`` at the
    first figure of the skeleton, then the same line given the new data and properties.

    Making a line (``ax.plot``: argument parsing, marker set-up, clip path, data limits) was a sixth of a
    sweep figure's cost; a kept line is hidden by :func:`_empty` until its ``slot`` is used again.  Its data
    limits are not those of the axes: the caller sets the y limits (or calls :func:`autoscale_y_visible`).
    """
    kept = _KEPT.setdefault(ax, {})
    line = kept.get(slot)
    if line is None:
        line = kept[slot] = ax.plot(x, y, **props)[0]
    else:
        line.set(data=(x, y), visible=True, **props)
    return line


def autoscale_y_visible(ax: Any) -> None:
    """The y limits of ``ax`` from the data of its visible artists (a kept line's data is not counted in the
    axes' data limits when it is replaced)."""
    ax.relim(visible_only=True)
    ax.autoscale_view(scalex=False)


def _empty(fig: Any) -> None:
    """Remove what a report figure drew on its skeleton (texts, legends, lines but the kept ones, which are
    hidden); y axes autoscale again."""
    for legend in list(fig.legends):
        legend.remove()
    for ax in fig.axes:
        kept = set(_KEPT.get(ax, {}).values())
        for artist in (*ax.lines, *ax.texts):
            if artist in kept:
                artist.set(visible=False, label=_UNUSED)
            else:
                artist.remove()
        if ax.legend_ is not None:
            ax.legend_.remove()
        _autoscale_y(ax)


def _autoscale_y(ax: Any) -> None:
    """Let the y limits of ``ax`` come from its data again, as on a new axes: no data limits, the view's
    y interval of a new axes (unit box: unset, so no data gives matplotlib's default range), autoscaled."""
    ax.relim()
    ax.viewLim.intervaly = (0.0, 1.0)
    ax.set_autoscaley_on(True)


def fig_to_png(fig: Any, *, tight: bool = True) -> bytes:
    """The figure as PNG bytes; a pyplot figure is closed.

    ``tight``: crop to the drawn artists (``bbox_inches="tight"``: nothing cut off, but the figure is drawn
    twice, once to measure it).  The report's own figures set their margins in inches and pass
    ``tight=False``: drawn once.
    """
    buf = io.BytesIO()
    crop = {"bbox_inches": "tight", "pad_inches": 0.1} if tight else {}
    fig.savefig(buf, format="png", dpi=DPI, pil_kwargs={"compress_level": PNG_COMPRESS_LEVEL}, **crop)
    if fig.canvas.manager is not None:  # made by pyplot, which keeps it until closed
        import matplotlib.pyplot as plt

        plt.close(fig)
    return buf.getvalue()
