"""Every engine's status words are honest and the same at the edges: overflow, assembly limit, no assembly.

The four engines (in-house, Pinocchio, MuJoCo rigid, MuJoCo simulation) are run on the same inputs:

* inputs that overflow the arithmetic (``crank_rpm = 1e308``-like speeds, ``crank_accel = -1e308``), built
  directly as case objects (the loader may refuse them: this is each engine's own second line of defence):
  no row may be ``ok`` (or ``dead_centre``) with a non-finite number; every row is ``not_finite``;
* positions at the exact edge of assembly, ``1e-9 a2`` inside and ``1e-9 a2`` outside, found with the closed
  form (the distance ``rho`` from the crank pin P2 to the slider line equals ``a2``): at and inside the edge
  every engine says ``assembly_limit`` (S1, S4 and ``closure_condition`` given, rates and reactions NaN),
  outside every engine says ``no_assembly``;
* the ``closure_condition`` column against the closed form ``sqrt(a2^2 - rho^2) / a2`` on regular cases.
"""

from __future__ import annotations

import importlib
import math
from dataclasses import replace

import numpy as np
import pytest
from numpy.testing import assert_allclose

from dualmech.core.status import ASSEMBLED, RATES_GIVEN, Status
from dualmech.core.table import NUMERIC_COLUMNS, REACTION_COLUMNS, ResultTable
from dualmech.models.case import Case, case_from_dict
from dualmech.validation.tolerances import ASSEMBLY_LIMIT_CONDITION, MATRIX_KINEMATICS, SIM_STROKE
from tests.oracles import assembly_margin
from tests.tolerances import S4_AT_ASSEMBLY_LIMIT

ENGINES = {"dualmech": "dualmech.models.slider_crank.analysis", "pinocchio":
"dualmech.validation.judges.pinocchio_slider_crank.engine",
           "mujoco": "dualmech.validation.judges.mujoco_slider_crank.engine",
           "mujoco-sim": "dualmech.validation.judges.mujoco_slider_crank.sim"}
LIBRARY = {"pinocchio": "pinocchio", "mujoco": "mujoco", "mujoco-sim": "mujoco"}
A1, A2 = 12.0, 50.0


def _solver(engine: str):
    if engine in LIBRARY:
        pytest.importorskip(LIBRARY[engine])
    return importlib.import_module(ENGINES[engine]).solve_case


def _case(a4: float, angles: dict, mode: str = "slider_force", twist: float = 270.0, s1: float = 0.0) -> Case:
    return case_from_dict({
        "name": "edge", "units": "inch-lbf-s",
        "geometry": {"crank_length": A1, "rod_length": A2, "slider_offset": a4, "slider_twist_deg": twist,
                     "crank_axial_shift": s1},
        "motion": {"crank_rpm": 50.0, "crank_accel": 2.0, "angles_deg": angles},
        "bodies": {"crank_radius": 1.5, "rod_radius": 1.0, "slider_side": 3.0, "weight_density": 0.28,
                   "gravity_constant": 386.4},
        "loads": {mode: 100.0, "gravity": [0.0, -386.4, 0.0]},
    })


def assert_honest(table: ResultTable) -> None:
    """Each row gives exactly what its status word promises (``core/status.py``), all of it finite."""
    status = np.asarray(table.status, dtype=str)
    assert set(status) <= {s.value for s in Status}, set(status)
    for name in NUMERIC_COLUMNS:
        col = table[name]
        if name in ("theta1_deg", "S1"):
            given = np.ones(status.shape, dtype=bool)
        elif name in REACTION_COLUMNS:
            given = status == Status.OK
        elif name in ("S4_dot", "S4_ddot", "transmission"):
            given = np.isin(status, list(RATES_GIVEN))
        elif name in ("S4", "closure_condition"):
            given = np.isin(status, list(ASSEMBLED))
        else:  # residual: the engine's own diagnostic, may be given anywhere
            continue
        assert np.isfinite(col[given]).all(), (name, table.engine, status[given & ~np.isfinite(col)][:3])
        assert np.isnan(col[~given]).all(), (name, table.engine, status[~given & ~np.isnan(col)][:3])


# ----------------------------------------------------------------------------- overflow

@pytest.mark.filterwarnings("ignore::RuntimeWarning")  # the overflow is the point
@pytest.mark.parametrize("engine", list(ENGINES))
@pytest.mark.parametrize("motion", [{"speed": 2 * math.pi * 1e308 / 60 / 10}, {"accel": -1e308}],
                         ids=["rpm-1e307", "accel-minus-1e308"])
def test_overflowing_motion_is_not_finite_never_ok(engine, motion):
    base = _case(30.0, {"start": 0.0, "stop": 360.0, "step": 60.0}, mode="drive_torque")
    case = base.with_parts(motion=replace(base.motion, **motion))  # built directly: the loader may refuse it
    table = _solver(engine)(case)
    assert_honest(table)
    assert (np.asarray(table.status, dtype=str) == Status.NOT_FINITE).all(), list(table.status)


# ----------------------------------------------------------------------------- edges of assembly

#: (family, a4 at the edge, the edge's crank angle, angles tabulated).  Planar (twist 270 deg, S1 = 0):
#: rho(theta) = |a1 cos(theta) + a4|.  "near": rho(0) = a1 + a4 = a2 is the largest rho, so the rows
#: around 0 assemble; "far": a4 = a1 + a2, rho(180) = a4 - a1 = a2 is the smallest, every other row cannot.
PLANAR_EDGES = {
    "near": (A2 - A1, 0.0, {"start": -20.0, "stop": 21.0, "step": 10.0}),
    "far": (A1 + A2, 180.0, {"start": 160.0, "stop": 201.0, "step": 10.0}),
}
#: Offsets of a4 from the edge, relative to a2 (< 0 moves P2 toward the slider line: inside).  "slack":
#: outside by 1e-13 a2, within ASSEMBLY_REACH (1e-12): still the limit in every engine, whatever its rounding.
SIDES = {"edge": 0.0, "inside": -1e-9, "outside": 1e-9, "slack": 1e-13}


@pytest.mark.parametrize("engine", list(ENGINES))
@pytest.mark.parametrize("family", list(PLANAR_EDGES))
@pytest.mark.parametrize("side", list(SIDES))
def test_planar_edge_of_assembly(engine, family, side):
    a4_edge, theta_edge, angles = PLANAR_EDGES[family]
    case = _case(a4_edge + SIDES[side] * A2, angles)  # both families: rho at the edge angle grows with a4
    table = _solver(engine)(case)
    assert_honest(table)
    theta = np.radians(table["theta1_deg"])
    margin = assembly_margin(case, theta)
    edge = np.isclose(table["theta1_deg"], theta_edge, rtol=0, atol=1e-9)
    expected = np.where(margin < 0.0, Status.NO_ASSEMBLY.value, Status.OK.value).astype(object)
    expected[edge] = Status.NO_ASSEMBLY.value if side == "outside" else Status.ASSEMBLY_LIMIT.value
    assert list(table.status) == list(expected), (engine, family, side)
    if side != "outside":
        row = np.flatnonzero(edge)[0]
        exact_s4 = math.sqrt(max(float(margin[row]), 0.0))  # closed form: P2 - F is normal to k4 here
        assert_allclose(table["S4"][row], exact_s4, rtol=0, atol=S4_AT_ASSEMBLY_LIMIT * A2)
        assert table["closure_condition"][row] < ASSEMBLY_LIMIT_CONDITION.value


@pytest.mark.parametrize("engine", list(ENGINES))
@pytest.mark.parametrize("side", list(SIDES))
def test_spatial_edge_of_assembly(engine, side):
    """Twist 250 deg, S1 = 3: at theta1 = 0, rho^2 = (a1 + a4)^2 + S1^2 sin^2(alpha4) = a2^2 at the edge."""
    twist, s1 = 250.0, 3.0
    a4_edge = math.sqrt(A2**2 - (s1 * math.sin(math.radians(twist))) ** 2) - A1
    case = _case(a4_edge + SIDES[side] * A2, {"start": 0.0, "stop": 0.5, "step": 1.0}, mode="drive_torque",
                 twist=twist, s1=s1)
    table = _solver(engine)(case)
    assert_honest(table)
    expected = Status.NO_ASSEMBLY if side == "outside" else Status.ASSEMBLY_LIMIT
    assert table.status[0] == expected, (engine, side)


@pytest.mark.parametrize("engine", list(ENGINES))
def test_closure_condition_matches_the_closed_form(engine):
    """``closure_condition`` = sqrt(a2^2 - rho^2)/a2 from each engine's own pose, on a random spatial case.

    Measured: <= 3.1e-14 (rigid engines), 5.9e-7 (simulation: its soft loop's pose).
    """
    rng = np.random.default_rng(7)
    case = _case(30.0 + float(rng.uniform(0.0, 2.0)), {"start": 0.0, "stop": 360.0, "step": 15.0},
                 twist=float(rng.uniform(240.0, 300.0)), s1=float(rng.uniform(2.0, 6.0)))
    table = _solver(engine)(case)
    assert_honest(table)
    margin = assembly_margin(case, np.radians(table["theta1_deg"]))
    rows = np.isin(np.asarray(table.status, dtype=str), list(ASSEMBLED))
    assert rows.sum() >= 10
    tol = (SIM_STROKE if engine == "mujoco-sim" else MATRIX_KINEMATICS).value
    assert_allclose(table["closure_condition"][rows], np.sqrt(margin[rows]) / A2, rtol=0, atol=tol)
