"""The one-page report of an SI design, as headless Chromium draws it (issue 14, "Done when").

``dualmech validate design.toml`` on the engineer's design of issue 14; Chromium lays the page
out (a probe script in an instrumented copy draws every interactive figure and reports where each
figure and the summary table are) and takes a screenshot of the report itself, as tall as the page
(so that every figure is in view, and drawn).  Checked on the screenshot: every figure is
drawn (not blank: ink of axes, labels and curves), the summary table is drawn with its passing
cells.  Checked on the page text: the peak-load table carries SI unit labels,
and the thesis's printed findings (lbf, inches) are absent.  Each check fails on a deliberate
fault: a blank figure, the thesis's findings forced in, a design without a unit label.
"""

from __future__ import annotations

import json
import re
import subprocess
from pathlib import Path
from typing import Callable

import numpy as np
import pytest
from click.testing import CliRunner

from dualmech.cli import main
from tests.validation.test_design import SI_DESIGN
from tests.validation.test_validate import chromium

#: Page width of the screenshot, CSS pixels (a laptop screen; device scale factor 1).
WIDTH = 1280
#: A pixel is ink (curves, markers, axes, text; not the white background) when its mean r, g, b is below this.
INK = 0.6
#: Smallest ink fraction of a drawn figure on the screenshot (axes, labels, curves): measured 2.0 % to 34.5 %.
MIN_INK = 0.005
#: The summary table's passing cells: background #e8f5e9 (validation/templates), as RGB in [0, 1].
PASS_CELL = np.array([0xE8, 0xF5, 0xE9]) / 255.0
#: Colour match of a screenshot pixel to PASS_CELL (PNG screenshots are exact; a little slack for blending).
PASS_CELL_MATCH = 2.0 / 255.0
#: Unit labels the peak-load table of an "m-N-s" design must carry (innerText: tabs between cells, newlines).
SI_LABELS = (r"\d m\s", r"\d N\s+at \d", r"\d N·m\s+at \d")

PROBE = """<script>
window.addEventListener('load', () => {
  window.dualmechReport.drawAll();
  setTimeout(() => {
    const box = e => { const r = e.getBoundingClientRect();
      return [r.left + window.scrollX, r.top + window.scrollY, r.width, r.height]; };
    const summary = document.querySelector('#summary ~ table');
    const p = document.createElement('pre'); p.id = 'probe';
    p.textContent = JSON.stringify({
      height: document.documentElement.scrollHeight,
      images: Array.from(document.querySelectorAll('div.plot')).map(
        d => ({alt: d.getAttribute('aria-label'), box: box(d), ok: d.dataset.drawn === 'yes'})),
      summary: summary ? box(summary) : null,
      text: document.body.innerText});
    document.body.appendChild(p);
  }, 3000);
});
</script></body>"""


def _run_chromium(browser: str, profile: Path, height: int, *args: str) -> str:
    flags = [browser, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
             "--disable-background-networking", "--disable-component-update", "--disable-sync",
             "--hide-scrollbars", "--force-device-scale-factor=1", f"--window-size={WIDTH},{height}",
             f"--user-data-dir={profile}", "--virtual-time-budget=10000", *args]
    return subprocess.run(flags, capture_output=True, text=True, timeout=120).stdout


def validate_design(tmp_path: Path, design: str = SI_DESIGN) -> Path:
    """``dualmech validate design.toml``, dualmech judged by Pinocchio and rigid MuJoCo; the report's path."""
    source = tmp_path / "design.toml"
    source.write_text(design)
    out = tmp_path / "run"
    result = CliRunner().invoke(main, ["validate", str(source), "-o", str(out), "--jobs", "1",
                                       "--engines", "dualmech,pinocchio,mujoco"])
    assert result.exit_code == 0, result.output
    return out / "report.html"


def _laid_out(report: Path, tmp_path: Path) -> dict:
    """``report`` laid out in headless Chromium by the probe: its height, figures, summary table, text."""
    html = report.read_text(encoding="utf-8")
    probed = tmp_path / "probed.html"
    probed.write_text(html.replace("</body>", PROBE), encoding="utf-8")
    dom = _run_chromium(chromium(), tmp_path / "profile-probe", 1000, "--dump-dom", probed.as_uri())
    start = dom.index('<pre id="probe">') + len('<pre id="probe">')
    return json.loads(dom[start:dom.index("</pre>", start)].replace("&lt;", "<").replace("&gt;", ">")
                      .replace("&amp;", "&"))


def _text_failures(page: dict) -> list[str]:
    """The checks of the page's text: the peak-load table's SI unit labels, no thesis findings."""
    failed = []
    text = page["text"]
    if "Peak joint loads" not in text or not all(re.search(label, text) for label in SI_LABELS):
        failed.append(f"unit labels: the peak-load table lacks one of {SI_LABELS}")
    if "thesis's printed findings" in text.lower() or "lbf" in text:
        failed.append("thesis's printed findings in the report of another design")
    return failed


def check_report_page(report: Path, tmp_path: Path,
                      text_failures: Callable[[dict], list[str]] = _text_failures) -> None:
    """Lay out and screenshot ``report`` in headless Chromium; one AssertionError names every failed check
    (those of its figures and summary table, then ``text_failures`` of the laid-out page)."""
    import matplotlib.image

    page = _laid_out(report, tmp_path)
    shot = tmp_path / "report.png"
    _run_chromium(chromium(), tmp_path / "profile-shot", page["height"], f"--screenshot={shot}",
                  report.as_uri())
    pixels = matplotlib.image.imread(shot)[..., :3]

    def region(box: list[float]) -> np.ndarray:
        x, y, w, h = (int(round(v)) for v in box)
        return pixels[y:y + h, x:x + w]

    failed = []
    if not page["images"] or not all(i["ok"] for i in page["images"]):
        failed.append(f"figures present: {[(i['alt'], i['ok']) for i in page['images']]}")
    for i in page["images"]:
        crop = region(i["box"])
        ink = float((crop.mean(axis=-1) < INK).mean()) if crop.size else 0.0
        if ink < MIN_INK:
            failed.append(f"figure blank on the screenshot: {i['alt']!r} (ink {ink:.2%})")
    table = region(page["summary"]) if page["summary"] else np.zeros((0, 0, 3))
    if not np.any(np.all(np.abs(table - PASS_CELL) <= PASS_CELL_MATCH, axis=-1)):
        failed.append("summary table not drawn with its passing cells")
    failed += text_failures(page)
    assert not failed, "\n".join(failed)


def check_report_text(report: Path, tmp_path: Path) -> None:
    """The text checks of :func:`check_report_page` alone (the page laid out, no screenshot): what the
    faults of the page's text are seen by."""
    failed = _text_failures(_laid_out(report, tmp_path))
    assert not failed, "\n".join(failed)


@pytest.fixture(scope="module")
def si_report(tmp_path_factory) -> Path:
    return validate_design(tmp_path_factory.mktemp("si"))


def test_si_design_report_renders_figures_table_and_units(si_report, tmp_path):
    check_report_page(si_report, tmp_path)


def test_a_blank_figure_fails(si_report, tmp_path):
    blank = tmp_path / "blank" / "report.html"
    blank.parent.mkdir()
    html = si_report.read_text(encoding="utf-8")
    hidden = {"visible": False}
    white = json.dumps({"data": [], "layout": {"width": 400, "height": 300, "xaxis": hidden,
                                               "yaxis": hidden}})  # a white figure of a plot's size
    blank.write_text(re.sub(r'(<script type="application/json" id="data-[^"]+">).*?(</script>)',
                            lambda m: m.group(1) + white + m.group(2), html, count=1, flags=re.S),
                     encoding="utf-8")
    with pytest.raises(AssertionError, match="figure blank on the screenshot"):
        check_report_page(blank, tmp_path)


def test_the_thesis_findings_forced_into_the_report_fail(tmp_path, monkeypatch):
    from dualmech.validation.matrix import Matrix

    monkeypatch.setattr(Matrix, "of_thesis", property(lambda self: True))
    with pytest.raises(AssertionError, match="thesis's printed findings"):
        check_report_text(validate_design(tmp_path), tmp_path)


def test_a_design_without_a_unit_label_fails(tmp_path):
    with pytest.raises(AssertionError, match="unit labels"):
        check_report_text(validate_design(tmp_path, SI_DESIGN.replace('units = "m-N-s"\n', "")), tmp_path)


def _linkage_text_failures(page: dict) -> list[str]:
    """The text checks of a linkage's page: the peak-load table with its joints in N and N·m, no stroke or
    balancing section, the sections left out named."""
    text = page["text"]
    failed = []
    if "Peak joint loads" not in text or not re.search(r"\d N\s+at \d", text) or "j4 |m|" not in text:
        failed.append("peak joint loads: the table of every joint, in N and N·m, is missing")
    if "\nStroke\n" in text or "Dynamic balancing\n" in text:
        failed.append("a slider crank's section (stroke, balancing) on a linkage's page")
    if "Not in this report" not in text:
        failed.append("the sections left out are not named")
    return failed


def test_a_linkage_report_is_the_same_page_its_figures_drawn(tmp_path):
    """Issue 32: a linkage run's report is the slider crank's page (the RCCC, judged by Pinocchio): every
    figure drawn interactively (the heat map and the case's engine overlay), the summary table with its
    passing cells, the linkage's own peak-load table."""
    out = tmp_path / "run"
    result = CliRunner().invoke(main, ["validate", "rccc", "-o", str(out), "--jobs", "1", "--engines",
                                       "dualmech,pinocchio"])
    assert result.exit_code == 0, result.output
    check_report_page(out / "report.html", tmp_path, _linkage_text_failures)
    page = _laid_out(out / "report.html", tmp_path)
    assert [i["alt"] for i in page["images"]] == ["rccc-example: theta4_deg from every engine",
                                                  "pinocchio: agreement per case and quantity"]
