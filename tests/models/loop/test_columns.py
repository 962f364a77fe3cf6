"""A loop table's result columns (``models/loop/columns.py``): the TableSpec the linkages' gate reads (pose,
rates, reactions, the key, unit groups, angle periods) and the settling of one engine's answer."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from dualmech.core.status import Status
from dualmech.models.linkages import linkage_case, read_linkage, table_spec
from dualmech.models.linkages.rssr import SPEC as RSSR_SPEC
from dualmech.models.loop.columns import column_names, loop_spec, loop_table
from dualmech.models.loop.table_format import loop_from_dict


def test_the_rscr_spec_names_every_column_and_its_group() -> None:
    spec = table_spec("loop", linkage_case("rscr"))
    assert spec.key == "theta1_deg" and spec.key_label == ("theta1", "deg") and spec.output == "theta4"
    assert spec.pose == ("theta1", "theta3", "s3", "theta4", "closure_condition")
    assert spec.rates == ("theta1_dot", "theta1_ddot", "theta3_dot", "theta3_ddot", "s3_dot", "s3_ddot",
                          "theta4_dot", "theta4_ddot")
    # the loads (joint 4's torque, joint 3's axial force) are given, the drive torque is solved
    efforts = ("effort_theta4", "effort_s3", "effort_theta1")
    wrenches = tuple(f"joint{j}_{k}{a}" for j in range(1, 5) for k in "fm" for a in "xyz")
    assert spec.reactions == efforts + wrenches + ("dynamics_residual",)
    assert spec.columns == ("theta1_deg", *spec.pose[:1], "theta1_dot", "theta1_ddot", "theta3", "theta3_dot",
                            "theta3_ddot", "s3", "s3_dot", "s3_ddot", "theta4", "theta4_dot", "theta4_ddot",
                            *efforts, *wrenches, "closure_condition", "residual", "dynamics_residual")
    assert spec.forces == ("effort_s3",) + tuple(c for c in wrenches if "_f" in c)
    assert spec.moments == ("effort_theta4", "effort_theta1") + tuple(c for c in wrenches if "_m" in c)
    groups = {c: spec.unit_group(c) for c in spec.kinematics + spec.forces + spec.moments}
    assert groups["theta3"] == "angle" and groups["theta3_dot"] == "angle_dot"
    assert groups["theta4_ddot"] == "angle_ddot" and groups["s3"] == "length"
    assert groups["s3_dot"] == "length_dot" and groups["s3_ddot"] == "length_ddot"
    assert groups["effort_s3"] == "force" and groups["effort_theta1"] == "moment"
    assert groups["joint2_fz"] == "force" and groups["joint4_my"] == "moment"
    assert groups["closure_condition"] == "ratio" and spec.period("closure_condition") is None
    assert spec.period("theta4") == pytest.approx(2 * np.pi, rel=1e-15, abs=0)
    assert spec.period("theta1_deg") == 360.0
    assert spec.period("s3") is None and spec.period("theta4_dot") is None


def test_a_universal_joint_and_a_slide_drive() -> None:
    """A P-driven table keys its rows on the slide itself; a U joint's second angle is an angle."""
    data = {"name": "rups", "mechanism": {"kind": "loop"},
            "joint": [{"type": "P", "a": 0.1}, {"type": "U", "a": 0.3}, {"type": "S", "a": 0.2},
                      {"type": "R", "alpha_deg": 90.0, "a": 0.25}],
            "drive": {"joint": 1, "positions": [0.01, 0.02], "speed": 1.0},
            "body": [{"mass": 1.0, "side": 0.1}, {"mass": 1.0, "side": 0.1}, {"mass": 1.0, "side": 0.1}],
            "load": [{"joint": 4, "value": 2.0}]}
    spec = loop_spec(loop_from_dict(data))
    assert spec.key == "s1" and spec.key_label == ("s1", "") and spec.pose[0] == "s1"
    assert spec.unit_group("eta2") == "angle" and spec.unit_group("eta2_ddot") == "angle_ddot"
    assert spec.period("eta2") == pytest.approx(2 * np.pi, rel=1e-15, abs=0)
    assert spec.unit_group("effort_s1") == "force" and spec.output == "theta4"


def test_the_rssr_and_rccc_specs_keep_their_key() -> None:
    assert RSSR_SPEC.key == "theta1_deg" and RSSR_SPEC.shown == "phi4_deg"
    assert table_spec("rccc", linkage_case("rccc")).key == "theta1_deg"


def test_a_table_is_settled_by_its_words() -> None:
    """Reactions NaN at a dead centre, everything NaN where the loop does not close, a non-finite value a
    word claims demotes it to not_finite; the key is the drive in degrees."""
    mech = loop_from_dict(_with_positions([0.0, 10.0, 20.0, 30.0]))
    cols = {c: np.arange(4.0) + 1.0 for c in (*column_names(mech), "residual", "dynamics_residual")}
    cols["theta4"] = np.array([1.0, 1.0, 1.0, np.inf])
    status = np.array([Status.OK.value, Status.DEAD_CENTRE.value, Status.NO_ASSEMBLY.value, Status.OK.value])
    table = loop_table("dualmech", mech, cols, status, {"iterations": np.zeros(4)})
    np.testing.assert_array_equal(table.status, ["ok", "dead_centre", "no_assembly", "not_finite"])
    np.testing.assert_allclose(table["theta1_deg"], [0.0, 10.0, 20.0, 30.0], rtol=1e-15, atol=1e-13)
    assert np.isnan(table["joint2_fx"][1]) and np.isfinite(table["theta3_dot"][1])
    assert np.isnan(table["theta3"][2]) and table["effort_theta1"][0] == 1.0
    assert table.meta["iterations"].shape == (4,) and table.case == "rscr"


def _with_positions(positions: list[float]) -> dict:
    data = copy.deepcopy(read_linkage("rscr"))
    data["drive"]["positions"] = positions
    return data
