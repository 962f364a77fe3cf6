"""The RCCC simulated by MuJoCo (soft weld at joint 1, servo-driven rotor, the output torque applied) against
the in-house rigid answer at the simulated input states, at the simulated judge's tolerances of the gate."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest
from numpy.testing import assert_allclose

from dualmech.models.linkages import read_linkage
from dualmech.models.linkages.forward_dynamics import MECHANISMS
from dualmech.models.linkages.rccc import SPEC
from dualmech.models.linkages.rccc_case import RcccCase, rccc_from_dict
from dualmech.validation.engines import solves
from dualmech.validation.linkages.gate import judge_tolerances, relative_differences

pytest.importorskip("mujoco")
sim_module = pytest.importorskip("dualmech.validation.linkages.mujoco_rccc_sim")


def _case() -> RcccCase:
    return rccc_from_dict(read_linkage("rccc"))


def _ratios(case: RcccCase) -> dict[str, float]:
    """Per column the simulation gives, its largest relative difference (the gate's ``r_i``) from the
    in-house answer at the simulated input states over the simulated judge's tolerance of the column's
    group; ``status`` the rows whose words differ."""
    table = sim_module.solve_mujoco_sim_rccc(case)
    mech = MECHANISMS["rccc"]
    reference = mech.table(mech.analyze(case, table.meta["crank"]))
    assert len(table) > 100 and (reference.status == "ok").all()
    tols = judge_tolerances("mujoco-sim")
    columns = tuple(c for c in SPEC.kinematics + SPEC.forces + SPEC.moments if c in sim_module.SIM_COLUMNS)
    rel = relative_differences(reference, table, SPEC, columns)
    out = {c: float(np.max(r)) / tols["kinematics" if c in SPEC.kinematics else "reactions"].value
           for c, r in rel.items()}
    out["status"] = float(np.sum(np.asarray(reference.status) != np.asarray(table.status)))
    return out


@pytest.fixture(scope="module")
def ratios() -> dict[str, float]:
    return _ratios(_case())


def test_the_simulation_follows_the_in_house_answer_at_its_input_states(ratios) -> None:
    assert set(ratios) == {*sim_module.SIM_COLUMNS, "status"}
    assert ratios["status"] == 0.0
    # measured: worst s4_dot 0.20 (semi-implicit Euler's lag dt/2 s4_ddot), every reaction <= 0.021
    assert_allclose([ratios[c] for c in sim_module.SIM_COLUMNS], 0.0, rtol=0, atol=1.0)


def test_the_mujoco_sim_engine_solves_rccc_cases() -> None:
    assert solves("mujoco-sim", "rccc", _case())


def _faulty(monkeypatch: pytest.MonkeyPatch, edit) -> None:
    """Make the simulation compile its MJCF after ``edit(root)`` (the parsed XML, changed in place)."""
    real = sim_module.rccc_sim_mjcf

    def wrong(*args, **kwargs) -> str:
        root = ET.fromstring(real(*args, **kwargs))
        edit(root)
        return ET.tostring(root, encoding="unicode")

    monkeypatch.setattr(sim_module, "rccc_sim_mjcf", wrong)


def test_the_check_sees_a_wrong_mass_in_the_mjcf(monkeypatch: pytest.MonkeyPatch) -> None:
    """Deliberate fault: the coupler 2 % heavier in the simulated model than in the case."""
    def heavier(root: ET.Element) -> None:
        inertial = root.find(".//body[@name='coupler']/inertial")
        inertial.set("mass", repr(1.02 * float(inertial.get("mass"))))

    _faulty(monkeypatch, heavier)
    got = _ratios(_case())
    assert max(got[c] for c in SPEC.forces + SPEC.moments if c in got) > 5.0
    assert max(got[c] for c in SPEC.kinematics) < 1.0  # servo-driven: the motion is the geometry's


def test_the_check_sees_a_wrong_axis_sign_in_the_mjcf(monkeypatch: pytest.MonkeyPatch) -> None:
    """Deliberate fault: the output cylinder's slide along -z4 in the simulated model."""
    def flipped(root: ET.Element) -> None:
        root.find(".//joint[@name='joint4_slide']").set("axis", "0 0 -1")

    _faulty(monkeypatch, flipped)
    got = _ratios(_case())
    assert got["s4"] > 10.0


def _in_house_seeded(case: RcccCase) -> tuple[np.ndarray, np.ndarray]:
    """The old design (a fault here): the rigid judge's Newton started from the in-house estimate."""
    from dualmech.models.linkages import rccc
    from dualmech.validation.linkages import mujoco_rccc as rigid

    mr = rigid.build(case)
    theta = np.radians(case.motion.angles_deg[:1])
    state = rccc.estimate(case.geometry, theta, rccc.spherical_estimate(case.geometry, theta, case.branch)[0])
    start = -state.scalars[0][[4, 5, 2, 3, 0, 1]]
    rigid._position(mr, case, float(theta[0]), case.motion.speed, case.motion.accel, start)
    return mr.data.qpos.copy(), mr.data.qvel.copy()


@pytest.mark.parametrize("seeded", [False, True], ids=["own-start", "fault-in-house-seed"])
def test_the_simulation_ignores_the_in_house_starts(seeded: bool, monkeypatch: pytest.MonkeyPatch) -> None:
    """With every in-house start function 1 rad off (or the other branch), the simulated table is bit for bit
    the same: its initial state is the rigid judge's own answer.  Seeded from the in-house estimate it is not
    (measured: the judge's Newton lands on the same pose from the garbage, so the table moves by rounding
    only, 2e-13 deg; bit for bit is what sees it)."""
    from tests.validation.linkages.test_judge_independence import _garbage, _same

    if seeded:
        monkeypatch.setattr(sim_module, "rigid_start", _in_house_seeded)
    before = sim_module.solve_mujoco_sim_rccc(_case())
    with _garbage():
        after = sim_module.solve_mujoco_sim_rccc(_case())
    assert _same(before, after) != seeded
