"""``dualmech simulate`` on a loop table (``[mechanism] kind = "loop"``): dispatched to the loop table's
forward dynamics (``models/loop/forward_dynamics.py``), its own columns; what it cannot simulate (a drive
by a slide, a motion leaving the range a drive that does not turn fully is tabulated over) and the
slider's options refused in one line (exit 2)."""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from numpy.testing import assert_allclose

from dualmech.cli import main
from dualmech.models.linkages import linkage_case
from dualmech.models.loop import forward_dynamics as loop_fd
from dualmech.models.loop.columns import loop_spec
from dualmech.validation.exit_codes import EXIT_BAD_INPUT

TORQUE = "0.3*sin(5*t) - 0.01*psidot"
ARGS = ["--duration", "0.2", "--samples", "11", "--torque", TORQUE, "--damping", "0.002", "--psi0", "30",
        "--psidot0", "5"]
#: A slider crank as a loop table driven at its slider (joint 4, P).
SLIDE_DRIVEN = """name = "slide-driven"
[mechanism]
kind = "loop"
[[joint]]
type = "R"
a = 0.05
[[joint]]
type = "S"
a = 0.2
[[joint]]
type = "S"
alpha_deg = 90.0
[[joint]]
type = "P"
alpha_deg = 270.0
a = 0.03
[drive]
joint = 4
positions = [0.2, 0.21]
speed = 0.1
""" + "[[body]]\nmass = 1.0\nside = 0.01\n" * 3


def _read(text: str) -> tuple[list[str], np.ndarray, list[str]]:
    rows = list(csv.reader(io.StringIO(text)))
    return rows[0], np.array([[float(v) for v in r[:-1]] for r in rows[1:]]), [r[-1] for r in rows[1:]]


@pytest.mark.parametrize("name", ["rscr", "rsrc", "7r"])
def test_simulate_writes_the_loop_motion(name: str, tmp_path: Path) -> None:
    out = tmp_path / "motion.csv"
    result = CliRunner().invoke(main, ["simulate", name, *ARGS, "-o", str(out)])
    assert result.exit_code == 0, result.output
    header, values, status = _read(out.read_text())
    mechanism = linkage_case(name)
    table = [c for c in loop_spec(mechanism).columns if c != "theta1_deg"]
    assert header == ["t", "theta1_deg", *loop_fd.SIMULATION_COLUMNS, *table, "status"]
    assert values.shape == (11, len(header) - 1) and status == ["ok"] * 11
    direct = loop_fd.simulate(mechanism, 0.2, torque=TORQUE, damping=0.002, psi0=np.radians(30.0),
                              psidot0=5.0, samples=11)
    for k, column in enumerate(header[:-1]):  # repr() round-trips floats exactly
        assert_allclose(values[:, k], direct.columns()[column], rtol=0, atol=0, err_msg=column)
    assert values[0, header.index("psi")] == np.radians(30.0) and values[0, header.index("psi_dot")] == 5.0
    assert "given loads: work" in result.output and "work-energy residual" in result.output
    assert "\ndrive: " in result.output


@pytest.mark.parametrize(("args", "words"), [
    (["rscr", "--slider-load", "1"], "--slider-load: 'rscr' is a loop case, which has no slider"),
    (["rscr", "--torque", "2*s4dot"], "torque: '2*s4dot' uses s4dot, the slider crank's slider"),
    (["7r", "--samples", "3", "--duration", "3"], "simulate: the drive reached -"),
])
def test_simulate_refuses_in_one_line(args: list[str], words: str) -> None:
    result = CliRunner().invoke(main, ["simulate", *args] + ([] if "--duration" in args else
                                                             ["--duration", "0.1"]))
    assert result.exit_code == EXIT_BAD_INPUT, result.output
    lines = [line for line in result.stderr.strip().splitlines() if not line.startswith("simulate ")]
    assert len(lines) == 1 and lines[0].startswith("dualmech: error: ") and words in lines[0], result.stderr


def test_simulate_refuses_a_drive_by_a_slide(tmp_path: Path) -> None:
    path = tmp_path / "slide.toml"
    path.write_text(SLIDE_DRIVEN)
    result = CliRunner().invoke(main, ["simulate", str(path), "--duration", "0.1"])
    assert result.exit_code == EXIT_BAD_INPUT, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "'slide-driven' is driven at joint[4]'s slide (P)" in lines[0], result.stderr
