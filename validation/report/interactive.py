"""The report's interactive figures: plotly.js figures (``{"data": [...], "layout": {...}}``) for HTML.

Each function takes the arguments of its static twin in :mod:`.plots` and returns the figure as JSON text,
written directly in the plotly.js schema (https://plotly.com/javascript/reference/ names every key): no
Python figure objects are made, so an interactive figure costs a few milliseconds, against a quarter of a
second or more to draw and rasterise the static one.  The page embeds plotly.js once
(:func:`plotly_js`) and draws each figure when it scrolls into view (``validation/templates/report.html.j2``).

Curves travel as little-endian float32 in base64 (plotly.js typed arrays, ``{"dtype": "f4", "bdata": ...}``:
5.3 characters a value against ~20 as JSON text, 7 significant digits, NaN kept as a gap); a uniform crank-
angle grid as its start and step (``x0``, ``dx``).  Every trace of a sweep or difference figure carries its
engine in ``meta``, which the page's engine switches use to hide and show an engine in every figure at once; a
legend entry toggles one (case, engine) series in every panel of its figure.

* :func:`sweep_plot`: per sweep and load mode, the reference as lines, the judges as markers, dead centres
  as dotted verticals (one legend entry toggles them), values beyond the initial axis range as triangles
  on its edge whose hover gives the value (a double click shows every value);
* :func:`difference_plot`: per judge, the relative difference against the crank angle, log scale;
* :func:`heatmap_plot`: per judge, the ratio to tolerance per case and quantity (:data:`.plots.RATIO_SCALE`);
* :func:`shaking_force_plot`: the balancing section's polar plot of the shaking force;
* a case's engine overlay (a linkage's): :func:`.overlay.overlay_plot`, beside its static twin.
"""

from __future__ import annotations

import base64
import json
import math
from typing import Any

import numpy as np

from dualmech.core.status import Status, is_status
from dualmech.core.table import ResultTable
from dualmech.models.units import axis_label, column_unit
from dualmech.validation.report.plots import (
    CRANK_TICKS,
    JUDGE_STRIDE,
    LOG_FLOOR,
    RATIO_SCALE,
    axis_range,
    flat_note,
    heatmap_ratios,
    polar_components,
    ratio_colour_stops,
    ratio_ticks,
)

#: Pixel size of one panel of a sweep figure (width, height) and of the margins around the panels.
PANEL_PX = (400, 260)
MARGIN_PX = {"l": 70, "r": 20, "t": 60, "b": 50}
#: Line colours of the cases: black for the base case, then matplotlib's tab10 (as the static figures).
CASE_COLOURS = ("#000000", "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2",
                "#7f7f7f", "#bcbd22", "#17becf")
#: plotly.js marker symbols of the judges, in the static figures' order (o, x, +, s, ^, v, d).
JUDGE_SYMBOLS = ("circle-open", "x-thin-open", "cross-thin-open", "square-open", "triangle-up-open",
                 "triangle-down-open", "diamond-open")
#: Thickness of the heat maps' colour bar (pixels).
COLOUR_BAR_PX = 25
#: A grid of crank angles whose steps agree to this relative difference is sent as its start and step.
UNIFORM_STEP = 1e-9
#: Hover text of every line and marker of a sweep figure (set once, in the layout's template): the series,
#: the crank angle, and the value with the panel's axis title (the column and its unit).
SWEEP_HOVER = "%{fullData.name}<br>θ1 = %{x}<br>%{yaxis.title.text} = %{y:.7g}<extra></extra>"
#: Crank-angle axis of every panel.
CRANK_AXIS = {"range": [0, 360], "tickvals": list(CRANK_TICKS), "ticksuffix": "°", "zeroline": False}


def plotly_js() -> str:
    """The plotly.js bundle that the ``plotly`` package ships (minified, ~4.8 MB), to inline once per page."""
    from plotly.offline import get_plotlyjs

    return get_plotlyjs()


def script_json(figure: dict) -> str:
    """``figure`` as JSON text safe inside an HTML ``<script type="application/json">`` element."""
    text = json.dumps(figure, separators=(",", ":"), allow_nan=False)
    return text.replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026")


def _f4(values: np.ndarray) -> dict:
    """A plotly.js typed array of ``values`` as float32 (non-finite values as NaN: a gap)."""
    v = np.asarray(values, dtype=np.float64)
    v = np.where(np.isfinite(v), v, np.nan).astype("<f4")
    return {"dtype": "f4", "bdata": base64.b64encode(v.tobytes()).decode("ascii")}


def _xy(x: np.ndarray, y: np.ndarray) -> dict:
    """The x and y of a trace: a uniform x as ``x0``/``dx``, otherwise a typed array."""
    out: dict[str, Any] = {"y": _f4(y)}
    steps = np.diff(x)
    if len(x) > 1 and np.allclose(steps, steps[0], rtol=UNIFORM_STEP, atol=0.0):
        out.update(x0=float(x[0]), dx=float(steps[0]))
    elif len(x) == 1:
        out.update(x0=float(x[0]), dx=1.0)
    else:
        out["x"] = _f4(x)
    return out


def _grid_axes(grid: tuple[int, int], n_panels: int, size: tuple[int, int]) -> tuple[dict, list[str]]:
    """Layout axes of a ``grid`` of panels (row-major, the first ``n_panels`` used) in a figure of ``size``
    pixels; returns the layout's axes and each panel's axis suffix (``""``, ``"2"``, ...)."""
    rows, cols = grid
    width, height = size
    gap_x, gap_y = 60 / width, 90 / height
    w, h = (1 - gap_x * (cols - 1)) / cols, (1 - gap_y * (rows - 1)) / rows
    layout: dict[str, Any] = {}
    suffixes = []
    for k in range(n_panels):
        r, c = divmod(k, cols)
        s = "" if k == 0 else str(k + 1)
        x0, y1 = c * (w + gap_x), 1 - r * (h + gap_y)
        layout[f"xaxis{s}"] = {"domain": [x0, x0 + w], "anchor": f"y{s}", **CRANK_AXIS}
        layout[f"yaxis{s}"] = {"domain": [y1 - h, y1], "anchor": f"x{s}", "exponentformat": "e"}
        suffixes.append(s)
    return layout, suffixes


def sweep_plot(
    title: str,
    columns: tuple[str, ...],
    grid: tuple[int, int],
    cases: list[tuple[str, dict[str, ResultTable]]],
    reference: str,
    judges: tuple[str, ...],
    torque: bool,
    units: str = "consistent",
) -> str:
    """The interactive twin of :func:`.plots.sweep_figure` (same arguments), as JSON text."""
    rows, cols = grid
    size = (PANEL_PX[0] * cols + MARGIN_PX["l"] + MARGIN_PX["r"],
            PANEL_PX[1] * rows + MARGIN_PX["t"] + MARGIN_PX["b"] + 40 * rows)
    layout, suffixes = _grid_axes(grid, len(columns), size)
    data: list[dict] = []
    shapes: list[dict] = []
    annotations: list[dict] = []
    listed: set[str] = set()  # the legend's entries so far
    tables = [t for _, per in cases for t in per.values()]
    for col, s in zip(columns, suffixes):
        unit = column_unit(col, units)
        xaxis, yaxis = layout[f"xaxis{s}"], layout[f"yaxis{s}"]
        yaxis["title"] = {"text": axis_label(col, units), "font": {"size": 11}}
        xaxis["title"] = {"text": "crank angle θ1 [deg]", "font": {"size": 11}}
        annotations.append(_panel_title(layout, s, f"<b>{col}</b>"))
        note = flat_note(tables, col, units)
        if note is not None:  # a panel without a trace: its axes are not drawn, the note says why
            annotations.append({"text": note.replace("\n", "<br>"), "xref": "paper", "yref": "paper",
                                "x": sum(xaxis["domain"]) / 2, "y": sum(yaxis["domain"]) / 2,
                                "showarrow": False})
            xaxis["visible"] = yaxis["visible"] = False
            continue
        lim = axis_range(tables, col, torque)
        if lim is not None:
            layout[f"yaxis{s}"]["range"] = list(lim)
        panel_data, panel_shapes = _panel_traces(col, s, cases, reference, judges, lim, unit, listed)
        data += panel_data
        shapes += panel_shapes
    layout.update(_base_layout(title, size, hover=SWEEP_HOVER), shapes=shapes, annotations=annotations,
                  legend={"orientation": "h", "x": 0, "y": -60 / size[1], "yanchor": "top",
                          "font": {"size": 10}})
    layout["margin"]["b"] = MARGIN_PX["b"] + 20 * math.ceil(len(cases) * (1 + len(judges)) / 4)
    layout["height"] = size[1] + layout["margin"]["b"] - MARGIN_PX["b"]
    return script_json({"data": data, "layout": layout})


def _panel_traces(col: str, suffix: str, cases: list[tuple[str, dict[str, ResultTable]]], reference: str,
                  judges: tuple[str, ...], lim: tuple[float, float] | None, unit: str, listed: set[str]
                  ) -> tuple[list[dict], list[dict]]:
    """The traces and dead-centre shapes of one panel of :func:`sweep_plot` (axes ``suffix``); a series is
    given a legend entry at its first trace (``listed``: the series listed so far, updated)."""
    axes = {"xaxis": f"x{suffix}", "yaxis": f"y{suffix}"}
    data: list[dict] = []
    shapes: list[dict] = []

    def series(name: str, engine: str, **trace: Any) -> dict:
        entry = {"type": "scatter", "name": name, "legendgroup": name, "showlegend": name not in listed,
                 "meta": engine, **axes, **trace}
        listed.add(name)
        return entry

    for i, (label, per) in enumerate(cases):
        colour = CASE_COLOURS[i % len(CASE_COLOURS)]
        ref = per.get(reference)
        if ref is not None:
            x, name = ref["theta1_deg"], f"{label} ({reference})"
            data.append(series(name, reference, mode="lines", line={"color": colour, "width": 1.5},
                               **_xy(x, ref[col])))
            data += _beyond(x, ref[col], lim, name, reference, colour, axes, col, unit)
            for a in x[is_status(ref.status, Status.DEAD_CENTRE)]:
                shapes.append(_dead_centre(float(a), colour, suffix, first="dead centres" not in listed))
                listed.add("dead centres")
        for j, e in enumerate(judges):
            t = per.get(e)
            if t is None:
                continue
            x = t["theta1_deg"]
            step = max(1, len(x) // JUDGE_STRIDE)
            sel = slice(j % step, None, step)
            marker = {"symbol": JUDGE_SYMBOLS[j % len(JUDGE_SYMBOLS)], "color": colour, "size": 6,
                      "line": {"width": 1.2, "color": colour}}
            name, y = f"{label} ({e})", t[col][sel]
            data.append(series(name, e, mode="markers", marker=marker, **_xy(x[sel], y)))
            data += _beyond(x[sel], y, lim, name, e, colour, axes, col, unit)
    return data, shapes


def _panel_title(layout: dict, suffix: str, text: str) -> dict:
    """The title of the panel on axes ``suffix``, above its top edge (in figure coordinates: a panel with
    no trace has no axes to refer to)."""
    return {"text": text, "xref": "paper", "yref": "paper", "x": sum(layout[f"xaxis{suffix}"]["domain"]) / 2,
            "y": layout[f"yaxis{suffix}"]["domain"][1], "yanchor": "bottom", "showarrow": False}


def _beyond(x: np.ndarray, y: np.ndarray, lim: tuple[float, float] | None, series: str, engine: str,
            colour: str, axes: dict, col: str, unit: str) -> list[dict]:
    """Triangles on the edge of the initial y range where ``y`` is beyond it, hovering the value (the
    static figures' :func:`.plots._draw_clipped`); none when every value is within."""
    if lim is None:
        return []
    lo, hi = lim
    above, below = np.isfinite(y) & (y > hi), np.isfinite(y) & (y < lo)
    if not (above.any() or below.any()):
        return []
    rows = above | below
    edge = np.where(above, hi, lo)[rows]
    symbols = np.where(above, "triangle-up", "triangle-down")[rows]
    return [{"type": "scatter", "mode": "markers", "name": series, "legendgroup": series, "showlegend": False,
             "meta": engine, "x": _f4(x[rows]), "y": _f4(edge), "customdata": _f4(y[rows]),
             "marker": {"symbol": symbols.tolist(), "color": colour, "size": 8}, "cliponaxis": False,
             "hovertemplate": (f"%{{fullData.name}}<br>θ1 = %{{x}}<br>{col} = %{{customdata:.7g}} {unit}"
                               "<br>(beyond the axis)<extra></extra>"), **axes}]


def _dead_centre(angle: float, colour: str, suffix: str, first: bool) -> dict:
    """A dotted vertical at a dead centre, across its panel; in the legend's "dead centres" group."""
    return {"type": "line", "xref": f"x{suffix}", "yref": f"y{suffix} domain", "x0": angle, "x1": angle,
            "y0": 0, "y1": 1, "layer": "below", "line": {"color": colour, "width": 1.2, "dash": "dot"},
            "name": "dead centres", "legendgroup": "dead centres", "showlegend": first}


def _base_layout(title: str, size: tuple[int, int], hover: str | None = None) -> dict:
    """The layout every figure starts from: title, size in pixels, margins; ``hover``: the hover text of
    every scatter trace that sets none (the layout's template)."""
    layout = {"title": {"text": title, "x": 0.5, "font": {"size": 14}}, "width": size[0], "height": size[1],
              "margin": dict(MARGIN_PX), "hovermode": "closest", "plot_bgcolor": "white",
              "paper_bgcolor": "white", "font": {"family": "sans-serif", "size": 11}}
    if hover is not None:
        layout["template"] = {"data": {"scatter": [{"hovertemplate": hover}]}}
    return layout


def difference_plot(
    engine: str,
    rows: dict[str, list[tuple[str, np.ndarray, np.ndarray, np.ndarray]]],
    tolerances: tuple[float, float],
) -> str:
    """Relative difference of one judge against the crank angle on a log scale, as JSON text.

    Parameters
    ----------
    rows : dict
        Load mode -> list of (case id, theta1_deg, worst kinematic r_i, worst reaction r_i), each (n,).
    tolerances : (float, float)
        Kinematic and reaction tolerance (drawn as dashed lines; the strictest if they vary).
    """
    modes = tuple(rows)
    size = (2 * PANEL_PX[0] + 300, (PANEL_PX[1] + 70) * len(modes) + MARGIN_PX["t"] + MARGIN_PX["b"])
    layout, suffixes = _grid_axes((len(modes), 2), 2 * len(modes), size)
    data: list[dict] = []
    shapes: list[dict] = []
    annotations: list[dict] = []
    for m, mode in enumerate(modes):
        for k, (what, tol) in enumerate(zip(("kinematics", "reactions"), tolerances)):
            s = suffixes[2 * m + k]
            layout[f"yaxis{s}"].update(type="log", exponentformat="power",
                                       title={"text": "relative difference r [1]", "font": {"size": 11}})
            layout[f"xaxis{s}"]["title"] = {"text": "crank angle θ1 [deg]", "font": {"size": 11}}
            annotations.append(_panel_title(layout, s, f"<b>{mode} mode: {what}</b> (worst column per row)"))
            for i, (cid, x, kin, rea) in enumerate(rows[mode]):
                y = kin if k == 0 else rea
                y = np.where(np.isfinite(y), np.maximum(y, LOG_FLOOR), np.where(np.isinf(y), 1e3, np.nan))
                data.append({"type": "scatter", "mode": "lines", "name": cid, "legendgroup": cid,
                             "showlegend": m == 0 and k == 0, "meta": engine,
                             "line": {"color": CASE_COLOURS[1 + i % 10], "width": 1.2},
                             "xaxis": f"x{s}", "yaxis": f"y{s}", **_xy(x, y),
                             "hovertemplate": f"{cid}<br>θ1 = %{{x}}<br>r = %{{y:.3e}}<extra></extra>"})
            shapes.append({"type": "line", "xref": f"x{s} domain", "yref": f"y{s}", "x0": 0, "x1": 1,
                           "y0": tol, "y1": tol, "line": {"color": "red", "dash": "dash", "width": 1.5},
                           "name": "tolerance", "legendgroup": "tolerance", "showlegend": not shapes})
    layout.update(_base_layout(f"{engine} against the reference: relative difference per crank position",
                               size), shapes=shapes, annotations=annotations,
                  legend={"x": 1.02, "y": 1, "font": {"size": 9}})
    layout["margin"]["r"] = 280
    return script_json({"data": data, "layout": layout})


def heatmap_plot(
    engine: str, cases: list[str], quantities: list[str], ratios: np.ndarray, failed: np.ndarray,
    max_rel: np.ndarray, tolerance: np.ndarray,
) -> str:
    """The interactive twin of :func:`.plots.heatmap_figure`: the ratio to tolerance per case and quantity
    on the two-part scale of :data:`.plots.RATIO_SCALE`; hover gives the ratio, the relative difference
    and the tolerance; failures marked ✗.  Arrays of shape ``(len(cases), len(quantities))``."""
    z = heatmap_ratios(ratios)
    lo, hi = RATIO_SCALE
    ticks, labels = ratio_ticks()
    custom = np.stack([ratios, max_rel, tolerance], axis=-1)
    size = (max(600, 28 * len(quantities) + 360), 24 * len(cases) + 220)
    data: list[dict] = [{
        "type": "heatmap", "x": quantities, "y": cases, "z": _nulls(z), "zmin": math.log10(lo),
        "zmax": math.log10(hi), "colorscale": ratio_colour_stops(), "customdata": _nulls(custom),
        "xgap": 1, "ygap": 1,
        "colorbar": {"title": {"text": "ratio to tolerance [1]", "side": "right"}, "tickvals": ticks,
                     "ticktext": labels, "len": 1, "y": 0, "yanchor": "bottom", "ypad": 0, "x": 1.02,
                     "xanchor": "left", "xpad": 0, "thickness": COLOUR_BAR_PX},
        "hovertemplate": ("case %{y}<br>%{x}<br>ratio to tolerance %{customdata[0]:.3g}"
                          "<br>relative difference %{customdata[1]:.3g}<br>tolerance %{customdata[2]:.3g}"
                          "<extra></extra>"),
    }]
    bad_i, bad_j = np.nonzero(failed)
    if bad_i.size:
        data.append({"type": "scatter", "mode": "text", "x": [quantities[j] for j in bad_j],
                     "y": [cases[i] for i in bad_i], "text": ["✗"] * bad_i.size, "name": "out of tolerance",
                     "textfont": {"color": "black", "size": 14}, "hoverinfo": "skip"})
    layout = _base_layout(f"{engine}: ratio to tolerance per case and quantity (> 1 fails)", size)
    margin = {"l": 190, "r": 140, "t": 50, "b": 130}
    boundary = -math.log10(lo) / (math.log10(hi) - math.log10(lo))  # ratio 1 on the colour bar
    bar_end = 1.02 + (COLOUR_BAR_PX + 6) / (size[0] - margin["l"] - margin["r"])
    layout.update(xaxis={"title": {"text": "quantity (output column)"}, "tickangle": -60, "type": "category"},
                  yaxis={"title": {"text": "case"}, "autorange": "reversed", "type": "category"},
                  margin=margin,
                  shapes=[{"type": "line", "xref": "paper", "yref": "paper", "x0": 1.01, "x1": bar_end,
                           "y0": boundary, "y1": boundary, "line": {"color": "black", "width": 3}}])
    return script_json({"data": data, "layout": layout})


def _nulls(values: np.ndarray) -> list:
    """A nested list of ``values`` with NaN as None (JSON null: plotly.js's gap)."""
    return np.where(np.isfinite(values), values, None).tolist()


def shaking_force_plot(forces: tuple[np.ndarray, np.ndarray], name: str, units: str) -> str:
    """The interactive twin of :func:`.plots.shaking_force_figure` (same arguments), as JSON text."""
    unit = column_unit("j1_fx", units)
    suffix = f" {unit}" if unit else ""
    data = []
    for f, label, dash in zip(forces, ("original", "balanced"), ("solid", "dash")):
        r, theta, peak = polar_components(f)
        data.append({"type": "scatterpolar", "mode": "lines", "r": _f4(r), "theta": _f4(theta),
                     "name": f"{label}: peak |f| = {peak:.3g}{suffix}", "line": {"dash": dash, "width": 2},
                     "hovertemplate": f"{label}<br>|f_xy| = %{{r:.5g}}{suffix}<br>direction %{{theta:.1f}}°"
                                      "<extra></extra>"})
    layout = _base_layout(f"shaking force on the frame, {name}: x-y components", (560, 560))
    layout.update(polar={"radialaxis": {"title": {"text": f"|f_xy| [{unit or 'force unit'}]"},
                                        "exponentformat": "e"},
                         "angularaxis": {"ticksuffix": "°"}},
                  legend={"x": 0, "y": -0.12, "yanchor": "top"}, margin={"l": 60, "r": 60, "t": 60, "b": 80})
    layout["height"] = 600
    return script_json({"data": data, "layout": layout})
