"""Pinocchio judge, dynamics: Newton–Euler and power identities, mode round trip, forward-dynamics check.

The reactions are judged against oracles that share nothing with either engine:
closed-form kinematics with per-body Newton–Euler balances and the power balance
(``tests/pinocchio_oracles.py``).  Pinocchio's own forward
``constraintDynamics`` must reproduce the prescribed accelerations from the efforts found.
"""

import numpy as np
import pytest
from click.testing import CliRunner
from numpy.testing import assert_allclose

from dualmech.core.table import REACTION_COLUMNS, read_csv
from dualmech.models.case import load_case, preset_names, with_loads
from dualmech.validation.tolerances import (
    DEAD_CENTRE_TRANSMISSION,
    PINOCCHIO_BALANCE,
    PINOCCHIO_FORWARD_DYNAMICS,
    PINOCCHIO_SUPERPOSITION,
)
from tests.pinocchio_oracles import (
    condition,
    group_scales,
    newton_euler_residuals,
    power_terms,
    random_case,
)

pin = pytest.importorskip("pinocchio")
from dualmech.validation.judges.pinocchio_slider_crank import engine as pe  # noqa: E402

GRAVITY = np.array([3.0, -50.0, -386.4])


def _variants(case):
    """The case in torque and force mode, gravity off and on."""
    force = with_loads(case, drive_torque=None, slider_force=-250.0)
    out = []
    for c in (case, force):
        out += [with_loads(c, gravity=np.zeros(3)), with_loads(c, gravity=GRAVITY)]
    return out


def _bundled_and_random():
    cases = [v for name in preset_names() if name.startswith("thesis/") for v in _variants(load_case(name))]
    for seed in range(4):
        rng = np.random.default_rng(100 + seed)
        cases += [random_case(rng, "torque", step=10.0), random_case(rng, "force", step=10.0)]
    return cases


CASES = _bundled_and_random()


@pytest.mark.parametrize("case", CASES, ids=[f"{i}-{c.name}-{c.loads.mode}" for i, c in enumerate(CASES)])
def test_every_body_is_in_newton_euler_balance(case):
    """18 balance equations per position (3 bodies x force, moment about the centre of mass)."""
    table = pe.solve_case(case)
    rows = table.status == "ok"
    assert rows.sum() >= len(table) - 2  # only the exact dead centres of a planar in-line case drop out
    cond = condition(case, table)
    force_scale, moment_scale = group_scales(table, rows, cond)
    res = newton_euler_residuals(case, table)[rows]
    tol = PINOCCHIO_BALANCE.value * cond[rows, None]
    assert np.all(np.abs(res[:, :, :3]).max(axis=2) <= tol * force_scale)
    assert np.all(np.abs(res[:, :, 3:]).max(axis=2) <= tol * moment_scale)
    # the given load is what the table reports, to the same round-off x condition as the balances above (the
    # drive torque is j1_mz, a difference of wrenches that grow like 1/|t| near a dead centre)
    if case.loads.mode == "torque":
        given, column, scale = case.loads.drive_torque, "drive_torque", moment_scale
    else:
        given, column, scale = case.loads.slider_force, "slider_load", force_scale
    assert_allclose(
        (table[column][rows] - given) / (cond[rows] * scale), 0.0, rtol=0, atol=PINOCCHIO_BALANCE.value
    )
    assert_allclose(table["drive_torque"], table["j1_mz"], rtol=0, atol=0)


@pytest.mark.parametrize(
    "case", CASES[::3], ids=[f"{i}-{c.name}-{c.loads.mode}" for i, c in enumerate(CASES[::3])]
)
def test_power_balance(case):
    """Drive + axial + slider-load + gravity power = dK/dt at every position."""
    table = pe.solve_case(case)
    rows = table.status == "ok"
    terms, kinetic_rate = power_terms(case, table)
    cond = condition(case, table)
    scale = max(np.abs(terms[rows] / cond[rows, None]).max(), np.abs(kinetic_rate[rows] / cond[rows]).max())
    assert np.all(
        np.abs(terms[rows].sum(1) - kinetic_rate[rows]) <= PINOCCHIO_BALANCE.value * scale * cond[rows]
    )


def test_torque_and_force_modes_round_trip():
    """Torque mode gives a slider load; feeding it back in force mode gives the same torque and reactions."""
    torque_case = with_loads(load_case("a4-20-alpha-310"), gravity=GRAVITY)
    for theta in (7.0, 95.0, 181.0, 300.0):
        one = torque_case.with_values(
            {"motion.angles_deg": {"start": theta, "stop": theta + 1.0, "step": 1.0}}
        )
        t_torque = pe.solve_case(one)
        forced = with_loads(one, drive_torque=None, slider_force=float(t_torque["slider_load"][0]))
        t_force = pe.solve_case(forced)
        scale = max(np.abs(t_torque[c]).max() for c in REACTION_COLUMNS)
        for col in REACTION_COLUMNS:
            assert_allclose(
                t_force[col], t_torque[col], rtol=0, atol=PINOCCHIO_BALANCE.value * scale, err_msg=col
            )


@pytest.mark.parametrize("case", [CASES[5], CASES[-1], CASES[-2]],
                         ids=["thesis-gravity", "random-force", "random-torque"])
def test_forward_constraint_dynamics_reproduces_the_motion(case):
    """pin.constraintDynamics(q, v, efforts) returns the prescribed accelerations and the same closure
    force."""
    pm = pe.build_model(case)
    sol, _ = pe.solve(case, pm)
    data = pm.model.createData()
    models = pin.StdVec_RigidConstraintModel()
    models.append(pm.constraint)
    datas = pin.StdVec_RigidConstraintData()
    datas.append(pm.constraint.createData())
    pin.initConstraintDynamics(pm.model, data, models, datas)
    rows = np.flatnonzero(sol.status == 0)
    assert rows.size > 0
    for i in rows[:: max(1, rows.size // 24)]:
        a = pin.constraintDynamics(pm.model, data, sol.q[i], sol.v[i], sol.effort[i], models, datas)
        assert_allclose(a, sol.a[i], rtol=0, atol=PINOCCHIO_FORWARD_DYNAMICS.value * np.abs(sol.a[i]).max())
        rod_axes = data.oMi[pm.rod_joint].rotation  # lambda_c is in the LOCAL frame of the rod end
        lam = sol.closure_force[i]
        assert_allclose(rod_axes @ data.lambda_c, lam, rtol=0,
                        atol=PINOCCHIO_FORWARD_DYNAMICS.value * np.abs(lam).max())


def test_rnea_with_the_closure_force_gives_the_joint_wrenches():
    """rnea(q, v, a, fext = closure force) returns the efforts, and data.f the wrenches of the table.

    Also: the ball joint at P2 transmits no moment (its wrench's moment about P2 vanishes).
    """
    case = random_case(np.random.default_rng(21), "torque", step=15.0)
    pm = pe.build_model(case)
    sol, _ = pe.solve(case, pm)
    model, data = pm.model, pm.model.createData()
    tol = PINOCCHIO_SUPERPOSITION.value
    for i in np.flatnonzero(sol.status == 0):
        q, v, a, lam = sol.q[i], sol.v[i], sol.a[i], sol.closure_force[i]
        pin.forwardKinematics(model, data, q)
        rod = data.oMi[pm.rod_joint]
        fext = pin.StdVec_Force()
        for _ in range(model.njoints):
            fext.append(pin.Force.Zero())
        end = np.array([pm.a2, 0.0, 0.0])
        local = rod.rotation.T @ lam
        fext[pm.rod_joint] = pin.Force(local, np.cross(end, local))
        # slider axes = world axes, applied at its origin P3
        fext[pm.slider_joint] = pin.Force(-lam, np.zeros(3))
        tau = pin.rnea(model, data, q, v, a, fext)
        scale = np.abs(sol.effort[i]).max()
        assert_allclose(tau, sol.effort[i], rtol=0, atol=tol * scale)
        wrenches = {j: data.oMi[j].act(data.f[j]) for j in (pm.crank_joint, pm.rod_joint, pm.slider_joint)}
        world = {j: np.r_[w.linear, w.angular] for j, w in wrenches.items()}
        fscale = max(np.abs(sol.wrench1[i]).max(), np.abs(sol.wrench4[i]).max(), np.abs(lam).max())
        assert_allclose(world[pm.crank_joint], sol.wrench1[i], rtol=0, atol=tol * fscale * pm.a2)
        assert_allclose(world[pm.rod_joint], sol.wrench2[i], rtol=0, atol=tol * fscale * pm.a2)
        assert_allclose(world[pm.slider_joint], sol.wrench4[i], rtol=0, atol=tol * fscale * pm.a2)
        moment_at_p2 = sol.wrench2[i, 3:] - np.cross(rod.translation, sol.wrench2[i, :3])
        assert_allclose(moment_at_p2, 0.0, atol=tol * fscale * pm.a2)


def test_dead_centres_are_flagged_in_torque_mode_only():
    torque = pe.solve_case(load_case("ideal"))
    dead = torque.status == "dead_centre"
    assert_allclose(torque["theta1_deg"][dead], [90.0, 270.0])  # the slider line is the y axis
    assert np.all(np.abs(torque["transmission"][dead]) < DEAD_CENTRE_TRANSMISSION.value)
    for col in REACTION_COLUMNS:
        assert np.isnan(torque[col][dead]).all() and np.isfinite(torque[col][~dead]).all(), col
    assert np.isfinite(torque["S4_ddot"]).all()
    assert torque.meta["messages"] == ["dead_centre: 2 positions at 90, 270 deg"]
    force = pe.solve_case(with_loads(load_case("ideal"), drive_torque=None, slider_force=-50.0))
    assert (force.status == "ok").all()
    assert_allclose(force["slider_load"], -50.0, rtol=PINOCCHIO_BALANCE.value)


def test_cli_solve_with_the_pinocchio_engine(tmp_path):
    from dualmech.cli import main

    out = tmp_path / "pin.csv"
    result = CliRunner().invoke(main, ["solve", "a4-30-s1-3.5", "--engine", "pinocchio", "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert "(pinocchio): ok 360" in result.output
    table = read_csv(out)
    direct = pe.solve_case(load_case("a4-30-s1-3.5"))
    assert (table.status == "ok").all()
    for col in ("S4", "j1_fx", "j4_mz", "slider_load"):
        assert_allclose(table[col], direct[col], rtol=0, atol=0)


def test_benchmark_reports_per_position_cost():
    case = load_case("a4-30-s1-3.5").with_values(
        {"motion.angles_deg": {"start": 0.0, "stop": 360.0, "step": 10.0}}
    )
    report = pe.benchmark(case, repeats=2)
    assert report["engine"] == "pinocchio" and report["positions"] == 36 and report["repeats"] == 2
    assert report["us_per_position"] > 0 and report["positions_us"] > 0 and report["dynamics_us"] > 0
    with pytest.raises(ValueError, match="repeats"):
        pe.benchmark(case, repeats=0)
