"""The report's figures drawn with matplotlib (Agg), each returned as PNG bytes.

* :func:`sweep_figure`: per sweep and load mode, the thesis's figs. 5-38 regenerated from the in-house
  engine, each judge overlaid as markers: slider displacement ``S4``, every joint force and moment
  component (world axes, ``docs/conventions.md``), the slider load and the drive torque, against the
  crank angle, the base (ideal) case in each. Dead-centre positions are marked with dotted vertical
  lines; values beyond the axis range (the ``1/t`` spikes beside a dead centre) are drawn as triangles
  on the axis edge -- never silently removed;
* :func:`difference_figure`: per judge, the relative difference ``r_i``
  (:mod:`dualmech.validation.compare`) against the crank angle on a log scale, worst over kinematics
  and over reactions;
* :func:`heatmap_figure`: per judge, the worst relative difference per case and quantity;
* :func:`shaking_force_figure`: the balancing section's polar plot of the shaking force
  (:func:`dualmech.models.balancing.draw_shaking_force_polar`).
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
#: Panel titles sit at the top of their axes (matplotlib would otherwise measure every tick label of
#: the panel at each draw to see whether an offset text is in the way; a panel's title is short and
#: centred, its offset text at the left edge).
TITLE_Y = 1.0
#: Crank-angle ticks of every panel (deg).
CRANK_TICKS = (0, 90, 180, 270, 360)


@dataclass(frozen=True)
class Figure:
    """One rendered figure."""

    key: str  # file stem under figures/
    section: str  # "sweep", "difference" or "heatmap"
    group: str  # the sweep's name, or the judge's
    title: str
    caption: str
    png: bytes

    @property
    def data_uri(self) -> str:
        return "data:image/png;base64," + base64.b64encode(self.png).decode("ascii")


def _axis_range(tables: list[ResultTable], column: str, torque: bool) -> tuple[float, float] | None:
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


def _flat_note(tables: list[ResultTable], column: str, units: str) -> str | None:
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
    note = _flat_note(tabs, col, units)
    if note is not None:
        ax.text(0.5, 0.5, note, transform=ax.transAxes, ha="center", va="center", fontsize=8, wrap=True)
        ax.set_yticks([])
        return
    ax.yaxis.set_major_locator(AutoLocator())  # the panel may have been a flat one of an earlier figure
    lim = _axis_range(tabs, col, torque)
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
            step = max(1, len(x) // 36)
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


def difference_figure(
    engine: str,
    rows: dict[str, list[tuple[str, np.ndarray, np.ndarray, np.ndarray]]],
    tolerances: tuple[float, float],
) -> bytes:
    """Log-scale relative difference of one judge against the crank angle.

    Parameters
    ----------
    rows : dict
        Load mode -> list of (case id, theta1_deg, worst kinematic r_i, worst reaction r_i), each (n,).
    tolerances : (float, float)
        Kinematic and reaction tolerance (drawn as dashed lines; the strictest if they vary).
    """
    from matplotlib import colormaps

    modes = tuple(rows)
    figsize = (12, 3.2 * len(modes) + 0.6)
    fig = skeleton(("difference", modes), figsize, lambda fig: _difference_axes(fig, modes))
    cmap = colormaps["tab20"]
    for m, mode in enumerate(modes):
        for k, tol in enumerate(tolerances):
            ax = fig.axes[2 * m + k]
            for i, (cid, x, kin, rea) in enumerate(rows[mode]):
                y = kin if k == 0 else rea
                y = np.where(np.isfinite(y), np.maximum(y, LOG_FLOOR), np.where(np.isinf(y), 1e3, np.nan))
                ax.plot(x, y, "-", lw=0.9, color=cmap(i % 20), label=cid)
            ax.axhline(tol, color="red", ls="--", lw=1.0, label="tolerance")
            ax.legend(fontsize=6, ncol=2, loc="upper right")
    fig.suptitle(f"{engine} against the reference: relative difference per crank position", fontsize=11)
    fig.subplots_adjust(
        left=0.07,
        right=0.98,
        top=1 - 0.6 / fig.get_figheight(),
        bottom=0.55 / fig.get_figheight(),
        hspace=0.45,
        wspace=0.08,
    )
    return fig_to_png(fig, tight=False)


def _difference_axes(fig: Any, modes: tuple[str, ...]) -> None:
    """The panels of a :func:`difference_figure` without data: per load mode, kinematics and reactions on
    one shared log scale."""
    axes = fig.subplots(len(modes), 2, squeeze=False, sharey=True)
    for m, mode in enumerate(modes):
        for k, what in enumerate(("kinematics", "reactions")):
            ax = axes[m, k]
            ax.set_yscale("log")
            ax.set_xlim(0, 360)
            ax.set_xticks(CRANK_TICKS)
            ax.set_title(f"{mode} mode: {what} (worst column per row)", fontsize=10, y=TITLE_Y)
            ax.set_xlabel("crank angle theta1 [deg]", fontsize=8)
            ax.grid(True, which="major", alpha=0.3)
            ax.tick_params(labelsize=8)
    axes[0, 0].set_ylabel("relative difference r")


def heatmap_figure(
    engine: str, cases: list[str], quantities: list[str], values: np.ndarray, failed: np.ndarray
) -> bytes:
    """Heat map of log10(worst relative difference), cases x quantities; failures boxed in red.

    ``values`` and ``failed`` have shape ``(len(cases), len(quantities))``; NaN = not compared.
    """
    from matplotlib.patches import Rectangle

    fig = new_figure((0.36 * len(quantities) + 4.0, 0.3 * len(cases) + 2.2))
    ax = fig.subplots()
    with np.errstate(divide="ignore", invalid="ignore"):
        logv = np.log10(np.maximum(values, LOG_FLOOR))
    im = ax.imshow(np.ma.masked_invalid(logv), cmap="viridis", aspect="auto", vmin=-17, vmax=0)
    for i, j in zip(*np.nonzero(failed)):
        ax.add_patch(Rectangle((j - 0.5, i - 0.5), 1, 1, fill=False, ec="red", lw=2))
        ax.text(j, i, "✗", ha="center", va="center", color="red", fontsize=8)
    ax.set_xticks(range(len(quantities)), quantities, rotation=70, fontsize=7)
    ax.set_yticks(range(len(cases)), cases, fontsize=7)
    fig.colorbar(im, ax=ax, label="log10 max relative difference")
    ax.set_title(f"{engine}: worst relative difference per case and quantity", fontsize=10, y=TITLE_Y)
    w, h = fig.get_figwidth(), fig.get_figheight()
    fig.subplots_adjust(left=1.9 / w, right=1 - 0.2 / w, top=1 - 0.4 / h, bottom=1.1 / h)
    return fig_to_png(fig, tight=False)


def shaking_force_figure(forces: tuple[np.ndarray, np.ndarray], name: str, units: str) -> bytes:
    """PNG of :func:`~dualmech.models.balancing.draw_shaking_force_polar` (original, then balanced)."""
    import tempfile
    from pathlib import Path

    from dualmech.models.balancing import draw_shaking_force_polar

    with tempfile.TemporaryDirectory() as tmp:
        return draw_shaking_force_polar(forces, name, units, Path(tmp) / "shaking.png").read_bytes()
