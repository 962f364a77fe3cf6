"""The loop table's file format and its mobility check: valid tables load, every bad value is one line."""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest

from dualmech.models.inputs import CaseError
from dualmech.models.loop.mobility import idle_spins, mobility
from dualmech.models.loop.table_format import loop_from_dict

#: The thesis's slider crank as a loop table (Table 1 with a cylindrical crank).
SLIDER_CRANK = {
    "name": "slider-crank",
    "mechanism": {"kind": "loop"},
    "gravity": [0.0, 0.0, -9.81],
    "joint": [
        {"type": "C", "a": 12.0},
        {"type": "S", "a": 50.0},
        {"type": "S", "alpha_deg": 90.0},
        {"type": "P", "alpha_deg": 270.0, "a": 0.0, "start": [48.5]},
    ],
    "drive": {"joint": 1, "positions": {"start": 0.0, "stop": 360.0, "step": 10.0}, "speed": 5.0,
              "axial_shift": 1.0, "axial_amplitude": 0.5, "axial_cycles": 2.0, "effort": 100.0},
    "body": [{"mass": 1.0, "com": [6.0, 0.0, 0.0], "inertia": [0.1, 1.0, 1.0]},
             {"mass": 2.0, "com": [25.0, 0.0, 0.0], "inertia": [0.1, 5.0, 5.0]},
             {"mass": 3.0, "inertia": [1.0, 1.0, 1.0]}],
    "load": [{"joint": 4}],
}


def test_slider_crank_table_loads() -> None:
    mech = loop_from_dict(SLIDER_CRANK)
    assert [j.type for j in mech.joints] == ["C", "S", "S", "P"]
    assert mech.joints[2].alpha == pytest.approx(math.pi / 2, rel=0, abs=1e-15)
    assert mech.drive.positions.shape == (36,)
    np.testing.assert_allclose(mech.drive.positions[1], math.radians(10.0), rtol=0, atol=1e-15)
    assert mech.prescribed == ((0, "theta"), (0, "s"))
    assert mech.loads[0].value is None and mech.drive.effort == 100.0
    assert idle_spins(mech.joints) == (1,)
    assert mobility(mech.joints) == 2


def _with(path: str, value) -> dict:
    data = copy.deepcopy(SLIDER_CRANK)
    node = data
    *parents, leaf = path.split(".")
    for p in parents:
        node = node[int(p)] if p.isdigit() else node[p]
    if value is None:
        del node[int(leaf) if leaf.isdigit() else leaf]
    else:
        node[int(leaf) if leaf.isdigit() else leaf] = value
    return data


@pytest.mark.parametrize(("path", "value", "message"), [
    ("joint.2.type", "Q", "joint[3].type: expected one of R, P, C, S, U, got 'Q'"),
    ("joint.0.a", "long", "joint[1].a: expected a finite number"),
    ("joint.0.theta_deg", 10.0, "joint[1].theta: a constant angle belongs to a P joint only"),
    ("joint.3.start", [1.0, 2.0], "joint[4].start: a P joint has 1 variables"),
    ("joint.0.colour", "red", "joint[1].colour: unknown key"),
    ("mechanism.kind", "rssr", 'mechanism.kind: expected "loop"'),
    ("drive.joint", 2, "drive.joint: joint[2] is S; the driven joint is an R, P or C"),
    ("drive.joint", 9, "drive.joint: expected a joint number 1..4, got 9"),
    ("drive.speed", None, "drive.speed: required key missing"),
    ("drive.positions", {"start": 0.0, "stop": 10.0, "step": -1.0}, "drive.positions: start=0.0"),
    ("body.1.mass", -1.0, "body[2].mass: expected a number, a positive mass"),
    ("body.2", None, "body: expected one [[body]] per moving link (3), got 2"),
    ("load.0.joint", 2, "load[1].coordinate: joint[2] is S, it has no free 'theta'"),
    ("drive.effort", None, "loads: exactly one effort is solved for"),
    ("gravity", [0.0, 1.0], "gravity: expected an array of 3 numbers"),
])
def test_bad_values_are_one_line_naming_the_key(path: str, value, message: str) -> None:
    with pytest.raises(CaseError) as err:
        loop_from_dict(_with(path, value))
    assert str(err.value).startswith(message), str(err.value)
    assert "\n" not in str(err.value)


def test_mobility_error_names_the_count_and_why() -> None:
    data = _with("joint.0.type", "R")  # a revolute crank: mobility 1, but the axial law asks for 2
    data["drive"].update(axial_shift=0.0, axial_amplitude=0.0)
    # a cylinder at the slider: mobility 2 with one driven coordinate
    data["joint"][3] = {"type": "C", "alpha_deg": 270.0}
    with pytest.raises(CaseError) as err:
        loop_from_dict(data)
    assert str(err.value) == ("joint: mobility 2 (freedoms 9 - 6 - 1), 1 idle spin of link 2 (S-S): a single "
                              "loop needs 1 (one driven coordinate); remove 1 freedom")


def test_overconstrained_loop_is_refused() -> None:
    data = copy.deepcopy(SLIDER_CRANK)
    data["joint"] = [{"type": "R", "a": 1.0}, {"type": "R", "a": 3.0}, {"type": "R", "a": 2.0},
                     {"type": "R", "a": 3.0}]
    data["drive"] = {"joint": 1, "positions": [0.0, 10.0], "speed": 1.0}
    data["load"] = []
    with pytest.raises(CaseError, match=r"^joint: mobility -2 \(freedoms 4 - 6\): a single") as err:
        loop_from_dict(data)
    assert str(err.value).endswith("add 3 freedoms; a planar 4R loop moves, but its reactions are statically "
                                   "indeterminate: make it spatial, e.g. an RSSR")
    spherical = [{"type": "R", "alpha_deg": t} for t in (70.0, 80.0, 60.0, 75.0)]
    with pytest.raises(CaseError, match="; a spherical 4R loop moves, but"):
        loop_from_dict({**data, "joint": spherical})
    twisted = [{**j, "alpha_deg": 30.0} for j in data["joint"]]  # a generic 4R: the count alone
    with pytest.raises(CaseError, match=r"add 3 freedoms$"):
        loop_from_dict({**data, "joint": twisted})


def test_an_idly_spinning_link_must_be_axisymmetric() -> None:
    data = _with("body.1.com", [25.0, 0.5, 0.0])
    with pytest.raises(CaseError, match=r"^body\[2\]: link 2 spins idly between two S joints"):
        loop_from_dict(data)
    data = _with("body.1.inertia", [1.0, 5.0, 5.5])
    with pytest.raises(CaseError, match=r"^body\[2\]: link 2 spins idly"):
        loop_from_dict(data)


def test_simple_shapes() -> None:
    data = _with("body.0", {"mass": 2.0, "radius": 0.5})
    data["body"][2] = {"mass": 3.0, "side": 2.0}
    mech = loop_from_dict(data)
    np.testing.assert_allclose(mech.bodies[0].com, [6.0, 0.0, 0.0], rtol=0, atol=0)  # the crank's middle
    transverse = 2.0 * (0.5**2 / 4 + 12.0**2 / 12)
    np.testing.assert_allclose(mech.bodies[0].inertia, np.diag([0.25, transverse, transverse]), rtol=1e-15,
                               atol=0)
    np.testing.assert_allclose(mech.bodies[2].inertia, np.eye(3) * 2.0, rtol=1e-15, atol=0)
    with pytest.raises(CaseError, match=r"^body\[1\]: give exactly one of inertia .* got inertia, radius$"):
        loop_from_dict(_with("body.0.radius", 0.5))
