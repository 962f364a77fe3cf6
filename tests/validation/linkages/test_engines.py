"""The linkages' engine registry: every engine by name, the simulation only where it applies, refusals in
one line."""

from __future__ import annotations

import numpy as np
import pytest

from dualmech.models.inputs import CaseError
from dualmech.models.linkages import CASES, summary
from dualmech.models.linkages import solve_linkage as in_house
from dualmech.validation.engines import ENGINES, solve_linkage
from dualmech.validation.linkages.mujoco_rssr_sim import SIM_COLUMNS
from tests.models.linkages.cases import bundled

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


def test_the_simulation_gives_its_columns_at_its_own_states() -> None:
    table = solve_linkage("rssr", engine="mujoco-sim")
    assert table.engine == "mujoco-sim" and len(table) > 150 and (table.status == "ok").all()
    assert all(np.isfinite(table[c]).all() for c in SIM_COLUMNS)
    assert np.isnan(table["j1_fx"]).all() and table.meta["gives"] == SIM_COLUMNS
    assert np.array_equal(np.degrees(table.meta["crank"].theta), table["theta1_deg"])


def test_engines_that_do_not_solve_a_case_are_refused_in_one_line() -> None:
    torque = bundled()
    torque["loads"]["drive_torque"] = torque["loads"].pop("output_torque")
    with pytest.raises(CaseError, match=r"engine: 'mujoco-sim' does not solve this RSSR case .*servo-driven"):
        solve_linkage(torque, engine="mujoco-sim")
    with pytest.raises(CaseError, match=r"engine: expected one of " + ", ".join(ENGINES) + r", got 'adams'"):
        solve_linkage("rssr", engine="adams")
