"""The report of a tolerance study: ``DIR/report.html`` (self-contained) and ``DIR/report.md``.

Sections: the yield; per output a histogram over the fully assembling designs with the
nominal value and the p99 marked; Monte Carlo against linear standard deviations; a tornado
chart of each key's share of the variance (first-order Sobol from the samples beside the
linear shares); the sensitivity table; the judges' spot checks.  Figures are matplotlib
(Agg) PNGs, embedded as data URIs in the HTML and written under ``DIR/figures/`` for the
Markdown, with the helpers of :mod:`dualmech.validation.report`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from dualmech.models.tolerance.outputs import DesignStatus
from dualmech.validation.report import Figure
from dualmech.validation.report import environment as _environment
from dualmech.validation.report import fig_to_png as _fig_to_png

TEMPLATES = Path(__file__).parent / "templates"
#: Histogram bins (at most; fewer for small studies).
HIST_BINS = 40
#: A histogram gets a logarithmic axis when its largest value exceeds the median this many times.
LOG_SPAN = 20.0


def histogram_figure(name: str, values: np.ndarray, nominal: float | None, p99: float | None) -> Figure:
    """Histogram of one output over the ``ok`` designs, nominal and p99 as vertical lines."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(4.2, 2.8))
    v = values[np.isfinite(values)]
    bins = max(5, min(HIST_BINS, int(np.sqrt(max(v.size, 1)))))
    if v.size and v.min() > 0 and v.max() > LOG_SPAN * np.median(v):  # heavy tail (peaks near dead centres)
        ax.set_xscale("log")
        bins = np.geomspace(v.min(), v.max(), bins + 1)
    ax.hist(v, bins=bins, color="#90a4ae")
    for x, label, style in ((nominal, "nominal", "-"), (p99, "p99", "--")):
        if x is not None and np.isfinite(x):
            ax.axvline(x, color="#c62828" if label == "p99" else "#1565c0", ls=style, label=label)
    ax.set_title(name, fontsize=9)
    ax.set_ylabel("designs", fontsize=8)
    ax.tick_params(labelsize=7)
    ax.legend(fontsize=7)
    fig.tight_layout()
    return Figure(f"hist-{name}", "histogram", name, name, f"{name}: {v.size} fully assembling designs",
                  _fig_to_png(fig))


def tornado_figure(name: str, keys: list[str], sobol: dict | None, linear: dict | None) -> Figure:
    """Horizontal bars: each key's share of the variance of ``name`` (Sobol first order, linear share)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5.0, 0.45 * len(keys) + 1.0))
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
    fig.tight_layout()
    return Figure(f"tornado-{name}", "tornado", name, name, f"{name}: share of variance per key",
                  _fig_to_png(fig))


def _figures(summary: dict, samples: dict[str, np.ndarray] | None) -> list[Figure]:
    names = list(summary["nominal"])
    out = []
    if samples is not None:
        ok = np.asarray(samples["status"], dtype=str) == DesignStatus.OK.value
        for name in names:
            out.append(histogram_figure(name, np.asarray(samples[name], float)[ok],
                                        summary["nominal"][name],
                                        summary["outputs"].get(name, {}).get("p99")))
    for name in names:
        out.append(tornado_figure(name, summary["keys"], (summary.get("contribution") or {}).get(name),
                                  (summary.get("linear_share") or {}).get(name)))
    return out


def write_tolerance_report(outdir: Path, summary: dict, x: np.ndarray | None,
                           samples: dict[str, np.ndarray] | None) -> list[str]:
    """Write ``report.html``, ``report.md`` and ``figures/*.png`` into ``outdir``; return those files."""
    figures = _figures(summary, samples)
    figdir = outdir / "figures"
    figdir.mkdir(parents=True, exist_ok=True)
    for f in figures:
        (figdir / f"{f.key}.png").write_bytes(f.png)
    context = {"s": summary, "figures": figures, "names": list(summary["nominal"])}
    for template, target, markdown in (("tolerance.html.j2", "report.html", False),
                                       ("tolerance.md.j2", "report.md", True)):
        text = _environment(TEMPLATES, markdown).get_template(template).render(**context)
        (outdir / target).write_text(text)
    return ["summary.json", "report.html", "report.md"] + [f"figures/{f.key}.png" for f in figures]
