"""The engine-overlay figure of one case: its output from every engine against the input, and below it each
judge's worst ratio to tolerance per row (log scale; at most 1 passes).

The report's figure of a case without sweeps (the RSSR, RCCC and loop tables,
:mod:`dualmech.validation.report.tables`): :func:`overlay_figure` draws it as PNG (the Markdown report),
:func:`overlay_plot` as a plotly.js figure (the HTML page, as :mod:`.interactive`'s); both take the same
arguments, the planned figure's job (:mod:`.figures`, kind ``"case"``).

``curves`` are ``(engine, x, y, ratio_x, ratio)``: the engine's input values and output ``(n,)`` (``None``
for an engine that failed), the rows where a judge was compared and its worst ratio there (``None`` for the
reference, or a judge not compared); the first is the reference, drawn as a line, the judges as markers.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from dualmech.validation.report.canvas import fig_to_png, new_figure
from dualmech.validation.report.interactive import (
    CASE_COLOURS,
    JUDGE_SYMBOLS,
    _base_layout,
    _f4,
    script_json,
)
from dualmech.validation.report.plots import JUDGE_MARKERS, LOG_FLOOR

#: One curve of the figure (module docstring).
Curve = tuple[str, Any, Any, Any, Any]
#: Size of the interactive figure (pixels) and the share of its height the output panel takes.
OVERLAY_PX, TOP_SHARE = (760, 620), 0.55


def overlay_figure(title: str, x_label: str, y_label: str, curves: tuple[Curve, ...]) -> bytes:
    """The figure (module docstring) as PNG bytes."""
    import matplotlib

    colours = [matplotlib.colormaps["tab10"](i) for i in range(10)]
    fig = new_figure((7.0, 5.6))
    top, bottom = fig.subplots(2, 1, sharex=True)
    for j, (engine, x, y, ratio_x, ratio) in enumerate(curves):
        style = {"color": colours[(j - 1) % 10], "ms": 4, "ls": "none", "mfc": "none"}
        marker = JUDGE_MARKERS[(j - 1) % len(JUDGE_MARKERS)]
        if x is not None and j == 0:
            top.plot(x, y, "-", color="black", lw=1.3, label=f"{engine} (reference)")
        elif x is not None:
            top.plot(x, y, marker, label=engine, **style)
        if ratio is not None:
            bottom.semilogy(ratio_x, np.clip(ratio, LOG_FLOOR, None), marker, label=engine, **style)
    bottom.axhline(1.0, color="#c62828", ls="--", lw=1.0, label="tolerance")
    top.set_ylabel(y_label, fontsize=8)
    top.set_title(title, fontsize=9)
    bottom.set_ylabel("worst |judge - ref| / (scale x tol)", fontsize=8)
    bottom.set_xlabel(x_label, fontsize=8)
    for ax in (top, bottom):
        ax.tick_params(labelsize=7)
        ax.legend(fontsize=7, loc="best")
    return fig_to_png(fig)


def overlay_plot(title: str, x_label: str, y_label: str, curves: tuple[Curve, ...]) -> str:
    """The interactive twin of :func:`overlay_figure` (same arguments), as JSON text; every trace carries its
    engine in ``meta`` (the page's engine switches)."""
    data: list[dict] = []
    for j, (engine, x, y, ratio_x, ratio) in enumerate(curves):
        colour = CASE_COLOURS[j % len(CASE_COLOURS)]
        hover = f"{engine}<br>{x_label} = %{{x:.6g}}<br>%{{y:.7g}}<extra></extra>"
        if x is not None:
            look = ({"mode": "lines", "line": {"color": colour, "width": 1.5}} if j == 0 else
                    {"mode": "markers", "marker": {"symbol": JUDGE_SYMBOLS[(j - 1) % len(JUDGE_SYMBOLS)],
                                                   "color": colour, "size": 6}})
            data.append({"type": "scatter", "name": f"{engine} (reference)" if j == 0 else engine,
                         "legendgroup": engine, "meta": engine, "x": _f4(x), "y": _f4(y),
                         "hovertemplate": hover, **look})
        if ratio is not None:
            data.append({"type": "scatter", "mode": "markers", "name": engine, "legendgroup": engine,
                         "showlegend": False, "meta": engine, "xaxis": "x2", "yaxis": "y2",
                         "x": _f4(ratio_x), "y": _f4(np.clip(ratio, LOG_FLOOR, None)), "hovertemplate": hover,
                         "marker": {"symbol": JUDGE_SYMBOLS[(j - 1) % len(JUDGE_SYMBOLS)], "color": colour,
                                    "size": 6}})
    gap = 0.08
    layout = _base_layout(title, OVERLAY_PX)
    layout.update(
        xaxis={"domain": [0, 1], "anchor": "y", "matches": "x2", "showticklabels": False},
        yaxis={"domain": [1 - TOP_SHARE, 1], "anchor": "x", "title": {"text": y_label}},
        xaxis2={"domain": [0, 1], "anchor": "y2", "title": {"text": x_label}},
        yaxis2={"domain": [0, 1 - TOP_SHARE - gap], "anchor": "x2", "type": "log", "exponentformat": "power",
                "title": {"text": "worst ratio to tolerance [1]"}},
        shapes=[{"type": "line", "xref": "x2 domain", "yref": "y2", "x0": 0, "x1": 1, "y0": 1.0, "y1": 1.0,
                 "line": {"color": "#c62828", "dash": "dash", "width": 1.5}}],
        legend={"orientation": "h", "x": 0, "y": -0.12, "yanchor": "top"})
    layout["margin"]["b"] = 110
    return script_json({"data": data, "layout": layout})
