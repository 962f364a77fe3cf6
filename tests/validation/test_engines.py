"""The linkages' engine registry: every engine by name, the simulation only where it applies, refusals in
one line."""

from __future__ import annotations

import numpy as np
import pytest

from dualmech.models.inputs import CaseError
from dualmech.models.linkages import CASES, linkage_case, summary
from dualmech.models.linkages import solve_linkage as in_house
from dualmech.validation.engines import ENGINES, solve_linkage
from dualmech.validation.judges.presets.engines import simulate_case
from tests.linkage_cases import bundled

pytest.importorskip("pinocchio")
pytest.importorskip("mujoco")


def test_every_engine_by_name(tmp_path) -> None:
    path = tmp_path / "four-bar.toml"
    path.write_text((CASES / "rssr.toml").read_text())
    assert solve_linkage(str(path)).to_csv() == in_house(str(path)).to_csv()
    table = solve_linkage(str(path), engine="pinocchio")
    assert table.engine == "pinocchio"
    assert summary(table).startswith("pinocchio: rssr-crank-rocker, 180 positions: 180 ok")
    assert solve_linkage("rccc", engine="mujoco").engine == "mujoco"


@pytest.mark.parametrize("kind", ["rssr", "rccc"])
def test_the_simulation_is_the_generated_judge(kind: str) -> None:
    """``mujoco-sim`` of an RSSR or RCCC case is the simulated judge generated from its joint table
    (:func:`~dualmech.validation.judges.presets.engines.simulate_case`), at the case's rows."""
    table = solve_linkage(kind, engine="mujoco-sim")
    again = simulate_case(linkage_case(kind))
    assert table.engine == again.engine == "mujoco-sim" and (table.status == "ok").all()
    for column in table.columns:
        np.testing.assert_array_equal(table[column], again[column], err_msg=column)


def test_engines_that_do_not_solve_a_case_are_refused_in_one_line() -> None:
    torque = bundled()
    torque["loads"]["drive_torque"] = torque["loads"].pop("output_torque")
    with pytest.raises(CaseError, match=r"engine: 'mujoco-sim' does not solve this RSSR case .*servo-driven"):
        solve_linkage(torque, engine="mujoco-sim")
    with pytest.raises(CaseError, match=r"engine: expected one of " + ", ".join(ENGINES) + r", got 'adams'"):
        solve_linkage("rssr", engine="adams")
