"""The MJCF of a case: MuJoCo compiles it, Pinocchio imports it, and both read the case's bodies and
frames."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from click.testing import CliRunner
from numpy.testing import assert_allclose

from dualmech.cli import main
from dualmech.models.case import load_case, preset_names
from dualmech.models.mjcf import case_to_mjcf, default_settings, slider_axis
from tests.oracles import exact_slider_motion
from tests.pinocchio_oracles import random_case

mujoco = pytest.importorskip("mujoco")

#: Mass properties and placements are written with repr() and read back by strtod: only the
#: compiler's eigen-decomposition of fullinertia (and our re-assembly) rounds, a few ulp.
EXACT = 1e-13
#: Poses computed along two chains of 3-4 rotations of lengths ~100: a few ulp of that.
POSE = 1e-12


def _cases():
    rng = np.random.default_rng(20240)
    # the presets with the default joints (the variants: test_mjcf_variants.py)
    return [c for c in map(load_case, preset_names()) if c.joints.is_default] + [
        random_case(rng, m) for m in ("torque", "force", "torque")
    ]


def _central_inertia(model, body: int) -> np.ndarray:
    """Inertia tensor about the centre of mass in body axes, from MuJoCo's principal form."""
    rot = np.empty(9)
    mujoco.mju_quat2Mat(rot, model.body_iquat[body])
    rot = rot.reshape(3, 3)
    return rot @ np.diag(model.body_inertia[body]) @ rot.T


def _quat_x_to(v: np.ndarray) -> np.ndarray:
    """(w, x, y, z) turning +x onto unit vector v (shortest arc; v != -x)."""
    q = np.array([1.0 + v[0], 0.0, -v[2], v[1]])
    return q / np.linalg.norm(q)


@pytest.mark.parametrize("case", _cases(), ids=lambda c: c.name)
def test_mujoco_compiles_the_case_bodies_joints_and_loop(case):
    m = mujoco.MjModel.from_xml_string(case_to_mjcf(case))
    assert (m.nq, m.nv, m.nbody, m.nu, m.neq) == (7, 6, 5, 3, 1)
    roots = [m.body(i).name for i in range(1, m.nbody) if m.body_parentid[i] == 0]
    assert roots == ["ground"]  # one root body: what Pinocchio's parser imports
    for name in ("crank", "rod", "slider"):
        b = m.body(name).id
        ref = getattr(case.bodies, name)
        scale = np.abs(ref.inertia).max()
        assert_allclose(m.body_mass[b], ref.mass, rtol=EXACT, atol=0)
        assert_allclose(m.body_ipos[b], ref.com, rtol=0, atol=EXACT * max(1.0, np.abs(ref.com).max()))
        assert_allclose(_central_inertia(m, b), ref.inertia, rtol=0, atol=EXACT * scale)
    assert_allclose(m.opt.gravity, case.loads.gravity, rtol=0, atol=0)
    g = case.geometry
    assert_allclose(m.body("rod").pos, [g.crank_length, 0, 0], rtol=0, atol=0)
    assert_allclose(m.body("slider").pos, [-g.slider_offset, 0, 0], rtol=0, atol=0)
    assert_allclose(m.joint("slider_stroke").axis, -slider_axis(case), rtol=0, atol=1e-15)
    for jname, jtype in (("crank_angle", "HINGE"), ("crank_axial", "SLIDE"), ("rod_ball", "BALL")):
        assert m.jnt_type[m.joint(jname).id] == getattr(mujoco.mjtJoint, f"mjJNT_{jtype}")
    assert m.eq_type[0] == mujoco.mjtEq.mjEQ_CONNECT
    assert m.eq_objtype[0] == mujoco.mjtObj.mjOBJ_SITE
    assert (m.eq_obj1id[0], m.eq_obj2id[0]) == (m.site("slider_pin").id, m.site("rod_end").id)


@pytest.mark.parametrize("case", _cases()[-3:], ids=lambda c: c.name)
def test_assembled_pose_reproduces_the_convention_frames(case):
    """qpos = [theta1, S1, q_rod, S4] from the closed form puts every body frame where docs/conventions.md
    says."""
    m = mujoco.MjModel.from_xml_string(case_to_mjcf(case))
    d = mujoco.MjData(m)
    g = case.geometry
    theta = np.radians(np.array([0.0, 71.0, 200.0, 333.0]))
    s4 = exact_slider_motion(case, theta)[0]
    s1 = case.motion.state(g.crank_axial_shift, np.degrees(theta)).s
    k4 = slider_axis(case)
    for th, s, q4 in zip(theta, s1, s4):
        p2 = np.array([g.crank_length * math.cos(th), g.crank_length * math.sin(th), s])
        p3 = np.array([-g.slider_offset, 0, 0]) - q4 * k4
        rz = np.array([[math.cos(th), -math.sin(th), 0], [math.sin(th), math.cos(th), 0], [0, 0, 1]])
        u_crank = rz.T @ (p3 - p2) / g.rod_length
        d.qpos[:] = [th, s, *_quat_x_to(u_crank), q4]
        mujoco.mj_kinematics(m, d)
        atol = POSE * g.rod_length
        assert_allclose(d.xpos[m.body("crank").id], [0, 0, s], rtol=0, atol=atol)
        assert_allclose(d.xmat[m.body("crank").id].reshape(3, 3), rz, rtol=0, atol=POSE)
        assert_allclose(d.xpos[m.body("rod").id], p2, rtol=0, atol=atol)
        assert_allclose(
            d.xmat[m.body("rod").id].reshape(3, 3)[:, 0], (p3 - p2) / g.rod_length, rtol=0, atol=POSE
        )
        assert_allclose(d.xpos[m.body("slider").id], p3, rtol=0, atol=atol)
        assert_allclose(d.xmat[m.body("slider").id], np.eye(3).ravel(), rtol=0, atol=0)
        assert_allclose(
            d.site_xpos[m.site("rod_end").id], d.site_xpos[m.site("slider_pin").id], rtol=0, atol=atol
        )


def test_user_text_is_escaped():
    case = load_case("thesis/ideal")
    object.__setattr__(case, "name", 'a <b> & "c" \x01 \'d\'')  # past the loader's checks, on purpose
    text = case_to_mjcf(case)
    root = ET.fromstring(text)
    assert root.get("model") == 'dualmech a <b> & "c" ? \'d\''
    m = mujoco.MjModel.from_xml_string(text)
    assert m.nbody == 5


def test_servos_are_affine_pd_laws_and_the_motor_is_the_slider_load():
    case = load_case("thesis/a4-20-alpha-232")
    s = default_settings(case, 1e-4)
    m = mujoco.MjModel.from_xml_string(case_to_mjcf(case, s))
    d = mujoco.MjData(m)
    rng = np.random.default_rng(3)
    d.qpos[:2] = rng.normal(size=2)
    d.qvel[:2] = rng.normal(size=2)
    d.ctrl[:] = rng.normal(size=3)
    mujoco.mj_forward(m, d)
    for a in range(2):
        expected = s.servo_kp[a] * (d.ctrl[a] - d.qpos[a]) - s.servo_kv[a] * d.qvel[a]
        assert_allclose(d.actuator_force[a], expected, rtol=1e-12, atol=0)
    dof = m.jnt_dofadr[m.joint("slider_stroke").id]
    # generalized force on a slide along -k4 of the force L k4: -L
    assert_allclose(d.qfrc_actuator[dof], -d.ctrl[2], rtol=1e-15, atol=0)


def test_general_actuator_ignores_biasprm_unless_affine():
    """The MuJoCo fact behind biastype="affine" in the servos (issue 5)."""
    xml = """<mujoco><worldbody><body><joint name="j" type="hinge"/>
             <inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/></body></worldbody>
             <actuator><general joint="j" gainprm="10" biasprm="0 -10 -1"/>
             <general joint="j" gainprm="10" biastype="affine" biasprm="0 -10 -1"/></actuator></mujoco>"""
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    d.qpos[0], d.qvel[0], d.ctrl[:] = 0.3, 2.0, 1.0
    mujoco.mj_forward(m, d)
    assert_allclose(d.actuator_force, [10.0, 10.0 - 3.0 - 2.0], rtol=1e-15, atol=0)


@pytest.mark.parametrize("case", _cases()[-3:], ids=lambda c: c.name)
def test_pinocchio_imports_the_same_bodies_joints_and_loop(case, tmp_path):
    pin = pytest.importorskip("pinocchio")
    path = tmp_path / "model.xml"
    path.write_text(case_to_mjcf(case))
    model, points, _ = pin.buildModelAndConstraintsFromMJCF(str(path))
    assert (model.nq, model.nv, model.njoints) == (7, 6, 4)
    crank, rod, slider = (model.getJointId(n) for n in ("Composite_crank_angle", "rod_ball", "slider_stroke"))
    assert (model.parents[crank], model.parents[rod], model.parents[slider]) == (0, crank, 0)
    g = case.geometry
    assert_allclose(model.jointPlacements[rod].translation, [g.crank_length, 0, 0], rtol=0, atol=0)
    assert_allclose(model.jointPlacements[slider].translation, [-g.slider_offset, 0, 0], rtol=0, atol=0)
    for joint, name in ((crank, "crank"), (rod, "rod"), (slider, "slider")):
        ref, inertia = getattr(case.bodies, name), model.inertias[joint]
        assert_allclose(inertia.mass, ref.mass, rtol=EXACT, atol=0)
        assert_allclose(inertia.lever, ref.com, rtol=0, atol=EXACT * max(1.0, np.abs(ref.com).max()))
        assert_allclose(inertia.inertia, ref.inertia, rtol=0, atol=EXACT * np.abs(ref.inertia).max())
    # the connect: site1 on the slider at its origin, site2 on the rod at (a2, 0, 0)
    assert len(points) == 1
    c = points[0]
    assert (c.joint1_id, c.joint2_id) == (slider, rod)
    assert_allclose(c.joint1_placement.translation, 0.0, rtol=0, atol=0)
    assert_allclose(c.joint2_placement.translation, [g.rod_length, 0, 0], rtol=0, atol=0)
    # same kinematics as MuJoCo at random coordinates (Pinocchio stores quaternions x, y, z, w)
    m = mujoco.MjModel.from_xml_string(path.read_text())
    d = mujoco.MjData(m)
    data = model.createData()
    rng = np.random.default_rng(8)
    for _ in range(3):
        quat = rng.normal(size=4)
        quat /= np.linalg.norm(quat)
        qm = np.array([*rng.normal(size=2), *quat, rng.normal()])
        d.qpos[:] = qm
        mujoco.mj_kinematics(m, d)
        pin.framesForwardKinematics(model, data, np.array([qm[0], qm[1], *quat[1:], quat[0], qm[6]]))
        for site in ("rod_end", "slider_pin"):
            assert_allclose(data.oMf[model.getFrameId(site)].translation, d.site_xpos[m.site(site).id],
                            rtol=0, atol=POSE * g.rod_length)


def test_cli_writes_a_model_mujoco_loads(tmp_path):
    out = tmp_path / "ideal.xml"
    result = CliRunner().invoke(main, ["mjcf", "thesis/ideal", "-o", str(out)])
    assert result.exit_code == 0, result.output
    m = mujoco.MjModel.from_xml_path(str(out))
    assert m.nbody == 5


def test_bad_settings_and_bodies_are_one_line_errors():
    case = load_case("thesis/ideal")
    with pytest.raises(ValueError, match="timestep"):
        default_settings(case, -1.0)
    thin = case.with_values(
        {"bodies.rod": {"mass": 0.1, "com": [25.0, 0.0, 0.0], "inertia": [0.0, 5.0, 5.0]}}
    )
    with pytest.raises(ValueError, match="bodies.rod.inertia"):
        case_to_mjcf(thin)
