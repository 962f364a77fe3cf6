"""``dualmech validate rssr | rccc | linkages | FILE``: the linkage matrix format, the run folder, the report,
the verdict line and the exit codes (0 pass, 1 fail, 2 bad input)."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from dataclasses import replace

import numpy as np
import pytest
from click.testing import CliRunner

from dualmech.cli import main
from dualmech.models.kinds import kind_of
from dualmech.models.linkages import CASES
from dualmech.validation.exit_codes import EXIT_BAD_INPUT, EXIT_FAIL, EXIT_PASS
from dualmech.validation.matrix import MatrixError, load_matrix
from dualmech.validation.matrix.cases import is_listed_source
from dualmech.validation.report.figures import PendingFigures
from tests.engine_faults import fault_engine
from tests.validation.runs import run_cases, table_figures

pytest.importorskip("pinocchio")
pytest.importorskip("mujoco")


def test_which_sources_are_linkage_runs(tmp_path) -> None:
    """Never raises: a slider-crank matrix, preset or a missing file is not one (the slider crank's reader
    then says what is wrong)."""
    matrix = tmp_path / "m.toml"
    matrix.write_text('name = "m"\nlinkages = ["rssr"]\n')
    for source, expected in (("rssr", True), ("rccc", True), ("linkages", True), (str(matrix), True),
                             (str(CASES / "rccc.toml"), True), ("thesis-1991", False), ("joints", False),
                             ("thesis/ideal", False), ("no-such", False), (None, False)):
        assert is_listed_source(source) is expected, source


@pytest.mark.parametrize("text, words", [
    ('name = "m"\nlinkages = ["rssr"]\nsweeps = 1\n',
     "sweeps: unknown key of a matrix of listed cases (valid: name,"),
    ('name = "m"\nlinkages = ["rssr"]\nsweep = 1\n',
     "sweep: expected [[sweep]] tables (case, key, values), got 1"),
    ('name = "m"\nlinkages = ["rssr"]\n[[sweep]]\ncase = "rscr"\nkey = "joint[7].a"\nvalues = [1.0]\n',
     "sweep[1].key: 'joint[7].a': joint has rows 1..4, got 7"),
    ('name = "m"\nlinkages = ["rssr"]\n[[sweep]]\ncase = "rscr"\nkey = "joint.a"\nvalues = [1.0]\n',
     "sweep[1].key: 'joint.a': joint is an array of rows: name one, e.g. joint[1]"),
    ('name = "m"\nlinkages = ["rssr"]\n[[sweep]]\ncase = "rscr"\nkey = "gear.a"\nvalues = [1.0]\n',
     "sweep[1].key: 'gear.a': the case has no 'gear'"),
    ('name = "m"\nlinkages = ["rssr"]\n[[sweep]]\ncase = "rscr"\nkey = "joint[2].a"\nvalues = ["long"]\n',
     "sweep[1]: joint[2].a = 'long': joint[2].a: expected a finite number"),
    ('name = "m"\nlinkages = ["rssr"]\n[[sweep]]\ncase = "rscr"\nkey = "joint[2].a"\nvalues = []\n',
     "sweep[1].values: expected a list of 1 to 100 values, got []"),
    ('name = "m"\nlinkages = ["rssr"]\n[[sweep]]\ncase = "rscr"\nkeys = "a"\n',
     "sweep[1].keys: unknown key (valid: case, key, values)"),
    ('name = "m"\nlinkages = []\n', "linkages: expected a list of 1 to 100 cases"),
    ('name = "m"\nlinkages = ["nope"]\n', "linkages[0]: 'nope' is not a case (case: 'nope' is neither"),
    ('name = "m"\ncases = ["rssr"]\nlinkages = ["rssr"]\n',
     "linkages: the old name of cases; give one of them"),
    ('name = "m"\nlinkages = ["rssr", "rssr"]\n', "linkages: two cases are named 'rssr-crank-rocker'"),
    ('name = "m"\nlinkages = ["rssr"]\nengines = ["dualmech", "adams"]\n', "engines: 'adams' is not an "),
    ('name = "m"\nlinkages = ["rssr"]\nengines = ["dualmech"]\n', "engines: ['dualmech'] has no judge"),
    ('name = "../x"\nlinkages = ["rssr"]\n', "name: '../x'"),
])
def test_bad_linkage_matrices_are_refused_in_one_line(tmp_path, text: str, words: str) -> None:
    path = tmp_path / "m.toml"
    path.write_text(text)
    _refused_in_one_line(path, words)


def _refused_in_one_line(path, words: str) -> None:
    """Matrix file ``path`` is refused with one line holding ``words``, by the reader and by ``validate``
    (exit code 2)."""
    with pytest.raises(MatrixError) as err:
        load_matrix(path)
    assert words in str(err.value) and "\n" not in str(err.value), str(err.value)
    result = CliRunner().invoke(main, ["validate", str(path), "-o", str(path.parent / "run")])
    assert result.exit_code == EXIT_BAD_INPUT and result.output.count("\n") == 1, result.output


def test_a_matrix_file_names_cases_beside_it(tmp_path) -> None:
    (tmp_path / "mine.toml").write_text((CASES / "rccc.toml").read_text().replace("rccc-example", "mine"))
    path = tmp_path / "m.toml"
    path.write_text('name = "m"\nlinkages = ["mine.toml", "rssr"]\nengines = ["dualmech", "mujoco"]\n')
    matrix = load_matrix(path)
    assert [c.id for c in matrix.cases] == ["mine", "rssr-crank-rocker"] and matrix.judges == ("mujoco",)


def test_validate_rssr_passes_and_writes_its_report(tmp_path) -> None:
    out = tmp_path / "run"
    result = CliRunner().invoke(main, ["validate", "rssr", "-o", str(out)])
    assert result.exit_code == EXIT_PASS, result.output
    assert "PASS: 79 of 79 checks passed (ratio = worst relative difference / tolerance; dead c. = " \
        "dead-centre rows excluded, counted); worst ratio: pinocchio " \
        in result.output
    summary = json.loads((out / "summary.json").read_text())
    assert summary["verdict"] == "PASS" and set(summary["worst"]) == {"pinocchio", "mujoco", "mujoco-sim"}
    assert (out / "figures" / "linkage-rssr-crank-rocker.png").stat().st_size > 10_000
    markdown = (out / "report.md").read_text()
    assert "| case | kind | dead-centre rows | pinocchio | mujoco | mujoco-sim |" in markdown
    assert "| rssr-crank-rocker | rssr | 0 | ✓ " in markdown and "## Stroke" not in markdown
    html = (out / "report.html").read_text()  # the slider crank's page: every figure interactive
    assert html.count('<div class="plot"') == 4 and '<img src="data:' not in html  # 3 heat maps, the case
    assert {p.name for p in (out / "figures").iterdir()} == {
        "linkage-rssr-crank-rocker.png", *(f"heatmap-{e}.png" for e in ("pinocchio", "mujoco", "mujoco-sim"))}
    assert {p.name for p in (out / "tables" / "rssr-crank-rocker").iterdir()} == {
        "dualmech.csv", "pinocchio.csv", "mujoco.csv", "mujoco-sim.csv"}
    again = CliRunner().invoke(main, ["validate", "rssr", "-o", str(out), "--engines", "dualmech,pinocchio"])
    assert again.exit_code == EXIT_PASS and "PASS: 27 of 27 checks passed" in again.output, again.output


def test_validate_fails_with_exit_code_1_on_a_faulty_judge(tmp_path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Deliberate fault: Pinocchio's output angle 1e-6 deg off on the RCCC."""
    def shifted(table):
        return replace(table, columns={**table.columns, "theta4_deg": table.columns["theta4_deg"] + 1e-6})

    fault_engine(monkeypatch, "pinocchio", shifted, ("rccc",))
    result = CliRunner().invoke(main, ["validate", "linkages", "-o", str(tmp_path / "run"), "--jobs", "1"])
    assert result.exit_code == EXIT_FAIL, result.output
    assert "FAIL: 181 of 182 checks passed" in result.output
    assert "✗ rccc-example / pinocchio: theta4_deg: max rel" in result.output
    assert json.loads((tmp_path / "run" / "summary.json").read_text())["n_failed"] == 1


def test_a_judges_heat_map_marks_its_failed_check(tmp_path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The report's heat map of a judge (the slider crank's, planned by
    :func:`~dualmech.validation.linkages.report.figure_specs`): the ratio of every check per case and column,
    the columns of both kinds (their union; NaN where a case has none), and the one failed check (the RCCC's
    ``theta4_deg``, shifted 1e-6 deg) marked, no other."""
    def shifted(table):
        return replace(table, columns={**table.columns, "theta4_deg": table.columns["theta4_deg"] + 1e-6})

    fault_engine(monkeypatch, "pinocchio", shifted, ("rccc",))
    run = run_cases(load_matrix("linkages").with_engines(("dualmech", "pinocchio")), jobs=1)
    (heatmap,) = [spec for spec in table_figures(run) if spec.section == "heatmap"]
    engine, ids, qs, ratios, failed, _, _ = heatmap.job[1]
    assert heatmap.key == "heatmap-pinocchio" and engine == "pinocchio" and heatmap.static
    assert ids == [e.id for e in run.matrix.cases]
    assert qs == list(dict.fromkeys(c.quantity for c in run.comparison.checks
                                    if c.engine == "pinocchio" and c.quantity != "status"))
    assert {"phi4_deg", "theta4_deg"} <= set(qs)
    assert [(ids[i], qs[j]) for i, j in zip(*failed.nonzero())] == [("rccc-example", "theta4_deg")]
    for c in run.comparison.checks:
        if c.engine == "pinocchio" and c.quantity != "status":
            assert ratios[ids.index(c.case), qs.index(c.quantity)] == c.ratio
    assert np.isnan(ratios[ids.index("rccc-example"), qs.index("phi4_deg")])
    pending = PendingFigures(1)
    pending.add([heatmap])
    (drawn,) = pending.collect()
    assert drawn.png.startswith(b"\x89PNG") and '"type":"heatmap"' in drawn.plot


def test_a_linkage_run_is_a_ci_gate_junit_and_baseline(tmp_path) -> None:
    """--junit (one test per case and engine that solves it), --write-baseline, then --baseline: no
    regression; the same baseline with the reference's output-angle peak 0.1 % off: a regression, exit 1, in
    the JUnit file too; --report-dir puts the report elsewhere."""
    run, junit, baseline = tmp_path / "run", tmp_path / "junit.xml", tmp_path / "baseline.json"
    args = ["validate", "rccc", "-o", str(run), "--engines", "dualmech,pinocchio", "--jobs", "1"]
    first = CliRunner().invoke(main, [*args, "--junit", str(junit), "--write-baseline", str(baseline),
                                      "--report-dir", str(tmp_path / "report")])
    assert first.exit_code == EXIT_PASS, first.output
    assert f"baseline written: {baseline}" in first.output and f"JUnit: {junit}" in first.output
    assert (tmp_path / "report" / "report.md").is_file() and not (run / "report.md").exists()
    suite = ET.parse(junit).getroot().find("testsuite")
    assert [(t.get("classname"), t.get("name")) for t in suite.iter("testcase")] == [
        ("rccc-example.rccc-example", "dualmech"), ("rccc-example.rccc-example", "pinocchio")]
    assert (suite.get("tests"), suite.get("failures"), suite.get("errors")) == ("2", "0", "0")
    data = json.loads(baseline.read_text())
    reference = data["cases"]["rccc-example"]["reference"]
    assert reference["stroke"] is None and reference["peaks"]["theta4_deg"] > 0
    checks = data["cases"]["rccc-example"]["checks"]["pinocchio"]
    assert checks["theta4_deg"]["passed"] and checks["theta4_deg"]["max_rel"] < 1e-9
    same = CliRunner().invoke(main, [*args, "--resume", "--baseline", str(baseline)])
    assert same.exit_code == EXIT_PASS and f"baseline {baseline}: no regression" in same.output, same.output
    reference["peaks"]["theta4_deg"] *= 1.001  # the in-house output angle's peak "was" 0.1 % larger
    baseline.write_text(json.dumps(data))
    regressed = CliRunner().invoke(main, [*args, "--resume", "--baseline", str(baseline), "--junit",
                                          str(junit)])
    assert regressed.exit_code == EXIT_FAIL, regressed.output
    assert "REGRESSION against" in regressed.output
    assert "rccc-example / dualmech: theta4_deg: in-house scale" in regressed.output
    assert ET.parse(junit).getroot().find("testsuite").get("failures") == "1"


def test_a_linkage_baseline_of_another_matrix_is_refused_before_the_run(tmp_path) -> None:
    baseline = tmp_path / "b.json"
    first = CliRunner().invoke(main, ["validate", "rccc", "-o", str(tmp_path / "a"), "--engines",
                                      "dualmech,pinocchio", "--write-baseline", str(baseline)])
    assert first.exit_code == EXIT_PASS, first.output
    other = CliRunner().invoke(main, ["validate", "rssr", "-o", str(tmp_path / "b"), "--baseline",
                                      str(baseline)])
    assert other.exit_code == EXIT_BAD_INPUT and other.output.count("\n") == 1, other.output
    assert "is for matrix 'rccc-example', not 'rssr-crank-rocker'" in other.output
    assert not (tmp_path / "b").exists()


def test_a_linkage_run_stores_each_result_and_resumes(tmp_path) -> None:
    """The matrix runner's rules for a linkage run: every result stored in ``cases/<id>.json`` as it
    finishes, and ``--resume`` runs only what is missing (here the judge added to a finished run)."""
    out = tmp_path / "run"
    first = CliRunner().invoke(main, ["validate", "rssr", "-o", str(out), "--engines", "dualmech,pinocchio",
                                      "--jobs", "1"])
    assert first.exit_code == EXIT_PASS, first.output
    stored = json.loads((out / "cases" / "rssr-crank-rocker.json").read_text())["engines"]
    assert set(stored) == {"dualmech", "pinocchio"}
    again = CliRunner().invoke(main, ["validate", "rssr", "-o", str(out), "--engines",
                                      "dualmech,pinocchio,mujoco", "--jobs", "1", "--resume"])
    assert again.exit_code == EXIT_PASS, again.output
    run = json.loads((out / "run.json").read_text())
    assert (run["ran"], run["skipped"], run["resumed"]) == (1, 2, True)
    resumed = json.loads((out / "cases" / "rssr-crank-rocker.json").read_text())["engines"]
    assert set(resumed) == {"dualmech", "pinocchio", "mujoco"} and resumed["pinocchio"] == stored["pinocchio"]


def test_report_of_a_linkage_run_compares_its_stored_results(tmp_path) -> None:
    """``dualmech report`` of a linkage run folder rewrites its report from the stored tables (it was an
    internal error: the slider crank's report read a linkage case): the same summary, and a stored table
    changed afterwards (a deliberate fault: the judge's output angle 1e-6 deg off) makes it FAIL."""
    out = tmp_path / "run"
    first = CliRunner().invoke(main, ["validate", "rssr", "-o", str(out), "--engines", "dualmech,pinocchio",
                                      "--jobs", "1"])
    assert first.exit_code == EXIT_PASS, first.output
    summary = json.loads((out / "summary.json").read_text())
    again = CliRunner().invoke(main, ["report", str(out)])
    assert again.exit_code == EXIT_PASS and again.output.startswith("PASS: report"), again.output
    rewritten = json.loads((out / "summary.json").read_text())
    assert (rewritten["verdict"], rewritten["n_checks"]) == (summary["verdict"], summary["n_checks"])
    path = out / "cases" / "rssr-crank-rocker.json"
    stored = json.loads(path.read_text())
    column = stored["engines"]["pinocchio"]["table"]["columns"]["phi4_deg"]
    stored["engines"]["pinocchio"]["table"]["columns"]["phi4_deg"] = [v + 1e-6 for v in column]
    path.write_text(json.dumps(stored))
    faulty = CliRunner().invoke(main, ["report", str(out)])
    assert faulty.exit_code == EXIT_FAIL and faulty.output.startswith("FAIL: report"), faulty.output


#: A matrix of the slider crank's format on a loop table: the base, ``set``, a grid and a list of cases.
BASED = '''
name = "rscr-study"
base = "rscr"
base_label = "nominal"
engines = ["dualmech", "pinocchio"]
set = { "drive.positions" = { start = 0.0, stop = 1.0, step = 0.5 } }
[labels]
"joint[2].a" = "a2"
[[sweep]]
name = "coupler"
grid = { "joint[2].a" = [0.10, 0.14], "drive.speed" = [1.0, 2.0] }
[[sweep]]
name = "one"
include_base = false
fixed = { "drive.speed" = 3.0 }
cases = [ { "joint[2].a" = 0.12 } ]
'''


def _set(table: dict, values: dict) -> dict:
    """``table`` (a parsed case file) with each dotted key (``joint[2].a``) of ``values`` set: the oracle of
    the based matrix's cases, written apart from it."""
    import copy
    import re

    out = copy.deepcopy(table)
    for key, value in values.items():
        *path, leaf = key.split(".")
        node = out
        for step in path:
            name, row = re.fullmatch(r"(\w+)(?:\[(\d+)\])?", step).groups()
            node = node[name] if row is None else node[name][int(row) - 1]
        node[leaf] = value
    return out


def test_a_matrix_of_the_slider_cranks_format_takes_a_linkage_base(tmp_path) -> None:
    """``base`` a loop table: the base with ``set`` first, one case per grid point and listed case (the base
    once, though both sweeps could give it: the second leaves it out), ids from ``base_label`` and the
    ``[labels]`` symbols, and each case the base file with exactly its keys set."""
    import tomllib

    from dualmech.models.linkages import read_linkage

    path = tmp_path / "m.toml"
    path.write_text(BASED)
    assert is_listed_source(path) and is_listed_source(str(path))
    matrix = load_matrix(path)
    assert [c.id for c in matrix.cases] == [
        "nominal", "nominal-a2=0.1_drive.speed=1.0", "nominal-a2=0.1_drive.speed=2.0",
        "nominal-a2=0.14_drive.speed=1.0", "nominal-a2=0.14_drive.speed=2.0",
        "nominal-drive.speed=3.0_a2=0.12"]
    assert matrix.engines == ("dualmech", "pinocchio") and matrix.name == "rscr-study"
    base = read_linkage("rscr")
    common = tomllib.loads(BASED)["set"]
    points = [{}, *({"joint[2].a": a, "drive.speed": w} for a in (0.10, 0.14) for w in (1.0, 2.0)),
              {"drive.speed": 3.0, "joint[2].a": 0.12}]
    for case, point in zip(matrix.cases, points):
        expected = _set(base, {"drive.positions": common["drive.positions"], **point})
        assert {k: v for k, v in case.raw.items() if k != "name"} == \
            {k: v for k, v in expected.items() if k != "name"}, case.id
        assert kind_of(case.raw) == "loop"


@pytest.mark.parametrize("extra, words", [
    ('quantities = ["S4"]\n',
     "quantities: not a key of a matrix whose base is not a slider crank (valid: name,"),
    ('[load_modes]\ntorque = { "loads.drive_torque" = 1.0 }\n', "load_modes: not a key of a matrix whose"),
    ('[tolerances]\nkinematics = 1e-9\n',
     "tolerances: not a key of a matrix whose base is not a slider crank"),
    ('[[sweep]]\nexpect = "no_assembly"\ngrid = { "joint[2].a" = [9.0] }\n',
     "sweep[0].expect: unknown key (valid: cases, fixed, grid, include_base, label, name)"),
    ('[[sweep]]\ngrid = { "joint[9].a" = [0.1] }\n', "sweep[0]: 'joint[9].a': joint has rows 1..4, got 9"),
    ('[[sweep]]\ngrid = { "joint[2].a" = ["long"] }\n',
     "sweep[0]: joint[2].a = 'long': joint[2].a: expected a finite number"),
    ('[[sweep]]\ngrid = { "joint[2].a" = [0.1], "drive.speed" = [1.0] }\ncases = [{}]\n',
     "sweep[0]: give exactly one of grid (a Cartesian product) or cases (a list)"),
    ('[[sweep]]\ngrid = { "joint[2].a" = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0], '
     '"drive.speed" = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0] }\n',
     "sweep[0]: more than 100 cases in the matrix (this sweep 100); a matrix of cases runs at most 100"),
    ('[labels]\n"joint[2].a" = "../a"\n', "labels.'joint[2].a': '../a'"),
])
def test_bad_based_linkage_matrices_are_refused_in_one_line(tmp_path, extra: str, words: str) -> None:
    path = tmp_path / "m.toml"
    path.write_text(f'name = "m"\nbase = "rscr"\n{extra}')
    _refused_in_one_line(path, words)


def test_validate_runs_a_matrix_whose_base_is_a_linkage_case(tmp_path) -> None:
    """Refused before ("base: case: 'rssr' is neither a file nor a bundled preset"): the slider crank's
    format on an RSSR file beside the matrix, run, compared and reported."""
    (tmp_path / "mine.toml").write_text((CASES / "rssr.toml").read_text())
    path = tmp_path / "m.toml"
    path.write_text('name = "mine-study"\nbase = "mine.toml"\nengines = ["dualmech", "pinocchio"]\n'
                    'set = { "motion.angles_deg" = { start = 0.0, stop = 360.0, step = 30.0 } }\n'
                    '[[sweep]]\ngrid = { "geometry.input_crank" = [0.09] }\n')
    out = tmp_path / "run"
    result = CliRunner().invoke(main, ["validate", str(path), "-o", str(out)])
    assert result.exit_code == EXIT_PASS, result.output
    assert "mine-study: 2 cases, engines dualmech, pinocchio" in result.output
    assert {p.name for p in (out / "tables").iterdir()} == {
        "rssr-crank-rocker", "rssr-crank-rocker-geometry.input_crank=0.09"}
    rows = (out / "tables" / "rssr-crank-rocker-geometry.input_crank=0.09" / "dualmech.csv").read_text()
    assert len(rows.strip().splitlines()) == 1 + 12  # the header, 0 to 330 deg by 30
