"""The Pinocchio model built from a case: masses, inertias, joint placements, constraint anchors, gravity."""

import numpy as np
import pytest
from numpy.testing import assert_allclose

from dualmech.models.case import load_case, with_loads
from tests.pinocchio_oracles import random_case

pin = pytest.importorskip("pinocchio")
from dualmech.validation.judges.pinocchio_slider_crank.model import build_model  # noqa: E402

#: Exact copies and single products of case numbers: only round-off of a few operations.
EXACT = 1e-14


def _cases():
    rng = np.random.default_rng(4)
    return [with_loads(load_case("a4-20-alpha-232"), gravity=np.array([1.0, -2.0, -386.4])),
            random_case(rng, "torque"), random_case(rng, "force")]


@pytest.mark.parametrize("case", _cases(), ids=["thesis", "random-torque", "random-force"])
def test_mass_properties_are_the_case_bodies(case):
    pm = build_model(case)
    joints = {"crank": pm.crank_joint, "rod": pm.rod_joint, "slider": pm.slider_joint}
    for name, joint in joints.items():
        body = getattr(case.bodies, name)
        inertia = pm.model.inertias[joint]
        assert_allclose(inertia.mass, body.mass, rtol=EXACT)
        assert_allclose(inertia.lever, body.com, rtol=EXACT, atol=EXACT)
        assert_allclose(inertia.inertia, body.inertia, rtol=EXACT, atol=EXACT * np.abs(body.inertia).max())
    assert_allclose(pm.model.gravity.linear, case.loads.gravity, rtol=0, atol=0)
    assert_allclose(pm.model.gravity.angular, 0.0, atol=0)


@pytest.mark.parametrize("case", _cases(), ids=["thesis", "random-torque", "random-force"])
def test_joint_frames_are_the_conventions_body_frames(case):
    """At any q: crank frame (0,0,S1) and Rz(theta1); rod frame at P2; slider frame at F - S4 k4, world
    axes."""
    rng = np.random.default_rng(5)
    pm = build_model(case)
    g = case.geometry
    a1, a2 = g.crank_length, g.rod_length
    k4 = np.array([0.0, np.sin(g.slider_twist), np.cos(g.slider_twist)])
    F = np.array([-g.slider_offset, 0.0, 0.0])
    data = pm.model.createData()
    for _ in range(5):
        theta, s1, s4 = rng.uniform(-np.pi, np.pi), rng.uniform(-5, 5), rng.uniform(-50, 50)
        q = pin.neutral(pm.model)
        q[pm.q_crank] = (theta, s1)
        q[pm.q_rod] = pin.Quaternion(pin.SE3.Random().rotation).coeffs()
        q[pm.q_slider] = s4
        pin.framesForwardKinematics(pm.model, data, q)
        crank, rod, slider = (data.oMi[j] for j in (pm.crank_joint, pm.rod_joint, pm.slider_joint))
        c, s = np.cos(theta), np.sin(theta)
        assert_allclose(crank.translation, [0.0, 0.0, s1], atol=EXACT * 10)
        assert_allclose(crank.rotation, [[c, -s, 0], [s, c, 0], [0, 0, 1]], atol=EXACT)
        assert_allclose(rod.translation, [a1 * c, a1 * s, s1], atol=EXACT * a1)
        assert_allclose(slider.translation, F - s4 * k4, atol=EXACT * 50)
        assert_allclose(slider.rotation, np.eye(3), atol=0)
        # constraint anchors: the rod end a2 along the rod's x axis, the slider pin at the slider origin
        assert_allclose(data.oMf[pm.rod_end_frame].translation, rod.translation + a2 * rod.rotation[:, 0],
                        atol=EXACT * a2)
        assert_allclose(data.oMf[pm.slider_pin_frame].translation, slider.translation, atol=0)


def test_loop_constraint_joins_rod_end_and_slider_pin():
    case = load_case("a4-30-s1-3.5")
    pm = build_model(case)
    c = pm.constraint
    assert c.type == pin.ContactType.CONTACT_3D
    assert (c.joint1_id, c.joint2_id) == (pm.rod_joint, pm.slider_joint)
    assert_allclose(c.joint1_placement.translation, [case.geometry.rod_length, 0, 0], atol=0)
    assert_allclose(c.joint1_placement.rotation, np.eye(3), atol=0)
    assert_allclose(c.joint2_placement.homogeneous, np.eye(4), atol=0)
    assert (pm.model.nq, pm.model.nv) == (7, 6)
    assert pm.model.frames[pm.rod_end_frame].parentJoint == pm.rod_joint
    assert pm.model.frames[pm.slider_pin_frame].parentJoint == pm.slider_joint
