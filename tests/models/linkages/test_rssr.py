"""The closed-form RSSR pipeline (the forward dynamics' analysis and the oracle of the in-house engine,
``tests/models/loop/test_preset_engine.py``): Newton closes the loop from a poor estimate, rates match
finite differences, the reactions balance power and the Newton-Euler equations, both load modes agree,
statuses are honest."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.optimize import brentq

from dualmech.core.status import Status
from dualmech.models.linkages.rssr import closed_form_phi, crank_pin, output_pin
from dualmech.models.linkages.rssr_case import RssrCase, rssr_from_dict
from tests import linkage_oracles, linkage_reactions
from tests.linkage_cases import bundled, random_rssr
from tests.linkage_oracles import analyze_rssr
from tests.linkage_oracles import rssr_to_table as to_table
from tests.tolerances import (
    LINKAGE_CLOSED_FORM,
    LINKAGE_DYNAMICS_RESIDUAL,
    LINKAGE_FINITE_DIFFERENCE,
    LINKAGE_POWER_BALANCE,
)


def _wrap(d: np.ndarray) -> np.ndarray:
    return np.mod(d + math.pi, 2 * math.pi) - math.pi


def test_newton_closes_the_loop_from_a_poor_estimate() -> None:
    """Start 0.3 rad off the closed form: the dual-number Newton (not the estimate) lands on the answer."""
    rng = np.random.default_rng(11)
    case = rssr_from_dict(bundled())  # |t4| >= 0.44 everywhere: a 0.3 rad error stays on the branch
    exact = analyze_rssr(case)
    theta = exact.crank.theta
    error = rng.uniform(0.1, 0.3, theta.shape) * rng.choice([-1.0, 1.0], theta.shape)
    guess = closed_form_phi(case.geometry, theta, case.branch)[0] + error
    moved = analyze_rssr(case, phi_guess=guess)
    assert (moved.iterations >= 2).all() and (moved.status == Status.OK).all()
    assert_allclose(_wrap(moved.phi - exact.phi), 0.0, rtol=0, atol=LINKAGE_CLOSED_FORM.value)
    p2, p3 = crank_pin(case.geometry, theta), output_pin(case.geometry, moved.phi)
    assert_allclose(np.linalg.norm(p3 - p2, axis=1), case.geometry.a2, rtol=LINKAGE_CLOSED_FORM.value, atol=0)


@pytest.mark.parametrize("seed", [1, 2])
def test_rates_match_finite_differences_of_the_closed_form(seed: int) -> None:
    rng = np.random.default_rng(seed)
    case = rssr_from_dict(random_rssr(rng))
    an = analyze_rssr(case)
    th, w, wd = an.crank.theta, an.crank.theta_dot, an.crank.theta_ddot
    h = 1e-4
    f = [closed_form_phi(case.geometry, th + k * h, case.branch)[0] for k in (-1, 0, 1)]
    d1 = _wrap(f[2] - f[0]) / (2 * h)
    d2 = (_wrap(f[2] - f[1]) - _wrap(f[1] - f[0])) / h**2
    for got, want in ((an.phi_dot, d1 * w), (an.phi_ddot, d2 * w**2 + d1 * wd)):
        peak = np.abs(want).max()
        tol = LINKAGE_FINITE_DIFFERENCE.value
        assert_allclose(got, want, rtol=tol, atol=tol * peak)


def power_residual(an) -> np.ndarray:
    """``(drive power + output power + weight power - dT/dt) / largest term``, ``(n,)``."""
    r, case = an.reactions, an.case
    drive = r.moment["j1"][:, 2] * an.crank.theta_dot
    out = (r.moment["j4"] @ case.geometry.k4) * an.phi_dot
    terms = [drive, out]
    for body, m in zip(case.bodies, an.motions):
        terms.append(body.mass * m.com_vel @ case.gravity)
        i_world = m.rotation @ body.inertia @ np.swapaxes(m.rotation, 1, 2)
        terms.append(-body.mass * np.einsum("ni,ni->n", m.com_vel, m.com_acc)
                     - np.einsum("ni,nij,nj->n", m.omega, i_world, m.omega_dot))
    scale = np.abs(np.stack(terms)).max(axis=0)
    return np.sum(terms, axis=0) / scale


@pytest.mark.parametrize("mode", ["torque", "output"])
def test_reactions_balance_power_and_newton_euler(mode: str) -> None:
    rng = np.random.default_rng(5)
    an = analyze_rssr(rssr_from_dict(random_rssr(rng, mode)))
    ok = an.status == Status.OK
    assert ok.all()
    assert_allclose(power_residual(an), 0.0, rtol=0, atol=LINKAGE_POWER_BALANCE.value)
    assert an.reactions.residual.max() <= LINKAGE_DYNAMICS_RESIDUAL.value


def test_the_power_check_sees_a_fault(monkeypatch: pytest.MonkeyPatch) -> None:
    """Deliberate fault: the reactions computed without gravity; the power balance must fail."""
    rng = np.random.default_rng(5)
    case = rssr_from_dict(random_rssr(rng))
    real = linkage_reactions.solve_joint_reactions
    monkeypatch.setattr(linkage_oracles, "solve_joint_reactions",
                        lambda b, m, j, g, given, length: real(b, m, j, 0 * g, given, length))
    assert np.abs(power_residual(analyze_rssr(case))).max() > 1e3 * LINKAGE_POWER_BALANCE.value


def test_both_load_modes_give_the_same_reactions() -> None:
    """Output torque given -> drive torque T; then T given at that angle -> the same output torque back."""
    rng = np.random.default_rng(8)
    data = random_rssr(rng, "output", step=7.0)
    first = to_table(analyze_rssr(rssr_from_dict(data)))
    k = int(np.flatnonzero(first.status == Status.OK)[3])
    angle = float(first["theta1_deg"][k])
    del data["loads"]["output_torque"]
    data["loads"]["drive_torque"] = float(first["drive_torque"][k])
    data["motion"]["angles_deg"] = {"start": angle, "stop": angle + 1.0, "step": 1.0}
    second = to_table(analyze_rssr(rssr_from_dict(data)))
    for col in first.columns:
        if col.startswith("j") or col.endswith("torque"):
            peak = max(np.abs(first[c][k]) for c in first.columns if c.startswith("j"))
            assert_allclose(second[col][0], first[col][k], rtol=1e-12, atol=1e-12 * peak, err_msg=col)


def _at_dead_centre(case: RssrCase) -> float:
    """A crank angle (deg) where the input transmission t1 changes sign (the coupler line meets z)."""
    def t1(theta_deg: float) -> float:
        one = replace(case, motion=replace(case.motion, angles_deg=np.array([theta_deg])))
        return float(analyze_rssr(one).t1[0])

    grid = analyze_rssr(case)
    k = int(np.flatnonzero(np.diff(np.sign(grid.t1)))[0])
    deg = np.degrees(grid.crank.theta)
    return brentq(t1, deg[k], deg[k + 1], xtol=1e-14)


def test_dead_centre_is_flagged_in_torque_mode_only() -> None:
    rng = np.random.default_rng(3)
    case = rssr_from_dict(random_rssr(rng, "torque"))
    deg = _at_dead_centre(case)
    at = replace(case, motion=replace(case.motion, angles_deg=np.array([deg, deg + 5.0])))
    table = to_table(analyze_rssr(at))
    assert list(table.status) == [Status.DEAD_CENTRE, Status.OK]
    assert np.isfinite(table["phi4_ddot"]).all() and np.isnan(table["drive_torque"][0])
    output_mode = replace(at, drive_torque=None, output_torque=1.0)
    assert list(to_table(analyze_rssr(output_mode)).status) == [Status.OK, Status.OK]


def _edge(case: RssrCase) -> tuple[float, float]:
    """Crank angles (deg) just inside and just outside an edge of assembly (|rho| = 1), 1e-9 deg from it."""
    grid = to_table(analyze_rssr(case))
    missing = grid.status == Status.NO_ASSEMBLY
    k = int(np.flatnonzero(np.diff(missing.astype(int)))[0])
    deg = grid["theta1_deg"]

    def reach(d: float) -> float:
        return float(np.abs(closed_form_phi(case.geometry, np.radians([d]), case.branch)[1][0]) - 1.0)

    edge = brentq(reach, deg[k], deg[k + 1], xtol=1e-13)
    toward = -1.0 if reach(deg[k]) < 0 else 1.0  # the side of the edge that assembles
    return edge + toward * 1e-9, edge - toward * 1e-9


def test_no_assembly_angles_are_stated_and_edged_by_assembly_limits() -> None:
    """A random case whose coupler cannot reach the output crank at some input angles."""
    case = rssr_from_dict(random_rssr(np.random.default_rng(11)))
    table = to_table(analyze_rssr(case))
    missing = table.status == Status.NO_ASSEMBLY
    assert 0 < missing.sum() < missing.size
    runs = table.meta["messages"][0]
    assert runs.startswith("no_assembly: the coupler cannot reach the output crank at crank angles ")
    assert np.isnan(table["phi4_deg"][missing]).all() and np.isnan(table["j1_fx"][missing]).all()
    inside, outside = _edge(case)
    at = replace(case, motion=replace(case.motion, angles_deg=np.array([inside, outside])))
    near = to_table(analyze_rssr(at))
    assert list(near.status) == [Status.ASSEMBLY_LIMIT, Status.NO_ASSEMBLY]
    assert np.isfinite(near["phi4_deg"][0]) and np.isnan(near["phi4_dot"][0])


def test_branches_have_the_stated_sign_and_a_jump_is_refused() -> None:
    data = bundled()
    data["mechanism"]["branch"] = -1
    case = rssr_from_dict(data)
    an = analyze_rssr(case)
    assert (an.status == Status.OK).all() and (an.t4 < 0).all()
    other = closed_form_phi(case.geometry, an.crank.theta, +1)[0]
    jumped = analyze_rssr(case, phi_guess=other)
    assert (jumped.status == Status.BRANCH_JUMP).all()
