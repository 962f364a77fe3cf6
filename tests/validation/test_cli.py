"""The dualmech command line: solve and cases (other subcommands are tested beside their modules)."""

import numpy as np
import pytest
from click.testing import CliRunner
from numpy.testing import assert_allclose

from dualmech.core.table import COLUMNS, read_csv
from dualmech.models.slider_crank import solve_case
from dualmech.models.case import load_case
from dualmech.validation.cli import main


def test_cases_lists_every_preset():
    result = CliRunner().invoke(main, ["cases"])
    assert result.exit_code == 0
    assert len(result.output.strip().splitlines()) == 9
    assert "thesis/a4-30-s1-3.5" in result.output


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
