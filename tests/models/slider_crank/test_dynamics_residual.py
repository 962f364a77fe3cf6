"""``meta["dynamics_residual"]`` of the slider crank's in-house engines against an independent oracle.

The engines report the largest violation of the 18 Newton-Euler equations by their own reactions. The
oracle evaluates the same equations independently (closed-form kinematics and momentum rates of
:mod:`tests.newton_euler_oracle`) on the table's own reaction columns: a true report is at round-off
where the columns are right.  (The compiled engine's report read 0.45 on ``thesis/ideal``: its scratch
overwrote the universal joint's moment before the residual read it.)  The universal joint's residual,
which the ball-joint oracle does not model, is held to the numpy engine's in ``tests/core/test_kernel.py``.
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from dualmech.core.table import ResultTable
from dualmech.models.case import Case, load_case, preset_names, with_loads
from dualmech.models.slider_crank import analysis as slider_crank
from dualmech.models.slider_crank import kernel as slider_crank_kernel
from tests.newton_euler_oracle import table_violation
from tests.tolerances import NEWTON_EULER_ROUND_OFF

BALL_JOINT_PRESETS = [n for n in preset_names() if load_case(n).joints.rod_slider == "ball"]
ENGINES = {
    "numpy": lambda case: slider_crank.to_table(slider_crank.analyze(case)),
    "compiled": slider_crank_kernel.solve_case,
}


def assert_residual_is_the_oracles(case: Case, table: ResultTable) -> None:
    """The engine's reported residual and the oracle's on the rows with reactions: both round-off."""
    ok = table.status == "ok"
    assert ok.any()
    reported = table.meta["dynamics_residual"]
    assert reported.shape == (len(table),)
    assert_allclose(reported[ok], table_violation(case, table)[ok], rtol=0, atol=NEWTON_EULER_ROUND_OFF,
                    err_msg=f"{table.engine} on {case.name}: dynamics_residual")


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("name", BALL_JOINT_PRESETS)
def test_reported_residual_is_the_oracles(name: str, engine: str) -> None:
    case = load_case(name)
    assert_residual_is_the_oracles(case, ENGINES[engine](case))


@pytest.mark.parametrize("engine", ENGINES)
def test_force_mode_and_random_geometries(engine: str) -> None:
    """Force mode (the slider load given) on seeded random designs, some rows beyond assembly."""
    rng = np.random.default_rng(30)
    base = load_case("thesis/a4-30-s1-3.5")
    for _ in range(4):
        case = with_loads(base.with_values({
            "geometry.slider_offset": float(rng.uniform(-20.0, 45.0)),
            "geometry.slider_twist_deg": float(rng.uniform(190.0, 350.0)),
            "geometry.crank_axial_shift": float(rng.uniform(-8.0, 8.0)),
            "motion.angles_deg": {"start": 0.0, "stop": 360.0, "step": 5.0}}),
            drive_torque=None, slider_force=float(rng.uniform(-500.0, 500.0)))
        assert_residual_is_the_oracles(case, ENGINES[engine](case))
