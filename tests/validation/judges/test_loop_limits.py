"""Every generated judge names a loop table's assembly limits and joint locks as the in-house engine does,
follows its branch through a lock, and the gate passes.

Three slider crank tables (``tests/models/loop/test_condition.py``, ``test_engine.py``), each engine on its
own pose (``models/loop/condition.py``):

* ``turning``: 1e-6 a2 inside a turning point of the drive (-60 deg): ``assembly_limit`` there (pose and
  condition given, no rates or reactions), ``no_assembly`` past it;
* ``touching``: the reach touches 1e-6 a2 short of the rod's normal pose at 0 deg, where the drive moves on:
  ``joint_lock`` there (no value), ``ok`` on both sides; ``touching-exactly``: it reaches it (the two
  assembly branches cross at 0 deg, where the engines used to disagree), and every engine goes on along
  the curve it came on, through the crossing, to the other closed-form branch (rows 10 deg apart: at 5 deg
  from the crossing, ``c`` = 8e-3, MuJoCo 3.14's slider acceleration carried its rounding to 1.4e-10 of the
  peak, over its 1e-10);
* ``universal``: a universal joint at the slider locks at 180 deg (the rod along the slider line); the
  closure Jacobian's determinant changes sign there, and every engine follows its branch on through it
  (``joint_lock`` at the lock, ``ok`` after, where each used to say ``branch_jump``);
* ``touching-1deg``, ``universal-1deg``: the same locks swept at 1 deg, whose rows beside the lock (``c`` down
  to 4e-3) carry the judges' closure precision, amplified, to 3.7e-8 of the peak (accelerations): over the
  ordinary tolerance, within the closure-condition law (``validation/compare/conditioning.py``), which the
  gate applies.

The gate compares every column on the rows both give (the condition with the pose).  The Exudyn judge
integrates its rows in time, and its runs' Newton iteration fails where the constraints are singular and
the rates unbounded (``not_converged`` at a turning point) or the branch turns (it says ``branch_jump``
past a lock): known, strict failures (``docs/validation.md``).
"""

from __future__ import annotations

import numpy as np
import pytest

from dualmech.models.loop.columns import loop_spec
from dualmech.models.loop.table import solve_loop_table
from dualmech.validation.compare.tables import judge_checks
from tests.models.loop.test_condition import TOUCHING_A4, TURNING_A4, _slider_crank
from tests.models.loop.test_engine import LOCK_A4, LOCK_TWIST
from tests.validation.test_engine_statuses import A1, A2

JUDGES = {"pinocchio": ("pinocchio", "dualmech.validation.judges.pinocchio_loop.table"),
          "mujoco": ("mujoco", "dualmech.validation.judges.mujoco_loop.table"),
          "exudyn": ("exudyn", "dualmech.validation.judges.exudyn_loop.table")}
#: Each table: its slider crank (a4, crank angles, universal joint, twist) and the words every engine says.
TABLES = {
    "turning": ((TURNING_A4, {"start": -80.0, "stop": -54.0, "step": 5.0}, False, 270.0),
                ["ok"] * 4 + ["assembly_limit", "no_assembly"]),
    "touching": ((TOUCHING_A4, {"start": -20.0, "stop": 21.0, "step": 5.0}, False, 270.0),
                 ["ok"] * 4 + ["joint_lock"] + ["ok"] * 4),
    "touching-exactly": ((A2 - A1, {"start": -30.0, "stop": 31.0, "step": 10.0}, False, 270.0),
                         ["ok"] * 3 + ["joint_lock"] + ["ok"] * 3),
    "universal": ((LOCK_A4, {"start": 170.0, "stop": 191.0, "step": 5.0}, True, LOCK_TWIST),
                  ["ok"] * 2 + ["joint_lock"] + ["ok"] * 2),
    "touching-1deg": ((TOUCHING_A4, {"start": -20.0, "stop": 20.5, "step": 1.0}, False, 270.0),
                      ["ok"] * 20 + ["joint_lock"] + ["ok"] * 20),
    "universal-1deg": ((LOCK_A4, {"start": 160.0, "stop": 200.5, "step": 1.0}, True, LOCK_TWIST),
                       ["ok"] * 20 + ["joint_lock"] + ["ok"] * 20),
}


@pytest.fixture(scope="module", params=list(TABLES))
def table(request):
    (a4, angles, universal, twist), words = TABLES[request.param]
    _, mechanism = _slider_crank(a4, angles, universal, twist)
    return request.param, mechanism, solve_loop_table(mechanism), words


#: The tables a judge cannot pass (module docstring).
CANNOT = {("exudyn", "turning"), ("exudyn", "universal"), ("exudyn", "touching-exactly")}
#: Not run: the Exudyn judge fails ``universal-1deg`` as it fails ``universal`` (above), after a minute of
#: integrating.
NOT_RUN = {("exudyn", "universal-1deg")}


@pytest.mark.parametrize("judge", list(JUDGES))
def test_every_judge_names_limits_and_locks_and_agrees(table, judge: str, request) -> None:
    library, module = JUDGES[judge]
    pytest.importorskip(library)
    name, mechanism, reference, words = table
    if (judge, name) in NOT_RUN:
        pytest.skip("the Exudyn judge fails this table as it fails universal's 5-degree sweep")
    if (judge, name) in CANNOT:
        request.applymarker(pytest.mark.xfail(strict=True, reason="integrates through a singular pose"))
    mine = pytest.importorskip(module).solve_table(mechanism)
    assert list(reference.status) == words and list(mine.status) == words, list(mine.status)
    spec = loop_spec(mechanism)
    limit = words.index("assembly_limit") if "assembly_limit" in words else None
    if limit is not None:
        assert np.isfinite(mine["closure_condition"][limit]) and np.isnan(mine["s4_ddot"][limit])
    checks, _ = judge_checks(name, reference, mine, spec)
    failed = [(c.quantity, c.max_rel, c.detail) for c in checks if not c.passed]
    assert not failed
    assert any(c.quantity == "closure_condition" for c in checks)
