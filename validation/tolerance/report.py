"""The report of a tolerance study: ``DIR/report.html`` (self-contained) and ``DIR/report.md``.

Sections: the yield; per output a histogram over the fully assembling designs with the
nominal value and the p99 marked; Monte Carlo against linear standard deviations; a tornado
chart of each key's share of the variance (first-order Sobol from the samples beside the
linear shares); the sensitivity table; the judges' spot checks.  Figures are matplotlib
(Agg) PNGs, embedded as data URIs in the HTML and written under ``DIR/figures/`` for the
Markdown, with the helpers of :mod:`dualmech.validation.report`.

Each figure is drawn once: its margins are set from the sizes of its labels, not found by a
tight layout and a tight bounding box (two more drawings of every tick label).  The figures
depend only on the samples and the statistics, not on the judges: :class:`FigureDrawing` draws
them in a spawned process while this one runs the spot checks (``parallel``), or here.
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from dualmech.core.thresholds import ROUND_OFF_RELATIVE
from dualmech.models.tolerance.outputs import DesignStatus
from dualmech.models.tolerance.summary import CONSTANT_RELATIVE
from dualmech.validation.rundir import locked, write_file

if TYPE_CHECKING:
    from dualmech.validation.report.plots import Figure

TEMPLATES = Path(__file__).resolve().parent.parent / "templates"
#: Histogram bins (at most; fewer for small studies).
HIST_BINS = 40
#: A histogram gets a logarithmic axis when its largest value exceeds the median this many times.
LOG_SPAN = 20.0
#: Resolution of the PNGs (dots per inch).
DPI = 80
#: Histogram margins (fractions of the figure): room for 6-digit counts, the y label, log-axis powers, the x
#: label.
HIST_MARGINS = {"left": 0.16, "right": 0.965, "bottom": 0.2, "top": 0.88}
#: Tornado margins in inches: below (tick labels and x label), above (title), right, and beside the keys.
TORNADO_BELOW, TORNADO_ABOVE, TORNADO_RIGHT, TORNADO_KEY_PAD = 0.56, 0.33, 0.25, 0.2


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _png(fig: Any) -> bytes:
    """The figure as PNG bytes at :data:`DPI` (one drawing), closed."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI)
    _pyplot().close(fig)
    return buf.getvalue()


def histogram_figure(name: str, values: np.ndarray, nominal: float | None, p99: float | None,
                     unit: str = "") -> Figure:
    """Histogram of one output (in ``unit``) over the ``ok`` designs, nominal and p99 as vertical lines."""
    from dualmech.validation.report.plots import Figure  # here: a command starts its figure worker sooner

    fig = histogram_plot(name, values, nominal, p99, unit)
    n = int(np.isfinite(values).sum())
    return Figure(f"hist-{name}", "histogram", name, name, f"{name}: {n} fully assembling designs", _png(fig))


def histogram_plot(name: str, values: np.ndarray, nominal: float | None, p99: float | None,
                   unit: str = "") -> Any:
    """The matplotlib figure of :func:`histogram_figure` (not drawn); x label ``name [unit]``."""
    fig, ax = _pyplot().subplots(figsize=(4.2, 2.8), dpi=DPI)
    fig.subplots_adjust(**HIST_MARGINS)
    v = values[np.isfinite(values)]
    bins = max(5, min(HIST_BINS, int(np.sqrt(max(v.size, 1)))))
    if v.size and v.min() > 0 and v.max() > LOG_SPAN * np.median(v):  # heavy tail (peaks near dead centres)
        ax.set_xscale("log")
        bins = np.geomspace(v.min(), v.max(), bins + 1)
    counts, edges = np.histogram(v, bins=bins)  # what ax.hist counts, drawn as one filled outline
    ax.stairs(counts, edges, fill=True, color="#90a4ae")
    for x, label, style in ((nominal, "nominal", "-"), (p99, "p99", "--")):
        if x is not None and np.isfinite(x):
            ax.axvline(x, color="#c62828" if label == "p99" else "#1565c0", ls=style, label=label)
    ax.set_title(name, fontsize=9)
    ax.set_xlabel(f"{name} [{unit}]" if unit else name, fontsize=8)
    ax.set_ylabel("designs", fontsize=8)
    ax.tick_params(labelsize=7)
    ax.legend(fontsize=7)
    return fig


def _key_width(fig: Any, keys: list[str]) -> float:
    """Width of the widest key label (7 pt) in inches."""
    from matplotlib.font_manager import FontProperties

    renderer = fig.canvas.get_renderer()
    font = FontProperties(size=7)
    widths = [renderer.get_text_width_height_descent(k, font, ismath=False)[0] for k in keys]
    return max(widths, default=0.0) / fig.dpi


def tornado_figure(name: str, keys: list[str], sobol: dict | None, linear: dict | None) -> Figure:
    """Horizontal bars: each key's share of the variance of ``name`` (Sobol first order, linear share)."""
    from dualmech.validation.report.plots import Figure

    fig = tornado_plot(name, keys, sobol, linear)
    return Figure(f"tornado-{name}", "tornado", name, name, f"{name}: share of variance per key", _png(fig))


def tornado_plot(name: str, keys: list[str], sobol: dict | None, linear: dict | None) -> Any:
    """The matplotlib figure of :func:`tornado_figure` (not drawn)."""
    width, height = 5.0, 0.45 * len(keys) + 1.0
    fig, ax = _pyplot().subplots(figsize=(width, height), dpi=DPI)
    left = min(0.6, (_key_width(fig, keys) + TORNADO_KEY_PAD) / width)
    fig.subplots_adjust(left=left, right=1 - TORNADO_RIGHT / width, bottom=TORNADO_BELOW / height,
                        top=1 - TORNADO_ABOVE / height)
    y = np.arange(len(keys))
    bars = ((-0.2, sobol, "Sobol (MC)", "#2e7d32"), (0.2, linear, "linear", "#1565c0"))
    for off, src, label, color in bars:
        if src:
            vals = [src.get(k) if src.get(k) is not None else 0.0 for k in keys]
            ax.barh(y + off, vals, height=0.4, label=label, color=color)
    ax.set_yticks(y, keys, fontsize=7)
    ax.set_xlim(0, 1)
    ax.set_xlabel("share of variance", fontsize=8)
    ax.set_title(name, fontsize=9)
    ax.invert_yaxis()
    ax.legend(fontsize=7)
    return fig


def figure_jobs(summary: dict, samples: dict[str, np.ndarray] | None) -> list[tuple]:
    """What every figure is drawn from (picklable): ``("hist", name, values, nominal, p99, unit)`` per
    output over the ``ok`` designs, then ``("tornado", name, keys, sobol, linear)``; none for an output
    that is round-off (``summary["round_off"]``: reported as 0) or constant (``summary["constant"]``):
    neither has a distribution nor variance shares.

    ``summary`` needs ``nominal``, ``outputs``, ``keys``, ``contribution`` and ``linear_share``, non-finite
    numbers as ``None`` (as in ``summary.json``), and may give ``round_off``, ``constant`` and ``units``.
    """
    flat = {**(summary.get("round_off") or {}), **(summary.get("constant") or {})}
    names = [name for name in summary["nominal"] if name not in flat]
    units = summary.get("units") or {}
    jobs: list[tuple] = []
    if samples is not None:
        ok = np.asarray(samples["status"], dtype=str) == DesignStatus.OK.value
        jobs += [("hist", name, np.asarray(samples[name], float)[ok], summary["nominal"][name],
                  summary["outputs"].get(name, {}).get("p99"), units.get(name, "")) for name in names]
    jobs += [("tornado", name, summary["keys"], (summary.get("contribution") or {}).get(name),
              (summary.get("linear_share") or {}).get(name)) for name in names]
    return jobs


def draw_figures(jobs: list[tuple]) -> list[Figure]:
    """Draw the figures of :func:`figure_jobs` (in this process: a pool worker's task)."""
    draw = {"hist": histogram_figure, "tornado": tornado_figure}
    return [draw[kind](*args) for kind, *args in jobs]


def warm_up() -> None:
    """A pool worker's first task: import matplotlib (while the study is still solving)."""
    _pyplot()


class FigureDrawing:
    """The report's figures, drawn in one spawned worker process (``parallel``) or in this one.

    :meth:`warm` starts the worker early (it imports matplotlib meanwhile); :meth:`start` hands it the
    figures as soon as the statistics are known; :meth:`collect` waits for them; :meth:`close` ends
    the worker.  Without ``parallel`` the figures are drawn by :meth:`collect`, here.
    """

    def __init__(self, parallel: bool) -> None:
        self.parallel = parallel
        self._pool: Any = None
        self._pending: Any = None
        self._collected = False

    def warm(self) -> None:
        """Spawn the worker now (``parallel`` only)."""
        if self.parallel and self._pool is None:
            from dualmech.validation.run.executors import process_pool

            self._pool = process_pool(1)
            self._pool.submit(warm_up)

    def start(self, summary: dict, samples: dict[str, np.ndarray] | None) -> None:
        """Begin drawing the figures of ``summary`` and ``samples`` (:func:`figure_jobs`)."""
        jobs = figure_jobs(summary, samples)
        self.warm()
        if self.parallel:
            self._pending = self._in_worker(lambda: self._pool.submit(draw_figures, jobs))
        else:
            self._pending = jobs

    def collect(self) -> list[Figure]:
        """The figures, in :func:`figure_jobs` order (:meth:`start` first)."""
        if self._pending is None:
            raise RuntimeError("figures: collect() before start()")
        figures = self._in_worker(self._pending.result) if self.parallel else draw_figures(self._pending)
        self._collected = True
        return figures

    def _in_worker(self, step: Any) -> Any:
        """``step()``; a killed worker (``BrokenProcessPool``) as one line, exit 4 at the command line
        (:func:`~dualmech.validation.run.executors.worker_died`)."""
        from concurrent.futures.process import BrokenProcessPool

        from dualmech.validation.run.executors import worker_died

        try:
            return step()
        except BrokenProcessPool as err:
            raise worker_died(self._pool, err, lambda pid: " while drawing the study's figures") from None

    def close(self) -> None:
        """End the worker: once the figures were collected it exits by itself (not waited for: it tears
        down while this process writes and prints; the command's end waits for it,
        :func:`~dualmech.validation.run.executors.end_all_pools`), else at once."""
        if self._pool is None:
            return
        from dualmech.validation.run.executors import end_pool, let_go

        pool, self._pool = self._pool, None
        if self._collected:
            let_go(pool)
        else:
            end_pool(pool, grace=0.0)


def write_tolerance_report(outdir: Path, summary: dict, x: np.ndarray | None,
                           samples: dict[str, np.ndarray] | None,
                           figures: FigureDrawing | list[Figure] | None = None) -> list[str]:
    """Write ``report.html``, ``report.md`` and ``figures/*.png`` into ``outdir``; return those files.

    ``figures``: already drawn, or being drawn (:class:`FigureDrawing`: collected once the templates are
    loaded); by default drawn here from ``summary`` and ``samples``.
    """
    from dualmech.validation.report.render import environment

    templates = [(environment(TEMPLATES, markdown).get_template(template), target)
                 for template, target, markdown in (("tolerance.html.j2", "report.html", False),
                                                    ("tolerance.md.j2", "report.md", True))]
    if figures is None:
        figures = draw_figures(figure_jobs(summary, samples))
    elif isinstance(figures, FigureDrawing):
        figures = figures.collect()
    given = summary.get("units") or {}
    units = {n: f"[{given[n]}]" if given.get(n) else "" for n in summary["nominal"]}
    context = {"s": summary, "figures": figures, "names": list(summary["nominal"]), "units": units,
               "round_off": summary.get("round_off") or {}, "round_off_relative": ROUND_OFF_RELATIVE.value,
               "constant": summary.get("constant") or {}, "constant_relative": CONSTANT_RELATIVE}
    with locked(outdir) as outdir:  # the run folder's rules: inside it, no link followed, atomic files
        for f in figures:
            write_file(outdir, f"figures/{f.key}.png", f.png)
        for template, target in templates:
            write_file(outdir, target, template.render(**context))
    return ["summary.json", "report.html", "report.md"] + [f"figures/{f.key}.png" for f in figures]
