"""The simulated judge drives the input through every angle of a case, so it solves only cases whose loop
closes at all of them; elsewhere it is "not applicable" and the rigid judges still check every row."""

from __future__ import annotations

import html
import json
from pathlib import Path

import pytest

from dualmech.models.linkages import CASES, linkage_case
from dualmech.validation import engines
from dualmech.validation.matrix import cases as matrix
from dualmech.validation.matrix import load_matrix
from dualmech.validation.matrix.cases import not_applicable
from tests.validation.runs import run_cases

pytest.importorskip("mujoco")


def _partial(tmp_path: Path) -> Path:
    """The bundled RSSR with a longer input crank: the coupler cannot reach at 142..202 deg; every 6 deg (ten
    rows in the gap, 51 outside it: the runs of a third of the bundled rows cost a third)."""
    text = (Path(CASES) / "rssr.toml").read_text()
    assert "input_crank = 0.1 " in text and "step = 2.0 }" in text
    path = tmp_path / "partial.toml"
    path.write_text(text.replace("input_crank = 0.1 ", "input_crank = 0.3 ")
                    .replace("step = 2.0 }", "step = 6.0 }"))
    return path


def test_the_simulation_solves_only_cases_that_close_at_every_angle(tmp_path) -> None:
    assert engines.solves("mujoco-sim", "rssr", linkage_case("rssr"))
    assert engines.solves("mujoco-sim", "rccc", linkage_case("rccc"))
    partial = linkage_case(_partial(tmp_path))
    assert not engines.solves("mujoco-sim", "rssr", partial)
    assert engines.solves("pinocchio", "rssr", partial) and engines.solves("mujoco", "rssr", partial)


def test_a_partly_assembling_case_passes_on_the_rigid_judges(tmp_path, monkeypatch) -> None:
    run = run_cases(load_matrix(_partial(tmp_path)))  # a Path, as the Python API allows
    assert run.comparison.verdict == "PASS"
    judged = {c.engine for c in run.comparison.checks if c.n_compared}
    assert {"pinocchio", "mujoco"} <= judged and "mujoco-sim" not in judged
    # the fault this rule prevents: the servo pushes the input into the gap, and the simulation's rows
    # there have no in-house counterpart
    monkeypatch.setattr(matrix, "solves", lambda engine, kind, case: kind in engines.ENGINES[engine])
    assert run_cases(load_matrix(str(_partial(tmp_path)))).comparison.verdict == "FAIL"


def test_each_engine_not_applicable_says_why(tmp_path: Path) -> None:
    """A user's five-joint table driven at its second joint, assembling from 125 deg: the simulation (the loop
    does not close at every position) and the Exudyn judge (it drives the first joint only) do not solve it.
    The console, both report pages and ``summary.json`` say so with each engine's one-line reason
    (:data:`~dualmech.validation.engines.SIM_REFUSALS`), never a bare "–"; the engines that solve it are not
    named there."""
    import dualmech

    table = Path(__file__).parents[1] / "data" / "rrcrc.toml"
    text = table.read_text()
    assert text.count("\njoint = 1\n") == 1
    path = tmp_path / "rrcrc.toml"
    path.write_text(text.replace("\njoint = 1\n", "\njoint = 2\n"))
    run = dualmech.validate(path, tmp_path / "run", engines="dualmech,mujoco,mujoco-sim,exudyn", jobs=1)
    run.write_report()
    why = {"mujoco-sim": engines.SIM_REFUSALS["loop-closes"][2:],
           "exudyn": engines.SIM_REFUSALS["exudyn"][2:]}
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert [(c["id"], c["engines"], c["not_applicable"]) for c in summary["cases"]] == [
        ("rrcrc", ["dualmech", "mujoco"], why)]
    lines = [f"{e} on rrcrc: {w}" for e, w in why.items()]
    assert not_applicable(run.matrix) == {"rrcrc": why}
    markdown = (tmp_path / "run" / "report.md").read_text()
    assert f"– not applicable: {'; '.join(lines)}." in markdown.replace("\\", "")
    registry = json.loads((tmp_path / "run" / "run.json").read_text())["registry"]
    assert registry["exudyn"] == registry["mujoco-sim"] == ""  # neither ran: the page says so, never "= "
    none = "(solves no case of this run)"
    assert f"; mujoco-sim = {none}; exudyn = {none}" in markdown.replace("\\", "")
    page = (tmp_path / "run" / "report.html").read_text()
    assert f'id="not-applicable">– not applicable: {"; ".join(lines)}.</p>' in html.unescape(page)
    console = [line for line in run.console_summary("1 job", "report.md") if isinstance(line, str)]
    said = [c for c in console if "not applicable" in c]
    assert said == [f"[dim]– not applicable: {line}[/]" for line in lines]
    bundled = load_matrix("rscr")
    assert not_applicable(bundled) == {}
