"""MuJoCo judges the generalized inertia and the forward dynamics.

The model is the case's MJCF (``models/mjcf.py``), edited here with MjSpec: for a held ``S1``
the axial slide and its servo are removed and the crank body is placed at ``S1``; actuators are
disabled (loads are applied through ``qfrc_applied`` and joint damping).  Configurations come
from the closed-form oracle (``tests/oracles.py``), never from the in-house solver.

* Generalized inertia: ``n^T M n`` with ``n`` the null-space vector of the loop constraints
  (connect gap, zero rod spin ``u . omega_rod = 0``, and ``S1_dot = S1' theta_dot`` when the
  axial joint is kept), scaled to ``theta_dot = 1``.
* Run-up: MuJoCo's RK4 integrator at ``dt = 1e-4 s`` with its soft connect; ``psi(t)`` and
  ``S4(t)`` against ``forward_dynamics.simulate``.
"""

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from dualmech.models.case import load_case
from dualmech.models.mjcf import case_to_mjcf, default_settings
from dualmech.models.slider_crank import dynamics_coefficients as dc
from dualmech.models.slider_crank import forward_dynamics as fd
from dualmech.validation.tolerances import DYN_MUJOCO_INERTIA, DYN_MUJOCO_INERTIA_DERIVATIVE, DYN_MUJOCO_RUNUP
from tests import oracles

mujoco = pytest.importorskip("mujoco")

#: MuJoCo time step of the run-up comparison (RK4), seconds.
RUNUP_TIMESTEP = 1e-4


def _closed_form(case, theta, s1):
    """S4, P2, P3 on the branch (P3 - P2).k4 < 0 at one crank angle: the tests' closed form
    (tests/oracles.py)."""
    g = case.geometry
    foot, k4 = oracles.slider_line(g.slider_offset, g.slider_twist)
    p2 = np.array([g.crank_length * math.cos(theta), g.crank_length * math.sin(theta), s1])
    s4 = float(oracles.sphere_line_s4(p2, foot, k4, g.rod_length)[0])
    return s4, p2, foot - s4 * k4


def _build(case, hold_axial: bool, damping: tuple[float, float] = (0.0, 0.0)):
    spec = mujoco.MjSpec.from_string(case_to_mjcf(case, default_settings(case, RUNUP_TIMESTEP)))
    if hold_axial:
        spec.delete(spec.actuator("crank_axial_servo"))
        spec.delete(spec.joint("crank_axial"))
        spec.body("crank").pos = [0.0, 0.0, case.geometry.crank_axial_shift]
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_RK4
    model = spec.compile()
    model.dof_damping[:] = 0.0
    model.dof_damping[model.joint("crank_angle").dofadr[0]] = damping[0]
    model.dof_damping[model.joint("slider_stroke").dofadr[0]] = damping[1]
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_ACTUATION
    return model, mujoco.MjData(model)


def _joint(model, name):
    j = model.joint(name)
    return int(j.qposadr[0]), int(j.dofadr[0])


def _has(model, name):
    return name in [model.joint(i).name for i in range(model.njnt)]


def _configure(model, data, case, theta, s1):
    _, p2, p3 = _closed_form(case, theta, s1)
    s4 = _closed_form(case, theta, s1)[0]
    u = (p3 - p2) / np.linalg.norm(p3 - p2)
    ref = np.array([0.0, 0.0, 1.0]) if abs(u[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    v = np.cross(ref, u)
    v /= np.linalg.norm(v)
    c, s = math.cos(theta), math.sin(theta)
    rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, (rz.T @ np.column_stack([u, v, np.cross(u, v)])).ravel())
    data.qpos[:] = 0.0
    data.qvel[:] = 0.0
    data.qpos[_joint(model, "crank_angle")[0]] = theta
    if _has(model, "crank_axial"):
        data.qpos[_joint(model, "crank_axial")[0]] = s1
    a = _joint(model, "rod_ball")[0]
    data.qpos[a:a + 4] = quat
    data.qpos[_joint(model, "slider_stroke")[0]] = s4
    mujoco.mj_forward(model, data)


def _null_vector(model, data, s1_rate):
    """Null-space vector of [connect gap; rod spin; axial cam] with unit crank rate, ``(nv,)``."""
    nv = model.nv
    j_end, j_pin, j_rod = np.zeros((3, nv)), np.zeros((3, nv)), np.zeros((3, nv))
    mujoco.mj_jacSite(model, data, j_end, None, model.site("rod_end").id)
    mujoco.mj_jacSite(model, data, j_pin, None, model.site("slider_pin").id)
    rod = model.body("rod").id
    mujoco.mj_jacBody(model, data, None, j_rod, rod)
    rows = [j_end - j_pin, (data.xmat[rod].reshape(3, 3)[:, 0] @ j_rod)[None, :]]
    crank = _joint(model, "crank_angle")[1]
    if _has(model, "crank_axial"):
        axial = np.zeros((1, nv))
        axial[0, _joint(model, "crank_axial")[1]] = 1.0
        axial[0, crank] = -s1_rate
        rows.append(axial)
    jac = np.vstack(rows)
    rest = [k for k in range(nv) if k != crank]
    n = np.zeros(nv)
    n[crank] = 1.0
    n[rest] = np.linalg.solve(jac[:, rest], -jac[:, crank])
    return n


def _projected(model, data, case, theta):
    """MuJoCo's generalized inertia and gravity force at crank angles ``theta``."""
    st = case.crank_state(theta, 1.0, 0.0)
    s1, s1p = st.s, st.s_dot  # S1 and dS1/dtheta1
    inertia, gravity = [], []
    mass = np.zeros((model.nv, model.nv))
    for th, s, sp in zip(theta, s1, s1p):
        _configure(model, data, case, th, s)
        n = _null_vector(model, data, sp)
        mujoco.mj_fullM(model, data, mass)
        inertia.append(n @ mass @ n)
        gravity.append(-n @ data.qfrc_bias)  # qvel = 0: the bias is minus the gravity force
    return np.array(inertia), np.array(gravity)


CASES = {
    "ideal": ("ideal", {}, True),
    "spatial-alpha-232": ("a4-20-alpha-232", {"loads.gravity": [1.0, -2.0, -386.4]}, True),
    "spatial-driven-s1": ("a4-30-s1-3.5", {"motion.axial_amplitude": 1.5, "motion.axial_cycles": 2.0,
                                           "loads.gravity": [100.0, 0.0, -386.4]}, False),
}


@pytest.mark.parametrize("key", sorted(CASES))
def test_generalized_inertia_matches_projected_mass_matrix(key):
    name, updates, hold = CASES[key]
    case = load_case(name).with_values(updates) if updates else load_case(name)
    model, data = _build(case, hold_axial=hold)
    rng = np.random.default_rng(50)
    theta = rng.uniform(0, 2 * np.pi, 12)
    inertia, gravity = _projected(model, data, case, theta)
    ours = dc.coefficients(case, theta)
    assert_allclose(ours.inertia, inertia, rtol=DYN_MUJOCO_INERTIA.value)
    g_scale = max(np.abs(gravity).max(), 1e-300)
    assert_allclose(ours.gravity_force, gravity, rtol=0, atol=DYN_MUJOCO_INERTIA.value * g_scale)
    h = 1e-5
    d_inertia = (
        _projected(model, data, case, theta + h)[0] - _projected(model, data, case, theta - h)[0]
    ) / (2 * h)
    assert_allclose(ours.inertia_derivative, d_inertia, rtol=0,
                    atol=DYN_MUJOCO_INERTIA_DERIVATIVE.value * inertia.max())


RUNUPS = {
    "ideal": ("ideal", {}, 100.0, (0.0, 0.0)),
    "spatial-gravity-damping": (
        "a4-20-alpha-232",
        {"loads.gravity": [1.0, -2.0, -386.4]},
        300.0,
        (0.5, 0.02),
    ),
}


@pytest.mark.parametrize("key", sorted(RUNUPS))
def test_run_up_matches_mujoco_forward_simulation(key):
    """Done-when: psi(t) and S4(t) of a constant-torque run-up from rest agree with MuJoCo (RK4,
    dt = 1e-4 s) to DYN_MUJOCO_RUNUP of their range."""
    name, updates, tau, (c1, c4) = RUNUPS[key]
    case = load_case(name).with_values(updates) if updates else load_case(name)
    duration, psi0 = 1.5, 0.25
    sim = fd.simulate(
        case, duration, torque=tau, psi0=psi0, psidot0=0.0, damping=c1, slider_damping=c4, samples=16
    )
    model, data = _build(case, hold_axial=True, damping=(c1, c4))
    _configure(model, data, case, psi0, case.geometry.crank_axial_shift)
    crank, slider = _joint(model, "crank_angle"), _joint(model, "slider_stroke")
    data.qfrc_applied[crank[1]] = tau
    steps = int(round(duration / RUNUP_TIMESTEP))
    every = steps // (len(sim.t) - 1)
    psi, s4 = [], []
    for k in range(steps + 1):
        if k % every == 0:
            psi.append(data.qpos[crank[0]])
            s4.append(data.qpos[slider[0]])
        if k < steps:
            mujoco.mj_step(model, data)
    assert_allclose(data.time, duration, rtol=1e-12)
    assert_allclose(psi, sim.psi, rtol=0, atol=DYN_MUJOCO_RUNUP.value * np.ptp(sim.psi))
    assert_allclose(s4, sim.s4, rtol=0, atol=DYN_MUJOCO_RUNUP.value * np.ptp(sim.s4))
    assert np.ptp(sim.psi) > 2 * np.pi  # the run passes both dead centres
