"""One design, every engine, one page (issue 14): `dualmech validate CASE.toml`."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from dualmech.cli import main
from dualmech.validation.matrix import MatrixError, load_matrix, parse_matrix

#: The engineer's design of issue 14 (SI units), at a coarse step to keep the test short.
SI_DESIGN = """
name = "my design"
units = "m-N-s"
[geometry]
crank_length = 0.05
rod_length = 0.2
slider_offset = 0.01
slider_twist_deg = 80.0
crank_axial_shift = 0.005
[motion]
crank_rpm = 1500.0
angles_deg = { start = 0.0, stop = 360.0, step = 10.0 }
[bodies]
crank_radius = 0.008
rod_radius = 0.006
slider_side = 0.03
weight_density = 7850.0
gravity_constant = 1.0
[loads]
drive_torque = 5.0
gravity = [0.0, 0.0, -9.81]
"""


@pytest.fixture()
def design(tmp_path) -> Path:
    path = tmp_path / "design.toml"
    path.write_text(SI_DESIGN)
    return path


def test_a_case_file_is_a_matrix_of_one_design_on_every_engine(design):
    m = load_matrix(design)
    assert [c.id for c in m.cases] == ["torque_design"] and m.name == "my_design"
    assert m.engines == ("dualmech", "pinocchio", "mujoco", "mujoco-sim") and not m.of_thesis
    assert load_matrix("thesis/ideal").of_thesis


def test_a_matrix_without_sweeps_is_its_base_case_alone():
    m = parse_matrix({"name": "alone", "base": "thesis/ideal", "engines": ["dualmech", "pinocchio"],
                      "reference": "dualmech"})
    assert len(m.cases) == 1 and m.judges == ("pinocchio",)
    with pytest.raises(MatrixError, match="sweep"):
        parse_matrix({"name": "bad", "base": "thesis/ideal", "engines": ["dualmech", "pinocchio"],
                      "reference": "dualmech", "sweep": []})


def test_validate_one_design_writes_its_report_without_the_thesis_findings(design, tmp_path):
    out = tmp_path / "run"
    result = CliRunner().invoke(main, ["validate", str(design), "-o", str(out), "--jobs", "1",
                                       "--engines", "dualmech,pinocchio,mujoco"])
    assert result.exit_code == 0, result.output
    md = (out / "report.md").read_text()
    assert "**PASS**" in md and "thesis's printed findings" not in md
    assert not (out / "errata.md").exists()


def test_the_thesis_report_carries_its_errata_beside_it(tmp_path):
    out = tmp_path / "run"
    result = CliRunner().invoke(main, ["validate", "thesis/ideal", "-o", str(out), "--jobs", "1",
                                       "--engines", "dualmech,pinocchio"])
    assert result.exit_code == 0, result.output
    md = (out / "report.md").read_text()
    assert "thesis's printed findings" in md and "[errata.md](errata.md)" in md
    assert (out / "errata.md").read_text().startswith("#")


def test_solve_prints_peak_loads_with_units_and_refuses_a_lost_joint_table(design, tmp_path):
    result = CliRunner().invoke(main, ["solve", str(design), "-o", str(tmp_path / "out.csv")])
    assert result.exit_code == 0, result.output
    assert "stroke: 0.098052179 m" in result.output and " N at " in result.output and "N·m" in result.output
    assert "warning: |transmission| < 0.05" in result.output
    refused = CliRunner().invoke(main, ["solve", str(design), "--frames", "joint"])
    assert refused.exit_code == 2 and "give -o" in refused.output


def test_a_constant_or_round_off_panel_is_a_line_of_text_with_its_unit():
    from dualmech.models.case import load_case
    from dualmech.models.slider_crank.analysis import solve_case
    from dualmech.validation.report.plots import flat_note

    case = load_case("thesis/ideal")
    table = solve_case(case)
    assert flat_note([table], "drive_torque", case.units).startswith("constant:\ndrive_torque = 100 lbf·in")
    assert flat_note([table], "j4_mz", case.units).startswith("zero to round-off")
    assert flat_note([table], "j1_fx", case.units) is None


def test_validate_bounds_the_positions_of_one_case(design, tmp_path):
    """A validation run holds whole tables: a case beyond MAX_VALIDATE_POSITIONS is one line, exit 2."""
    from dualmech.validation.matrix import MAX_VALIDATE_POSITIONS

    big = tmp_path / "big.toml"
    big.write_text(design.read_text().replace("step = 10.0", "step = "
                                                             f"{360.0 / (MAX_VALIDATE_POSITIONS + 10):.12g}"))
    result = CliRunner().invoke(main, ["validate", str(big), "-o", str(tmp_path / "run")])
    assert result.exit_code == 2 and "dualmech solve" in result.output and "\n" not in result.output.strip()
