"""The report's figures drawn with matplotlib (Agg), each returned as PNG bytes.

* :func:`sweep_figure`: per sweep and load mode, the thesis's figs. 5-38 regenerated from the in-house
  engine, each judge overlaid as markers: slider displacement ``S4``, every joint force and moment
  component (world axes, ``docs/conventions.md``), the slider load and the drive torque, against the
  crank angle, the base (ideal) case in each. Dead-centre positions are marked with dotted vertical
  lines; values beyond the axis range (the ``1/t`` spikes beside a dead centre) are drawn as triangles
  on the axis edge -- never silently removed;
* :func:`heatmap_figure`: per judge, the ratio to tolerance per case and quantity, on a two-part colour
  scale that changes at the pass/fail boundary (ratio 1, :data:`RATIO_SCALE`);
* :func:`shaking_force_figure`: the balancing section's polar plot of the shaking force.

The report's interactive figures (:mod:`.interactive`) share this module's choices: axis ranges, flat panels,
judge markers, the ratio scale.
"""

from __future__ import annotations

import base64
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from dualmech.core.status import Status, is_status
from dualmech.core.table import NUMERIC_COLUMNS, REACTION_COLUMNS, ResultTable
from dualmech.models.units import DIMENSIONS, axis_label, column_unit
from dualmech.validation.compare import Comparison
from dualmech.validation.report.canvas import autoscale_y_visible, fig_to_png, kept_line, new_figure, skeleton

#: Rows with |transmission| below this set no axis range in torque mode (their reactions
#: are the 1/t spikes beside a dead centre); they are still drawn, at the edge if beyond it.
AXIS_RANGE_TRANSMISSION = 0.1
#: Floor of the log-scale difference plots (exact agreement is drawn here).
LOG_FLOOR = 1e-17
#: A panel is drawn as a line of text when its spread is below this fraction of its size (a constant),
#: or its size below this fraction of the case's largest value of the same dimension (round-off of zero).
FLAT_RELATIVE = 1e-9
JUDGE_MARKERS = ("o", "x", "+", "s", "^", "v", "d")
#: A judge is drawn as about this many markers per curve (every step-th row), the reference as a line.
JUDGE_STRIDE = 36
#: Range of the heat maps' ratio-to-tolerance scale (log): ratios beyond it take its end colours.  Below 1
#: (pass) the scale runs from dark blue (1e-6: far inside the tolerance) to pale yellow-green; at 1 it
#: jumps to orange-red and darkens to 100 times the tolerance (fail).
RATIO_SCALE = (1e-6, 1e2)
#: The two parts of the ratio scale: (matplotlib colormap, its first and last fraction used), pass then fail.
RATIO_PARTS = (("YlGnBu_r", 0.0, 0.85), ("Reds", 0.5, 1.0))
#: Panel titles sit at the top of their axes (matplotlib would otherwise measure every tick label of
#: the panel at each draw to see whether an offset text is in the way; a panel's title is short and
#: centred, its offset text at the left edge).
TITLE_Y = 1.0
#: Crank-angle ticks of every panel (deg).
CRANK_TICKS = (0, 90, 180, 270, 360)


@dataclass(frozen=True)
class Figure:
    """One made figure: interactive, and drawn as PNG if the Markdown report shows it."""

    key: str  # file stem under figures/ (and the HTML element's id)
    section: str  # "sweep", "difference", "heatmap", "balancing" or "case"
    group: str  # the sweep's name, the judge's, or the case's
    title: str
    caption: str
    png: bytes | None  # None: interactive only
    plot: str | None = None  # the interactive figure: plotly.js JSON, safe inside a <script> element

    @property
    def data_uri(self) -> str:
        """The PNG as a ``data:`` URI."""
        if self.png is None:
            raise ValueError(f"figure {self.key!r} has no PNG: it is interactive only")
        return "data:image/png;base64," + base64.b64encode(self.png).decode("ascii")


def axis_range(tables: list[ResultTable], column: str, torque: bool) -> tuple[float, float] | None:
    """The y range of ``column``'s panel: every finite value (in torque mode, of a reaction, those of rows
    with |transmission| >= :data:`AXIS_RANGE_TRANSMISSION`), padded; None if there is none."""
    vals = []
    for t in tables:
        v = t[column]
        rows = np.isfinite(v)
        if torque and column in REACTION_COLUMNS:
            rows &= np.abs(t["transmission"]) >= AXIS_RANGE_TRANSMISSION
        vals.append(v[rows])
    v = np.concatenate(vals) if vals else np.array([])
    if not v.size:
        return None
    lo, hi = float(v.min()), float(v.max())
    pad = 0.08 * (hi - lo) if hi > lo else max(1e-9, 0.05 * abs(hi)) or 1.0
    return lo - pad, hi + pad


def flat_note(tables: list[ResultTable], column: str, units: str) -> str | None:
    """A line that replaces a panel whose curve would show nothing: a constant, or round-off of zero.

    Constant: the spread of the values is below :data:`FLAT_RELATIVE` of their size.
    Round-off: every value is below :data:`FLAT_RELATIVE` of the largest value of any
    column of the same dimension in these tables (e.g. a planar case's out-of-plane moments).
    """
    dimension = DIMENSIONS[column]
    values = np.concatenate([t[column][np.isfinite(t[column])] for t in tables]) if tables else np.array([])
    if not values.size:
        return None
    peer = [
        np.abs(t[c][np.isfinite(t[c])]).max(initial=0.0)
        for t in tables
        for c in NUMERIC_COLUMNS
        if DIMENSIONS.get(c) == dimension and c != "residual"
    ]
    size, scale = float(np.abs(values).max()), max(peer, default=0.0)
    unit = column_unit(column, units)
    if size <= FLAT_RELATIVE * scale:
        return (f"zero to round-off:\n|{column}| <= {size:.1e} {unit}\n"
                f"(< {FLAT_RELATIVE:g} of the case's largest)")
    if float(values.max() - values.min()) <= FLAT_RELATIVE * size:
        return f"constant:\n{column} = {float(np.median(values)):.9g} {unit}"
    return None


def _draw_clipped(ax: Any, x: np.ndarray, y: np.ndarray, lim: tuple[float, float], color: Any) -> None:
    lo, hi = lim
    above, below = np.isfinite(y) & (y > hi), np.isfinite(y) & (y < lo)
    if above.any():
        ax.plot(x[above], np.full(above.sum(), hi), "^", color=color, ms=5, clip_on=False, zorder=5)
    if below.any():
        ax.plot(x[below], np.full(below.sum(), lo), "v", color=color, ms=5, clip_on=False, zorder=5)


def sweep_figure(
    title: str,
    columns: tuple[str, ...],
    grid: tuple[int, int],
    cases: list[tuple[str, dict[str, ResultTable]]],
    reference: str,
    judges: tuple[str, ...],
    torque: bool,
    units: str = "consistent",
) -> bytes:
    """One figure of a sweep: ``columns`` against the crank angle, the reference as lines, judges as markers.

    Every axis says its quantity and unit (``units``: the cases' unit label,
    :mod:`dualmech.models.units`); tick labels never use an offset; a column that is
    constant or round-off of zero is stated in a line of text instead of drawn.

    Parameters
    ----------
    cases : list of (legend label, {engine: table})
        The sweep's cases, base case first.
    """
    from matplotlib import colormaps

    nrows, ncols = grid
    n_labels = len(cases) * (1 + len(judges))
    legend_in = 0.16 * math.ceil(n_labels / 4) + 0.15
    figsize = (4.2 * ncols + 0.8, 2.9 * nrows + 0.9 + legend_in)
    fig = skeleton(("sweep", grid, columns, units), figsize,
                   lambda fig: _sweep_axes(fig, grid, columns, units))
    panels = fig.axes[: len(columns)]
    colors = ["black"] + [colormaps["tab10"](i) for i in range(10)]
    for ax, col in zip(panels, columns):
        _sweep_panel(ax, col, cases, reference, judges, torque, units, colors)
    handles, labels = panels[0].get_legend_handles_labels()
    suptitle = fig.suptitle(title, fontsize=11)
    height = fig.get_figheight()
    legend_in = 0.16 * math.ceil(len(labels) / 4) + 0.15
    legend = fig.legend(
        handles, labels, loc="lower center", ncol=min(4, max(1, len(labels))), fontsize=7, frameon=False
    )
    _widen_to_fit(fig, (suptitle, legend))
    # fixed margins (inches -> figure fraction): tight_layout would cost a full extra draw
    fig.subplots_adjust(
        left=0.7 / fig.get_figwidth(),
        right=0.98,
        top=1 - 0.55 / height,
        bottom=(legend_in + 0.45) / height,
        hspace=0.3,  # room for the lower panels' titles: the upper ones show no crank-angle labels
        wspace=0.22,
    )
    return fig_to_png(fig, tight=False)


def _sweep_axes(fig: Any, grid: tuple[int, int], columns: tuple[str, ...], units: str) -> None:
    """The panels of a :func:`sweep_figure` without data: a framed axes per column, the grid's others off."""
    axes = list(fig.subplots(*grid, squeeze=False).flat)
    for k, (ax, col) in enumerate(zip(axes, columns)):
        _frame(ax, col, units)
        if k + grid[1] < len(columns):  # a panel below shows the same crank-angle axis
            ax.tick_params(labelbottom=False)
            ax.set_xlabel("")
    for ax in axes[len(columns) :]:
        ax.axis("off")


def _widen_to_fit(fig: Any, artists: tuple[Any, ...], pad_in: float = 0.2) -> None:
    """Widen ``fig`` to the widest of ``artists`` (a legend, a title: their size is set in points) plus
    ``pad_in`` inches, so that nothing is cut off the saved image (one panel and many legend entries)."""
    renderer = fig.canvas.get_renderer()
    need = max(a.get_window_extent(renderer).width for a in artists) / fig.dpi + pad_in
    if need > fig.get_figwidth():
        fig.set_figwidth(need)


def _sweep_panel(
    ax: Any,
    col: str,
    cases: list[tuple[str, dict[str, ResultTable]]],
    reference: str,
    judges: tuple[str, ...],
    torque: bool,
    units: str,
    colors: list[Any],
) -> None:
    """One panel of :func:`sweep_figure` (framed by :func:`_frame`): column ``col`` of every case, or the
    line saying it is flat."""
    from matplotlib.ticker import AutoLocator

    tabs = [t for _, per in cases for t in per.values()]
    note = flat_note(tabs, col, units)
    if note is not None:
        ax.text(0.5, 0.5, note, transform=ax.transAxes, ha="center", va="center", fontsize=8, wrap=True)
        ax.set_yticks([])
        return
    ax.yaxis.set_major_locator(AutoLocator())  # the panel may have been a flat one of an earlier figure
    lim = axis_range(tabs, col, torque)
    for i, (label, per) in enumerate(cases):
        color = colors[i % len(colors)]
        ref = per.get(reference)
        if ref is not None:
            x = ref["theta1_deg"]
            kept_line(ax, ("reference", i), x, ref[col], linestyle="-", marker="None", color=color,
                      linewidth=1.3, label=f"{label} ({reference})")
            if lim is not None:
                _draw_clipped(ax, x, ref[col], lim, color)
            for a in x[is_status(ref.status, Status.DEAD_CENTRE)]:
                ax.axvline(a, color=color, ls=":", lw=1.0, zorder=1.5)  # beneath every curve
        for j, e in enumerate(judges):
            t = per.get(e)
            if t is None:
                continue
            x = t["theta1_deg"]
            step = max(1, len(x) // JUDGE_STRIDE)
            sel = slice(j % step, None, step)
            kept_line(ax, ("judge", i, j), x[sel], t[col][sel], linestyle="None",
                      marker=JUDGE_MARKERS[j % len(JUDGE_MARKERS)], color=color, markersize=4,
                      markerfacecolor="none", label=f"{label} ({e})" if i == 0 else "_nolegend_")
            if lim is not None:
                _draw_clipped(ax, x[sel], t[col][sel], lim, color)
    if lim is not None:
        ax.set_ylim(*lim)
    else:  # nothing finite to show
        autoscale_y_visible(ax)


def _frame(ax: Any, column: str, units: str) -> None:
    """Title, axis labels with units, plain tick labels (no offset or scientific multiplier) of one panel."""
    ax.set_title(column, fontsize=10, y=TITLE_Y)
    ax.set_xlim(0, 360)
    ax.set_xticks(CRANK_TICKS)
    ax.grid(True, alpha=0.3)
    ax.set_xlabel("crank angle theta1 [deg]", fontsize=8)
    ax.set_ylabel(axis_label(column, units), fontsize=8)
    ax.tick_params(labelsize=8)
    ax.ticklabel_format(axis="y", useOffset=False, style="sci", scilimits=(-3, 4))


def ratio_colormap() -> Any:
    """The heat maps' colormap over log10 of :data:`RATIO_SCALE`: :data:`RATIO_PARTS` joined at ratio 1."""
    from matplotlib import colormaps
    from matplotlib.colors import ListedColormap

    lo, hi = (math.log10(v) for v in RATIO_SCALE)
    n_pass = round(256 * -lo / (hi - lo))
    parts = zip(RATIO_PARTS, (n_pass, 256 - n_pass))
    colours = [colormaps[name](np.linspace(a, b, n)) for (name, a, b), n in parts]
    return ListedColormap(np.concatenate(colours), name="ratio_to_tolerance")


def ratio_colour_stops() -> list[list]:
    """:func:`ratio_colormap` as plotly.js colour-scale stops: each part by its ends and middle, the jump at
    ratio 1 as two stops at the same place."""
    from matplotlib import colormaps
    from matplotlib.colors import to_hex

    lo, hi = (math.log10(v) for v in RATIO_SCALE)
    boundary = -lo / (hi - lo)
    stops = []
    for (name, a, b), (start, end) in zip(RATIO_PARTS, ((0.0, boundary), (boundary, 1.0))):
        for f in np.linspace(0.0, 1.0, 5):
            stops.append([start + f * (end - start), to_hex(colormaps[name](a + f * (b - a)))])
    return stops


def ratio_ticks() -> tuple[list[float], list[str]]:
    """Ticks of the ratio scale's colour bar: log10 of each decade of :data:`RATIO_SCALE`, labelled with the
    ratio, the boundary as "1 = tolerance"."""
    lo, hi = (round(math.log10(v)) for v in RATIO_SCALE)
    ticks = [float(k) for k in range(lo, hi + 1)]
    return ticks, ["1 = tolerance" if k == 0 else f"1e{k:+d}".replace("+", "") for k in range(lo, hi + 1)]


def heatmap_ratios(ratios: np.ndarray) -> np.ndarray:
    """log10 of ``ratios`` clipped to :data:`RATIO_SCALE` (0, exact agreement, at its floor); NaN stays NaN
    (not compared)."""
    lo, hi = RATIO_SCALE
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.log10(np.clip(ratios, lo, hi))


#: The caption of a judge's heat map (:func:`heatmap_figure`; a slider-crank report's and a linkage run's).
HEATMAP_CAPTION = ("Ratio of the worst relative difference to its tolerance: blue to pale below 1 (pass), "
                   "red above (fail), the boundary marked on the colour bar; ✗: out of tolerance (a whole "
                   "row: a status or the engine failed); grey: not compared.")


def heatmap_arrays(comparison: Comparison, engine: str, cases: list[str], quantities: list[str]
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A judge's heat map (:func:`heatmap_figure`): per case and quantity its ratio to tolerance,
    whether it failed, its worst relative difference and its tolerance, each ``(len(cases),
    len(quantities))``, NaN where not compared; a failed check of another quantity (a status, the engine)
    fails the case's whole row."""
    ratios, max_rel, tolerance = (np.full((len(cases), len(quantities)), np.nan) for _ in range(3))
    failed = np.zeros((len(cases), len(quantities)), dtype=bool)
    for i, cid in enumerate(cases):
        for c in comparison.for_engine(cid, engine):
            if c.quantity in quantities:
                j = quantities.index(c.quantity)
                ratios[i, j], max_rel[i, j], tolerance[i, j] = c.ratio, c.max_rel, c.tolerance.value
                failed[i, j] = not c.passed
            elif not c.passed:  # status or engine failure: the whole row
                failed[i, :] = True
    return ratios, failed, max_rel, tolerance


def heatmap_figure(
    engine: str, cases: list[str], quantities: list[str], ratios: np.ndarray, failed: np.ndarray,
    max_rel: np.ndarray, tolerance: np.ndarray,
) -> bytes:
    """Heat map of the ratio to tolerance (worst relative difference / tolerance), cases x quantities.

    Coloured on :func:`ratio_colormap`: blue to pale below 1 (pass), red above (fail), the boundary drawn
    across the colour bar; failures (also of a status or an engine: the whole row) boxed in red with a ✗.
    Arrays have shape ``(len(cases), len(quantities))``; NaN = not compared (grey).  ``max_rel`` and
    ``tolerance`` are the interactive twin's (:func:`.interactive.heatmap_plot`) hover values.
    """
    from matplotlib.patches import Rectangle

    del max_rel, tolerance  # the static figure shows the ratio only
    fig = new_figure((0.36 * len(quantities) + 4.6, 0.3 * len(cases) + 2.4))
    ax = fig.subplots()
    ax.set_facecolor("#d9d9d9")  # not compared
    lo, hi = (math.log10(v) for v in RATIO_SCALE)
    im = ax.imshow(np.ma.masked_invalid(heatmap_ratios(ratios)), cmap=ratio_colormap(), aspect="auto",
                   vmin=lo, vmax=hi, interpolation="nearest")
    for i, j in zip(*np.nonzero(failed)):
        ax.add_patch(Rectangle((j - 0.5, i - 0.5), 1, 1, fill=False, ec="red", lw=2))
        ax.text(j, i, "✗", ha="center", va="center", color="black", fontsize=8)
    ax.set_xticks(range(len(quantities)), quantities, rotation=70, fontsize=7)
    ax.set_yticks(range(len(cases)), cases, fontsize=7)
    ax.set_xlabel("quantity (output column)", fontsize=8)
    ax.set_ylabel("case", fontsize=8)
    bar = fig.colorbar(im, ax=ax, label="ratio to tolerance [1] (log scale)")
    ticks, labels = ratio_ticks()
    bar.set_ticks(ticks, labels=labels, fontsize=7)
    bar.ax.axhline(0.0, color="black", lw=2.5)  # the pass/fail boundary
    ax.set_title(f"{engine}: ratio to tolerance per case and quantity (> 1 fails)", fontsize=10, y=TITLE_Y)
    w, h = fig.get_figwidth(), fig.get_figheight()
    fig.subplots_adjust(left=1.9 / w, right=1 - 0.3 / w, top=1 - 0.4 / h, bottom=1.3 / h)
    return fig_to_png(fig, tight=False)


def polar_components(force: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """The shaking force ``(m, 3)`` in its x-y plane: magnitude ``(m,)``, direction in degrees ``(m,)``, and
    the peak of the full magnitude |f|."""
    return (np.hypot(force[:, 0], force[:, 1]), np.degrees(np.arctan2(force[:, 1], force[:, 0])),
            float(np.linalg.norm(force, axis=1).max()))


def shaking_force_figure(forces: tuple[np.ndarray, np.ndarray], name: str, units: str) -> bytes:
    """Polar plot of the shaking force on the frame (its x-y components, ``forces``: original, then balanced,
    each ``(m, 3)``), the radial axis and the peaks in the case's force unit (``units``: its unit label)."""
    unit = column_unit("j1_fx", units)
    suffix = f" {unit}" if unit else ""
    fig = new_figure((6.0, 6.4))
    ax = fig.add_subplot(projection="polar")
    for f, label, style in zip(forces, ("original", "balanced"), ("-", "--")):
        r, theta, peak = polar_components(f)
        ax.plot(np.radians(theta), r, style, lw=1.5, label=f"{label}: peak |f| = {peak:.3g}{suffix}")
    ax.set_title(f"shaking force on the frame, {name}: x-y components", fontsize=10)
    ax.text(np.radians(22.5), ax.get_rmax() * 1.2, f"|f_xy| [{unit or 'force unit'}]", fontsize=8,
            ha="center")
    ax.tick_params(labelsize=8)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.06), fontsize=9, frameon=False)
    fig.subplots_adjust(left=0.1, right=0.9, top=0.88, bottom=0.16)
    return fig_to_png(fig, tight=False)
