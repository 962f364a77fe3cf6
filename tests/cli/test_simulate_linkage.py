"""``dualmech simulate`` on a linkage case (RSSR, RCCC): dispatched to the linkage forward dynamics, its own
columns, the options that do not apply refused in one line (exit 2); the slider crank's path as before."""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from numpy.testing import assert_allclose

from dualmech.cli import main
from dualmech.models.kinds import KIND_HOMES, SLIDER_CRANK
from dualmech.models.linkages import CASES, linkage_case, rccc, rssr
from dualmech.models.linkages import forward_dynamics as lfd
from dualmech.models.loop import preset_dynamics
from dualmech.models.simulation import SIMULATION_COLUMNS

TABLE_COLUMNS = {"rssr": rssr.COLUMNS, "rccc": rccc.COLUMNS}
TORQUE = "1 + 0.1*sin(t) - 0.01*psidot"
ARGS = ["--duration", "0.2", "--samples", "11", "--torque", TORQUE, "--damping", "0.01", "--psi0", "30",
        "--psidot0", "5"]


def _read(text: str) -> tuple[list[str], np.ndarray, list[str]]:
    rows = list(csv.reader(io.StringIO(text)))
    return rows[0], np.array([[float(v) for v in r[:-1]] for r in rows[1:]]), [r[-1] for r in rows[1:]]


@pytest.mark.parametrize("kind", ["rssr", "rccc"])
def test_simulate_writes_the_linkage_motion(kind: str, tmp_path: Path) -> None:
    out = tmp_path / "motion.csv"
    result = CliRunner().invoke(main, ["simulate", kind, *ARGS, "-o", str(out)])
    assert result.exit_code == 0, result.output
    header, values, status = _read(out.read_text())
    assert header == [*lfd.SIMULATION_COLUMNS, *TABLE_COLUMNS[kind][1:], "status"]
    assert values.shape == (11, len(header) - 1) and status == ["ok"] * 11
    direct = preset_dynamics.simulate(linkage_case(kind), 0.2, torque=TORQUE, damping=0.01,
                          psi0=np.radians(30.0), psidot0=5.0, samples=11)
    for k, name in enumerate(header[:-1]):  # repr() round-trips floats exactly
        assert_allclose(values[:, k], direct.columns()[name], rtol=0, atol=0, err_msg=name)
    assert values[0, header.index("psi")] == np.radians(30.0) and values[0, header.index("psi_dot")] == 5.0
    assert "output torque" in result.output and "work-energy residual" in result.output


def test_simulate_writes_a_linkage_csv_to_stdout() -> None:
    result = CliRunner().invoke(main, ["simulate", "rccc", "--duration", "0.05", "--samples", "3"])
    assert result.exit_code == 0, result.output
    header, values, _ = _read(result.stdout)
    assert header[:3] == ["t", "theta1_deg", "psi"] and values.shape[0] == 3
    assert "case rccc-example: 3 samples over 0.05 s" in result.stderr


@pytest.mark.parametrize(("option", "words"), [
    (["--slider-load", "1"], "--slider-load: 'rssr' is a rssr case, which has no slider"),
    (["--slider-damping", "0"], "--slider-damping: 'rssr' is a rssr case, which has no slider"),
    (["--torque", "2*s4"], "torque: '2*s4' uses s4, the slider crank's slider"),
    (["--torque", "psi +"], "cannot parse"),
    (["--samples", "1"], "--samples: expected an integer from 2"),
    (["--method", "Euler"], "method: 'Euler' is not a solve_ivp method"),
    (["--rtol", "nan"], "--rtol"),
])
def test_simulate_refuses_what_does_not_apply_to_a_linkage(option: list[str], words: str) -> None:
    result = CliRunner().invoke(main, ["simulate", "rssr", "--duration", "0.1", *option])
    assert result.exit_code == 2, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("dualmech: error: ") and words in lines[0], result.stderr


def test_simulate_refuses_a_linkage_whose_input_does_not_turn(tmp_path: Path) -> None:
    text = (CASES / "rssr.toml").read_text()
    assert "input_crank = 0.1 " in text
    case = tmp_path / "rocker.toml"
    case.write_text(text.replace("input_crank = 0.1 ", "input_crank = 0.3 "))
    result = CliRunner().invoke(main, ["simulate", str(case), "--duration", "0.1"])
    assert result.exit_code == 2 and "does not turn fully" in result.stderr, result.output


def test_the_slider_crank_keeps_its_path(tmp_path: Path) -> None:
    out = tmp_path / "sc.csv"
    result = CliRunner().invoke(main, ["simulate", "ideal", "--duration", "0.01", "--samples", "3",
                                       "--slider-damping", "0.1", "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert _read(out.read_text())[0] == [*SIMULATION_COLUMNS, "status"]
    assert "slider S4:" in result.output


def test_the_kind_table_sends_a_linkage_to_its_forward_dynamics(monkeypatch: pytest.MonkeyPatch) -> None:
    """Deliberate fault: with the RSSR's simulator in the kind table swapped for the slider crank's, the
    command fails instead of integrating the linkage."""
    args = ["simulate", "rssr", "--duration", "0.05", "--samples", "3"]
    assert "output torque" in CliRunner().invoke(main, args).output
    rssr = KIND_HOMES["rssr"]
    monkeypatch.setitem(KIND_HOMES, "rssr", rssr._replace(simulator=KIND_HOMES[SLIDER_CRANK].simulator))
    result = CliRunner().invoke(main, args)
    assert result.exit_code != 0 and "output torque" not in result.output
