"""A real linkage run's report shows the agreement of every pair of engines (issue 33): one row per pair, each
cell the worst relative difference of its column group, recomputed here from the stored tables
(``tables/<case>/<engine>.csv``) by the table kinds' gate rule restated (module docstring of
``validation/compare/tables.py``): ``|B - A| / s_g(A)``, ``s_g`` the first engine's largest ``|A|`` over the
rows both give, of every compared column of the unit group."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from numpy.testing import assert_allclose

from dualmech.cli import main
from dualmech.models.linkages import linkage_case, table_spec
from dualmech.validation.exit_codes import EXIT_PASS
from dualmech.validation.matrix.tolerances import group_tolerances

from .test_linkage_report import _table

pytest.importorskip("pinocchio")
pytest.importorskip("mujoco")

ENGINES = ("dualmech", "pinocchio", "mujoco", "mujoco-sim")
CASE = "rssr-crank-rocker"
#: Each judge's tolerances, kinematics and reactions (the linkage gate's: test_gate.py holds them to
#: validation/tolerances.py).
TOLERANCES = {e: (group_tolerances(e)["kinematics"].value, group_tolerances(e)["reactions"].value)
              for e in ENGINES[1:]}


def _group(column: str, pose: tuple[str, ...], rates: tuple[str, ...]) -> str:
    """The pair table's column group: the pose, its rates, a joint's force or moment component, or an
    effort (a torque)."""
    if column in pose or column in rates:
        return "coordinates" if column in pose else "rates"
    match = re.fullmatch(r".+_([fm])[xyz]", column)
    return "efforts" if match is None else {"f": "forces", "m": "moments"}[match.group(1)]


def _cell(one: dict[str, np.ndarray], other: dict[str, np.ndarray], columns: list[str], compared: list[str],
          unit_group) -> tuple[float, set[str]]:
    """The worst ``|other - one| / s_g(one)`` over ``columns`` and the rows both give, ``s_g`` over every
    ``compared`` column of the unit group (module docstring), and the columns where it occurs (to 1e-9: a
    joint's force may be another's, equal and opposite, to the bit)."""
    both = {c: np.isfinite(one[c]) & np.isfinite(other[c]) for c in compared}
    scale: dict[str, float] = {}
    for c in compared:
        scale[unit_group(c)] = max(scale.get(unit_group(c), 0.0), float(np.abs(one[c][both[c]]).max()))
    worst = {c: float(np.abs(other[c] - one[c])[both[c]].max()) / scale[unit_group(c)] for c in columns}
    value = max(worst.values())
    return value, {c for c, v in worst.items() if v >= value * (1.0 - 1e-9)}


def test_the_report_shows_every_pair_of_engines(tmp_path: Path) -> None:
    out = tmp_path / "run"
    result = CliRunner().invoke(main, ["validate", "rssr", "-o", str(out), "--engines", ",".join(ENGINES),
                                       "--jobs", "1"])
    assert result.exit_code == EXIT_PASS, result.output
    spec = table_spec("rssr", linkage_case("rssr"))
    tables = {e: _table(out, CASE, e) for e in ENGINES}
    compared = [*spec.kinematics, *spec.forces, *spec.moments]
    groups: dict[str, list[str]] = {}
    for c in compared:
        groups.setdefault(_group(c, spec.pose, spec.rates), []).append(c)
    assert list(groups) == ["coordinates", "rates", "forces", "moments", "efforts"]
    markdown = (out / "report.md").read_text()
    section = markdown.split("## Agreement of every pair of engines\n", 1)[1].split("\n## ", 1)[0]
    assert "informative, not a verdict" in section
    header, *rows = [line for line in section.splitlines() if line.startswith("| ") and "---" not in line]
    assert header == "| pair | kind | cases | statuses | " + " | ".join(groups) + " |"
    pairs = [(one, other) for i, one in enumerate(ENGINES) for other in ENGINES[i + 1:]]
    assert len(rows) == len(pairs)
    stored = {(p["one"], p["other"]): p for p in json.loads((out / "summary.json").read_text())["pairs"]}
    for (one, other), line in zip(pairs, rows):
        cells = [cell.strip() for cell in line.strip("|").split("|")]
        kind = "gate" if one == "dualmech" else "informative"
        assert cells[:4] == [f"{one} – {other}", kind, "1", "agree"]
        looser = [max(TOLERANCES[e][i] for e in (one, other) if e in TOLERANCES) for i in (0, 1)]
        for (group, columns), cell in zip(groups.items(), cells[4:]):
            value, worst = _cell(tables[one], tables[other], columns, compared, spec.unit_group)
            held = stored[one, other]["cells"][group]
            assert_allclose(held["max_rel"], value, rtol=1e-9, atol=0, err_msg=f"{one}-{other} {group}")
            tolerance = looser[0] if group in ("coordinates", "rates") else looser[1]
            assert held["tolerance"]["value"] == tolerance and value <= tolerance
            shown = cell.replace("\\", "")
            assert shown.rsplit(" ", 1)[0] == f"✓ {held['max_rel']:.2g} ({tolerance:g})"
            assert shown.rsplit(" ", 1)[1] in worst, (shown, worst)
    html = (out / "report.html").read_text()
    assert html.count('<table id="pair-table">') == 1 and "informative, not a verdict" in html
