"""Every generated judge names a loop table's assembly limit as the in-house engine does, and the gate passes.

The slider crank's table 1e-6 a2 inside its planar edge of assembly (``a4 = a2 - a1``: the rod normal to the
slider line at ``theta1 = 0``, closed form): each engine's own pose gives its closure condition
(``models/loop/condition.py``), below the band at that row only, so each says ``assembly_limit`` there (pose
and condition given, no rates or reactions) and ``ok`` elsewhere; the gate compares every column on the rows
both give, the condition with the pose.
"""

from __future__ import annotations

import numpy as np
import pytest

from dualmech.models.loop.columns import loop_spec
from dualmech.models.loop.table import solve_loop_table
from dualmech.validation.compare.tables import judge_checks
from tests.models.loop.test_condition import _slider_crank
from tests.validation.test_engine_statuses import A1, A2

JUDGES = {"pinocchio": ("pinocchio", "dualmech.validation.judges.pinocchio_loop.table"),
          "mujoco": ("mujoco", "dualmech.validation.judges.mujoco_loop.table"),
          "exudyn": ("exudyn", "dualmech.validation.judges.exudyn_loop.table")}


@pytest.fixture(scope="module")
def near_edge():
    _, mechanism = _slider_crank(A2 - A1 - 1e-6 * A2, {"start": -20.0, "stop": 21.0, "step": 5.0})
    return mechanism, solve_loop_table(mechanism)


@pytest.mark.parametrize("judge", list(JUDGES))
def test_every_judge_names_the_assembly_limit_and_agrees(near_edge, judge: str) -> None:
    library, module = JUDGES[judge]
    pytest.importorskip(library)
    mechanism, reference = near_edge
    mine = pytest.importorskip(module).solve_table(mechanism)
    expected = ["ok"] * 4 + ["assembly_limit"] + ["ok"] * 4
    assert list(reference.status) == expected and list(mine.status) == expected, list(mine.status)
    assert np.isfinite(mine["closure_condition"]).all() and np.isnan(mine["s4_ddot"][4])
    checks, _ = judge_checks("near-edge", reference, mine, loop_spec(mechanism))
    failed = [(c.quantity, c.max_rel, c.detail) for c in checks if not c.passed]
    assert not failed
    assert any(c.quantity == "closure_condition" for c in checks)
