"""The HTML report's interactive figures and the heat maps' ratio-to-tolerance scale (issue 30, "A report an
engineer reads at a glance").

In headless Chromium, with name resolution blocked and every request logged (Chromium's net log): the page
requests no http(s) URL, draws every figure (plotly.js inlined once), hovers a value with its unit, and its
engine switches hide and show an engine in every figure.  Without a browser: heat maps coloured by ratio
to tolerance with the boundary at 1 on the colour bar, every axis and colour bar labelled with its unit,
dead centres marked in the interactive sweep figures.  Each check fails on a deliberate fault (a page that
loads its library from the network, an engine switch that does nothing, a heat map coloured by the relative
difference).
"""

from __future__ import annotations

import json
import math
import re
import subprocess
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from dualmech.validation.compare import compare_run
from dualmech.validation.matrix import load_matrix
from dualmech.validation.report import figures, interactive, plots
from dualmech.validation.report.render import write_report
from dualmech.validation.run.runner import run_matrix
from tests.validation.test_validate import FAKE_REGISTRY, chromium

#: Virtual time Chromium gives the page to draw every figure after load (ms; no real time passes idle).
DRAW_MS = 5000

PROBE = """<script>
window.addEventListener('load', () => {
  const plots = Array.from(document.querySelectorAll('div.plot'));
  const shown = engine => plots.filter(d => d.data).map(
    d => d.data.filter(t => t.meta === engine && t.visible !== false).length).reduce((a, b) => a + b, 0);
  const drawnTraces = () => document.querySelectorAll('div.plot g.trace').length;
  const errors = [];
  try { window.dualmechReport.drawAll(); } catch (e) { errors.push(String(e)); }
  setTimeout(() => {
    const out = {plots: plots.map(d => ({id: d.id, drawn: d.dataset.drawn === 'yes',
                                          svg: d.querySelectorAll('svg.main-svg').length})),
                 summary: document.querySelector('#summary-table') !== null, errors: errors};
    const first = plots.find(d => d.data && d.data.length);
    if (first) Plotly.Fx.hover(first, [{curveNumber: 0, pointNumber: 1}]);
    const box = document.querySelector('#engine-switches input[data-engine="' + ENGINE + '"]');
    out.before = {shown: shown(ENGINE), traces: drawnTraces()};
    setTimeout(() => {
      out.hover = first ? Array.from(first.querySelectorAll('.hovertext')).map(e => e.textContent) : [];
      box.click();
    }, 300);
    setTimeout(() => {
      out.hidden = {shown: shown(ENGINE), traces: drawnTraces()};
      box.click();
      setTimeout(() => {
        out.again = {shown: shown(ENGINE), traces: drawnTraces()};
        const p = document.createElement('pre'); p.id = 'probe'; p.textContent = JSON.stringify(out);
        document.body.appendChild(p);
      }, 500);
    }, 800);
  }, DRAW_MS);
});
</script></body>"""


def load_in_chromium(page: Path, tmp_path: Path, engine: str) -> tuple[dict, list[str]]:
    """Load ``page``, with :data:`PROBE` (toggling ``engine``) added, in headless Chromium that resolves no
    host name; the probe's findings and every http(s) URL the browser requested (its net log)."""
    probed = tmp_path / "probed.html"
    probe = PROBE.replace("ENGINE", json.dumps(engine)).replace("DRAW_MS", str(DRAW_MS))
    probed.write_text(page.read_text(encoding="utf-8").replace("</body>", probe), encoding="utf-8")
    netlog = tmp_path / "netlog.json"
    dom = subprocess.run(
        [chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--host-resolver-rules=MAP * ~NOTFOUND", f"--log-net-log={netlog}",
         f"--user-data-dir={tmp_path / 'profile'}", f"--virtual-time-budget={DRAW_MS + 20000}",
         "--dump-dom", probed.as_uri()],
        capture_output=True, text=True, timeout=300,
    ).stdout
    start = dom.index('<pre id="probe">') + len('<pre id="probe">')
    found = json.loads(dom[start:dom.index("</pre>", start)].replace("&lt;", "<").replace("&gt;", ">")
                       .replace("&quot;", '"').replace("&amp;", "&"))
    return found, _page_requests(json.loads(netlog.read_text(encoding="utf-8")))


def _page_requests(netlog: dict) -> list[str]:
    """The http(s) URLs a page opened from a file requested, from Chromium's net log: the requests started
    for the file:// site (the browser's own, e.g. its update checks, have another isolation key)."""
    start = netlog["constants"]["logEventTypes"]["URL_REQUEST_START_JOB"]
    return sorted({e["params"]["url"] for e in netlog["events"]
                   if e["type"] == start and e["params"].get("network_isolation_key", "").startswith("file://")
                   and re.match(r"https?://", e["params"]["url"])})


@pytest.fixture(scope="module")
def small_report(tmp_path_factory) -> Path:
    """The report of the small matrix (stand-in engines)."""
    from tests.validation.conftest import SMALL

    tmp = tmp_path_factory.mktemp("interactive")
    (tmp / "small.toml").write_text(SMALL)
    run_matrix(load_matrix(tmp / "small.toml"), tmp / "run", jobs=1, registry=FAKE_REGISTRY)
    return write_report(tmp / "run", None, jobs=1).html


def _referenced_urls(html: str) -> list[str]:
    """http(s) URLs the page's markup and styles point to (src, href, CSS url()); the inlined scripts' code
    is left out: the library names URLs of features the report does not use (map tiles, its home page)."""
    markup = re.sub(r"(<script\b[^>]*>).*?(</script>)", r"\1\2", html, flags=re.S | re.I)
    return re.findall(r'(?:\b(?:src|href)\s*=\s*["\']?|url\(\s*["\']?)(https?://[^"\')\s>]+)', markup, re.I)


def check_interactive_page(page: Path, tmp_path: Path, engine: str = "pinocchio") -> None:
    """The browser checks of the module docstring on ``page``; one AssertionError names each failure."""
    html = page.read_text(encoding="utf-8")
    found, requested = load_in_chromium(page, tmp_path, engine)
    failed = []
    if requested:
        failed.append(f"http(s) requested: {requested[:5]}")
    if _referenced_urls(html):
        failed.append(f"http(s) referenced: {_referenced_urls(html)[:5]}")
    if not found["plots"] or not all(p["drawn"] and p["svg"] for p in found["plots"]) or found["errors"]:
        failed.append(f"figures not drawn: {[p['id'] for p in found['plots'] if not p['drawn']]} "
                      f"{found['errors']}")
    if not found["summary"]:
        failed.append("summary table missing")
    if not any(re.search(r"θ1 = [\d.]+.*\[\w+\] = -?[\d.]", h) for h in found.get("hover", [])):
        failed.append(f"hover: no value with its unit: {found.get('hover')}")
    before, hidden, again = found["before"], found["hidden"], found["again"]
    if not (before["shown"] > 0 and hidden["shown"] == 0 and hidden["traces"] < before["traces"]
            and again == before):
        failed.append(f"engine switch of {engine}: {before} -> hidden {hidden} -> shown {again}")
    assert not failed, "\n".join(failed)


def test_the_html_report_draws_offline_and_toggles_engines(small_report, tmp_path):
    html = small_report.read_text(encoding="utf-8")
    assert html.count("Copyright 2012-") == 1  # plotly.js inlined once, not per figure
    assert "default-src 'none'" in html  # the page's own policy: nothing fetched, whatever a script asks
    check_interactive_page(small_report, tmp_path)


def test_a_page_that_loads_its_library_from_the_network_fails(small_report, tmp_path):
    html = small_report.read_text(encoding="utf-8")
    start = html.index("<script>/**\n* plotly.js")
    end = html.index("</script>", start) + len("</script>")
    fetched = tmp_path / "fetched" / "report.html"
    fetched.parent.mkdir()
    fetched.write_text(re.sub(r'<meta http-equiv="Content-Security-Policy"[^>]*>', "",
                              html[:start] + '<script src="https://cdn.plot.ly/plotly-3.0.1.min.js"></script>'
                              + html[end:]), encoding="utf-8")
    with pytest.raises(AssertionError, match="requested: \\['https://cdn.plot.ly") as err:
        check_interactive_page(fetched, tmp_path)
    assert "referenced" in str(err.value) and "figures not drawn" in str(err.value)


def test_an_engine_switch_that_does_nothing_fails(small_report, tmp_path):
    broken = tmp_path / "broken" / "report.html"
    broken.parent.mkdir()
    html = small_report.read_text(encoding="utf-8")
    broken.write_text(html.replace("if (traces.length) Plotly.restyle(", "if (false) Plotly.restyle("),
                      encoding="utf-8")
    with pytest.raises(AssertionError, match="engine switch of pinocchio"):
        check_interactive_page(broken, tmp_path)


# ------------------------------------------------------------------------ without a browser


def _heatmap_spec(matrix, results):
    comparison = compare_run(matrix, results)
    specs = figures.figure_specs(matrix, results, comparison)
    return next(s for s in specs if s.job[0] == "heatmap"), comparison


def test_heat_maps_are_coloured_by_ratio_to_tolerance(matrix, results):
    """Why: coloured by log10 of the relative difference, a cell's pass or fail depended on a tolerance the
    reader had to look up.  The cell's value is the check's ratio (difference / tolerance), and the colour
    jumps at ratio 1."""
    spec, comparison = _heatmap_spec(matrix, results)
    engine, cases, quantities, ratios, failed = spec.job[1][:5]
    checks = {(c.case, c.quantity): c for c in comparison.checks if c.engine == engine}
    for i, case in enumerate(cases):
        for j, q in enumerate(quantities):
            if (case, q) in checks:
                assert ratios[i, j] == checks[case, q].ratio
    cmap = plots.ratio_colormap()
    lo, hi = (math.log10(v) for v in plots.RATIO_SCALE)
    colour = lambda ratio: np.array(cmap((math.log10(ratio) - lo) / (hi - lo))[:3])  # noqa: E731
    inside, outside = colour(0.97), colour(1.03)
    assert outside[0] - max(outside[1:]) > 0.3 and inside[1] >= inside[0]  # red beyond, green-yellow within
    assert np.abs(inside - outside).sum() > 0.5  # the boundary is a jump, not a gradient


def test_a_heat_map_of_the_relative_difference_is_seen(matrix, results, monkeypatch):
    """The fault the test above must see: the heat map fed the relative differences (as before issue 30)."""
    def by_difference(matrix, comparison):
        specs = real(matrix, comparison)
        return [s._replace(job=(s.job[0], (*s.job[1][:3], s.job[1][5], *s.job[1][4:]))) for s in specs]

    real = figures._heatmap_specs
    monkeypatch.setattr(figures, "_heatmap_specs", by_difference)
    with pytest.raises(AssertionError):
        test_heat_maps_are_coloured_by_ratio_to_tolerance(matrix, results)


def _static(spec):
    """The matplotlib figure that ``spec`` draws as PNG."""
    kept = {}
    import dualmech.validation.report.plots as p

    real = p.fig_to_png
    p.fig_to_png = lambda fig, **kwargs: kept.setdefault("fig", fig) and b""
    try:
        figures._render(spec.job, static=True)
    finally:
        p.fig_to_png = real
    return kept["fig"]


def _all_specs(matrix, results):
    from dualmech.validation.report import derived
    from dualmech.validation.report.sections import balancing_spec

    comparison = compare_run(matrix, results)
    return [*figures.figure_specs(matrix, results, comparison), balancing_spec(derived.balancing(matrix))]


def test_every_static_axis_and_colour_bar_has_a_label_with_its_unit(matrix, results):
    """Every drawn axes of each static kind says what it shows; a data axis of a sweep panel, the heat map's
    colour bar and the polar plot say their unit (the small matrix is in inch-lbf-s)."""
    kinds = {}
    for spec in _all_specs(matrix, results):
        if figures._FIGURE_FUNCTIONS[spec.job[0]][0] is not None:
            kinds.setdefault(spec.job[0], spec)
    assert set(kinds) == {"sweep", "heatmap", "balancing"}
    for kind, spec in kinds.items():
        fig = _static(spec)
        for ax in fig.axes:
            if not ax.axison:
                continue
            if ax.name == "polar":
                assert any("[lbf]" in t.get_text() for t in ax.texts), kind
                assert all(" lbf" in t.get_text() for t in ax.get_legend().get_texts()), kind
            elif ax.get_label() == "<colorbar>":
                assert ax.get_ylabel() == "ratio to tolerance [1] (log scale)"
                assert "1 = tolerance" in [t.get_text() for t in ax.get_yticklabels()]
                assert any(np.allclose(line.get_ydata(), 0.0) for line in ax.lines)  # the boundary
            else:
                assert ax.get_xlabel() and ax.get_ylabel(), (kind, ax.get_title())
                if kind == "sweep" and ax.get_yticks().size:
                    assert re.search(r"\[(in|lbf|lbf·in|in/s|in/s²|1)\]", ax.get_ylabel()), ax.get_ylabel()


def test_every_interactive_axis_has_a_title_and_sweep_axes_a_unit(matrix, results):
    for spec in _all_specs(matrix, results):
        layout = json.loads(figures._render(spec.job)[1])["layout"]
        axes = {k: v for k, v in layout.items() if re.fullmatch(r"[xy]axis\d*", k) and v.get("visible", True)}
        if spec.job[0] == "balancing":
            assert layout["polar"]["radialaxis"]["title"]["text"] == "|f_xy| [lbf]"
            continue
        assert axes and all(a.get("title", {}).get("text") for a in axes.values()), spec.key
        if spec.job[0] == "sweep":
            assert all(re.search(r"\[[^\]]+\]$", a["title"]["text"]) for a in axes.values()), spec.key


def test_interactive_sweep_figures_mark_the_dead_centres(matrix, results):
    """Why: an engineer zooms on the spikes beside a dead centre; the interactive figure must show where the
    dead centres are, as the static one does (dotted verticals at each angle the reference flags)."""
    from dualmech.core.status import Status, is_status

    spec = next(s for s in _all_specs(matrix, results) if s.key.endswith("torque-joint2"))
    cases = spec.job[1][3]
    ref = cases[0][1]["dualmech"]
    flagged = ref["theta1_deg"][is_status(ref.status, Status.DEAD_CENTRE)]
    if not flagged.size:  # plant one: the stand-in engines flag dead centres where |t| < 1e-9
        status = ref.status.copy()
        status[3] = "dead_centre"
        cases[0][1]["dualmech"] = ref = replace(ref, status=status)
        flagged = ref["theta1_deg"][[3]]
    layout = json.loads(interactive.sweep_plot(*spec.job[1]))["layout"]
    lines = [s for s in layout["shapes"] if s["name"] == "dead centres"]
    panels = {s["xref"] for s in lines}
    assert panels and panels <= {"x", "x2", "x3"}
    assert sorted({s["x0"] for s in lines}) == sorted(float(a) for a in flagged)
    assert sum(s["showlegend"] for s in lines) == 1
