"""The dualmech command line: solve and cases (other subcommands are tested beside their modules)."""

import re
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from numpy.testing import assert_allclose

from dualmech.cli import main
from dualmech.core.table import COLUMNS, read_csv
from dualmech.models.case import load_case, preset_names, preset_path
from dualmech.models.kinds import kind_of
from dualmech.models.linkages import bundled_names, read_linkage
from dualmech.models.slider_crank.analysis import solve_case
from dualmech.validation import solve_output
from dualmech.validation.exit_codes import EXIT_BAD_INPUT


def test_cases_lists_every_preset():
    """Every preset of every kind, with its kind: the slider crank's, then the RSSR's, RCCC's and the loop
    tables' (issue 30: no linkage was listed; issue 32: nor a loop table)."""
    result = CliRunner().invoke(main, ["cases"])
    assert result.exit_code == 0
    lines = result.output.strip().splitlines()
    assert [line.split()[0] for line in lines] == preset_names() + bundled_names()
    kinds = {line.split()[0]: line.split()[1] for line in lines}
    assert {kinds[n] for n in preset_names()} == {"slider-crank"}
    assert {n: kinds[n] for n in bundled_names()} == {"7r": "loop", "rccc": "rccc", "rscr": "loop",
                                                     "rsrc": "loop", "rssr": "rssr"}
    assert "thesis/a4-30-s1-3.5" in result.output


def test_case_path_gives_the_file_of_every_listed_preset():
    """Each name ``cases`` lists: ``case-path`` prints a file of that kind, which ``solve`` reads as the name
    (issue 30: ``case-path rssr`` exited 2 while ``solve rssr`` worked)."""
    runner = CliRunner()
    listed = [line.split()[:2] for line in runner.invoke(main, ["cases"]).output.strip().splitlines()]
    for name, kind in listed:
        result = runner.invoke(main, ["case-path", name])
        assert result.exit_code == 0, f"{name}: {result.output}"
        path = Path(result.output.strip())
        assert path.is_file() and path.suffix == ".toml", name
        data = read_linkage(path) if kind != "slider-crank" else load_case(path).raw
        assert kind_of(data) == kind, name
    assert runner.invoke(main, ["case-path", "ideal"]).output.strip().endswith("thesis/ideal.toml")


def test_case_path_of_an_unknown_name_is_one_line_naming_every_preset():
    result = CliRunner().invoke(main, ["case-path", "no-such-case"])
    assert result.exit_code == 2
    assert len(result.output.strip().splitlines()) == 1
    assert "'no-such-case'" in result.output and "..." not in result.output
    named = re.findall(r"([\w-]+)/\{([^}]*)\}", result.output)  # a folder's presets grouped: thesis/{a, b}
    grouped = {f"{group}/{stem}" for group, stems in named for stem in stems.split(", ")}
    assert set(preset_names()) <= grouped
    assert all(re.search(rf"[ (]{re.escape(name)}[,)]", result.output) for name in bundled_names())


def _ideal_with_offset(tmp_path: Path, offset: float) -> Path:
    """The ``thesis/ideal`` preset's file with ``slider_offset`` changed (a design of the user's own)."""
    text = preset_path("thesis/ideal").read_text()
    assert "slider_offset = 0.0\n" in text
    path = tmp_path / "design.toml"
    path.write_text(text.replace("slider_offset = 0.0\n", f"slider_offset = {offset!r}\n"))
    return path


@pytest.mark.parametrize("engine", ["dualmech", "pinocchio"])
def test_solve_of_a_design_that_assembles_nowhere_is_one_line_and_exit_2(tmp_path, engine):
    """a4 = 100 in with a1 = 12, a2 = 50: the slider line is 88 in from the crank pin at best (at theta1 = 180
    deg, the pin's distance being |a4 + a1 cos theta1|) (issue 30:
    exit 0, "stroke: nan m", "worst closure residual: 4")."""
    result = CliRunner().invoke(main, ["solve", str(_ideal_with_offset(tmp_path, 100.0)), "--engine", engine])
    assert result.exit_code == EXIT_BAD_INPUT, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and "nan" not in lines[0], lines
    assert lines[0].startswith("dualmech: error: thesis-ideal: the design assembles at no crank angle")
    assert "no nearer the slider line than 88 in (theta1 = 180 deg)" in lines[0]
    assert "rod's reach a2 = 50 in" in lines[0] and "|a4| = 100 in exceeds" in lines[0]
    assert "a1 + a2 = 62 in" in lines[0]


def test_solve_of_a_spatial_design_out_of_reach_names_the_least_distance(tmp_path):
    """Out of reach by the axial shift S1 = 60 in (the pin 60 in above the slider line's plane at least), not
    by the offset: the line gives the least distance, and no offset clause."""
    path = _ideal_with_offset(tmp_path, 5.0)
    path.write_text(path.read_text().replace("crank_axial_shift = 0.0", "crank_axial_shift = 60.0"))
    result = CliRunner().invoke(main, ["solve", str(path)])
    assert result.exit_code == EXIT_BAD_INPUT, result.output
    assert "no crank angle: the crank pin comes no nearer the slider line than 60" in result.output
    assert "|a4|" not in result.output


@pytest.mark.parametrize("streamed", [False, True])
def test_solve_of_a_partly_assembling_design_names_the_ranges(tmp_path, monkeypatch, streamed):
    """a4 = 45 in: the rod reaches the line where |45 + 12 cos theta1| <= 50, cos theta1 <= 5/12 (theta1 from
    65.4 to 294.6 deg); the table is written, exit 0, the ranges named,
    and the worst closure residual is a closure's (not the reach's excess on the rows that do not close), also
    in the summary of a long case streamed into the file."""
    if streamed:
        monkeypatch.setattr(solve_output, "STREAM_POSITIONS", 100)
    out = tmp_path / "out.csv"
    result = CliRunner().invoke(main, ["solve", str(_ideal_with_offset(tmp_path, 45.0)), "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert "no_assembly: the rod cannot reach the slider line at crank angles 0..65, 295..359 deg" \
        in result.output
    worst = [line for line in result.output.splitlines() if line.startswith("worst closure residual: ")]
    assert len(worst) == 1 and float(worst[0].split(": ")[1]) < 1e-10, worst
    assert ("streamed" in result.output) == streamed
    table = read_csv(out)
    assert (table.status == "no_assembly").sum() == 131


def test_solve_writes_the_table_and_a_summary(tmp_path):
    out = tmp_path / "out.csv"
    result = CliRunner().invoke(main, ["solve", "a4-30-s1-3.5", "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert out.read_text().splitlines()[0].split(",") == list(COLUMNS)
    table = read_csv(out)
    direct = solve_case(load_case("a4-30-s1-3.5"))
    assert_allclose(table["S4"], direct["S4"], rtol=0, atol=0)  # repr() round-trips floats exactly
    stroke = np.ptp(direct["S4"])
    assert f"stroke: {stroke:.9g} in" in result.output
    assert "(dualmech): ok 360" in result.output


def test_solve_joint_frames(tmp_path):
    out = tmp_path / "out.csv"
    result = CliRunner().invoke(main, ["solve", "ideal", "-o", str(out), "--frames", "joint"])
    assert result.exit_code == 0, result.output
    header = (tmp_path / "out.joint.csv").read_text().splitlines()[0]
    assert header.startswith("theta1_deg,1F1i") and header.endswith("4T4k,status")


def test_unknown_preset_is_one_line(tmp_path):
    result = CliRunner().invoke(main, ["solve", "no-such-case"])
    assert result.exit_code == 2
    assert "no-such-case" in result.output and "presets:" in result.output


def test_mjcf_opens_assembled(tmp_path):
    mujoco = pytest.importorskip("mujoco")
    out = tmp_path / "model.xml"
    result = CliRunner().invoke(main, ["mjcf", "a4-30-s1-3.5", "-o", str(out)])
    assert result.exit_code == 0, result.output
    model = mujoco.MjModel.from_xml_path(str(out))
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    mujoco.mj_forward(model, data)
    gap = data.site("rod_end").xpos - data.site("slider_pin").xpos
    assert np.linalg.norm(gap) < 1e-10 * 50.0


# ----------------------------------------------------------------------------- summary tables in logs

#: A [labels] symbol long enough that the validate table is wider than the 120 columns once used for logs.
LONG_SYMBOL = "offset_of_the_slider_axis_from_the_crank_axis_measured_along_x_in_inches"


def _wide_matrix(tmp_path) -> str:
    path = tmp_path / "wide.toml"
    path.write_text(f'''name = "wide"
base = "thesis/ideal"
engines = ["dualmech", "pinocchio", "mujoco"]
set = {{ "motion.angles_deg" = {{ start = 0.0, stop = 360.0, step = 90.0 }} }}
[labels]
"geometry.slider_offset" = "{LONG_SYMBOL}"
[[sweep]]
name = "a4"
grid = {{ "geometry.slider_offset" = [10.0, 20.0] }}
''')
    return str(path)


def test_validate_table_in_a_log_prints_every_row_and_cell_whole(tmp_path):
    """Through a pipe (CliRunner's output is not a terminal) no cell is cut, however wide the table."""
    result = CliRunner().invoke(main, ["validate", _wide_matrix(tmp_path), "-o", str(tmp_path / "run"),
                                       "--jobs", "1"])
    assert result.exit_code == 0, result.output
    rows = [line for line in result.stdout.splitlines() if line.startswith("torque_")]
    ids = ["torque_base"] + [f"torque_{LONG_SYMBOL}={a4}" for a4 in (10, 20)]
    assert [r.split()[0] for r in rows] == ids, result.stdout
    assert all(r.count("✓") == 2 for r in rows), rows  # both judges' cells, whole
    assert "…" not in result.stdout  # stdout: the progress bars on stderr may abbreviate
    assert max(len(r) for r in rows) > 120  # wider than the 120 columns once used for logs
    assert "stroke (dualmech) [in]" in result.stdout  # the unit of the thesis's cases


def test_summary_console_abbreviates_only_on_a_terminal():
    """The same wide table into a narrow terminal is cut with an ellipsis (what a log must never show)."""
    import io

    from rich.table import Table

    from dualmech.cli.validate import summary_console

    table = Table()
    for name in ("case", "stroke (dualmech)", "pinocchio", "mujoco"):
        table.add_column(name, no_wrap=True)
    table.add_row(f"torque_{LONG_SYMBOL}=10", "24.530151", "✓ 9.2e-05", "✓ 9.0e-05")
    for terminal, cut in ((False, False), (True, True)):
        out = io.StringIO()
        summary_console(terminal, file=out).print(table)  # a StringIO "terminal" is 80 columns wide
        assert ("…" in out.getvalue()) is cut and (LONG_SYMBOL in out.getvalue()) is not cut


@pytest.mark.parametrize("name", ["rssr", "rccc"])
def test_solve_dispatches_other_linkages_to_their_solver(tmp_path, name):
    # [mechanism] kind = "rssr" | "rccc": the linkage's own table, the same as the Python API's
    from dualmech.models.linkages import solve_linkage

    out = tmp_path / f"{name}.csv"
    result = CliRunner().invoke(main, ["solve", name, "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert out.read_text() == solve_linkage(name).to_csv()
    assert " ok" in result.output


@pytest.mark.parametrize("name", ["rssr", "rscr"])
def test_solve_writes_a_linkage_table_as_parquet(tmp_path, name):
    """A linkage's table into Parquet: its own columns in order, then the status words, the numbers the CSV
    gives bit for bit (it was refused: "a linkage's table is written as CSV")."""
    import pyarrow.parquet as pq

    from dualmech.validation.engines import solve_linkage

    out = tmp_path / f"{name}.parquet"
    result = CliRunner().invoke(main, ["solve", name, "-o", str(out)])
    assert result.exit_code == 0, result.output
    read, table = pq.read_table(out).to_pydict(), solve_linkage(name)
    assert list(read) == [*table.columns, "status"]
    for column, values in table.columns.items():
        np.testing.assert_array_equal(np.asarray(read[column], dtype=float), values, err_msg=column)
    assert read["status"] == [str(s) for s in table.status]


@pytest.mark.parametrize(
    "name, args", [("rssr", ["-o", "x.txt"]), ("rccc", ["--frames", "joint", "-o", "x.csv"]),
                   ("rssr", ["--frames", "joint", "-o", "x.csv"])]
)
def test_solve_refuses_what_a_linkage_cannot_give(tmp_path, name, args):
    # a linkage's table is in world frames (the joint-frame table is the slider crank's thesis notation)
    result = CliRunner().invoke(main, ["solve", name, *args])
    assert result.exit_code == 2 and result.output.count("\n") == 1, result.output


def test_benchmark_can_skip_the_judges_and_refuses_empty_runs():
    """``--judge-cases 0`` (and ``--big 0``, ``--main-job 0``) skip those rows; it divided by zero before.
    No cases or no repeats is a usage error (exit 2)."""
    result = CliRunner().invoke(main, ["benchmark", "--cases", "2", "--judge-cases", "0", "--big", "0",
                                       "--repeats", "1", "--main-job", "0"])
    assert result.exit_code == 0, result.output
    assert "yardstick" in result.output
    for skipped in ("Pinocchio", "Parquet", "main job"):
        assert skipped not in result.output, skipped
    for option in ("--cases", "--repeats"):
        assert CliRunner().invoke(main, ["benchmark", option, "0"]).exit_code == 2
