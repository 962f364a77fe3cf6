"""Forward dynamics of the RSSR and the RCCC from the in-house inverse dynamics (generalized inertia), the
loop engine on their preset tables (``models/loop/preset_dynamics.py``).

Each check is shown failing on a deliberate fault: a wrong sign of ``C`` breaks the energy of free
motion, a wrong sign of the output ratio the work-energy balance and the virtual work of the output
torque, an inertia that took the wrong difference the finite-difference inertia.  MuJoCo's free
simulation of the RSSR (no servo, the drive torque applied) follows it.
"""

from __future__ import annotations

import copy
from dataclasses import replace

import numpy as np
import pytest
from numpy.testing import assert_allclose

from dualmech.core.motion import CrankState
from dualmech.core.thresholds import Tolerance
from dualmech.models.linkages import forward_dynamics, linkage_case, read_linkage, solve_linkage, table_spec
from dualmech.models.linkages.forward_dynamics import POINTS, Coefficients, drive_load, inverse_case, loads
from dualmech.models.linkages.rssr_case import RssrCase
from dualmech.models.loop.preset_dynamics import at_states, simulate
from tests.linkage_oracles import analyze_rccc, analyze_rssr, rccc_to_table, rssr_to_table

KINDS = ("rssr", "rccc")
#: Free motion (no torques, 1 s): peak-to-peak total energy over the peak kinetic energy.
FREE_ENERGY = Tolerance(
    1e-9, "DOP853's global error at rtol = atol = 1e-12 (it scales with rtol: 9.4e-8 at 1e-8, 1.4e-12 at "
    "1e-13) on a table interpolated to ~1e-13; measured 2.8e-11 (RSSR), 3.5e-11 (RCCC); wrong sign of C: ~1")
#: Work-energy balance under a drive torque, damping and the output torque: the largest
#: |delta(T + V) - (W_drive + W_output - D)| over the largest energy or work.
WORK_ENERGY = Tolerance(
    1e-9, "the same integrator error as FREE_ENERGY (the works are integrated with the motion); measured "
    "6.7e-12 (RSSR), 8.8e-12 (RCCC); a wrong sign of the output ratio: 0.58, 1.4")
#: Generalized inertia against sum(m |dG/dtheta|^2 + w' I w) by central differences of the poses (h = 1e-5),
#: relative to its peak.
INERTIA_FINITE_DIFFERENCE = Tolerance(
    1e-8, "truncation ~h^2 (measured 3.4e-6 at h = 1e-3, 3.4e-8 at 1e-4) plus rounding of the closed poses "
    "~1e-15/h; measured 1.6e-10 (RSSR), 3.1e-10 (RCCC) at h = 1e-5")
#: Generalized inertia against twice the kinetic energy at unit input rate, relative to its peak.
INERTIA_KINETIC = Tolerance(
    1e-12, "the same rates summed in two ways (Newton-Euler least squares, kinetic energy): round-off; "
    "measured 1.8e-13 (RSSR), 2.0e-14 (RCCC)")
#: C against half the derivative of the interpolated I, relative to max |C|.
HALF_DERIVATIVE = Tolerance(
    1e-9, "derivative of the degree-7 spline at 0.5 deg (error ~h^7) of a table rounded to ~1e-14; "
    "measured 8.1e-12 (RSSR), 2.7e-12 (RCCC)")
#: The coefficient table's spline at the midpoints of its grid against direct solves there, relative to each
#: coefficient's peak.
SPLINE_MIDPOINTS = Tolerance(
    1e-12, "a degree-7 spline on 0.5 deg (error ~h^8) down to the table's rounding; measured 3.4e-13 (RSSR), "
    "6.5e-14 (RCCC); a cubic one misses by 7.1e-9, 8.3e-8")
#: The table along a simulated motion against the case solved at each simulated state, relative to the peak of
#: each column's unit group (the closure and dynamics residuals absolutely: they are ratios).
SIMULATED_VS_SOLVED = Tolerance(
    1e-12, "the same analysis at the same states, the rate passed through rpm: round-off; measured <= "
    "5.7e-14 absolute (RSSR branch -1, phi4_ddot), the peaks O(1) to O(100)")
#: Q with the output torque T minus Q without it, against -T G, relative to |T| max |G|.
OUTPUT_VIRTUAL_WORK = Tolerance(
    1e-11, "an identity of the linear inverse dynamics: round-off; measured 3.2e-15 (RSSR), 1.5e-15 (RCCC)")


def coefficients(case, points: int = POINTS) -> Coefficients:
    """The coefficient table of ``case`` by the loop engine on its preset table."""
    return forward_dynamics.coefficients(case, at_states, points)


def energy(case, theta: np.ndarray, theta_dot: np.ndarray) -> np.ndarray:
    """Kinetic plus potential energy at the input states, by the loop engine on the preset table."""
    return forward_dynamics.energy(case, at_states, theta, theta_dot)


@pytest.fixture(scope="module", params=KINDS)
def kind(request: pytest.FixtureRequest) -> str:
    return request.param


@pytest.fixture(scope="module")
def free_case(kind: str):
    """The bundled case without output torque (gravity kept)."""
    return replace(linkage_case(kind), output_torque=0.0)


@pytest.fixture(scope="module")
def free_coeffs(free_case) -> Coefficients:
    return coefficients(free_case)


def _free_drift(case, coeffs: Coefficients) -> tuple[float, float]:
    """Peak-to-peak kinetic plus potential energy over the peak kinetic energy, and the swing (rad), 1 s
    without torques."""
    sim = simulate(case, 1.0, torque=0.0, samples=201, coeffs=coeffs)
    total = sim.kinetic + sim.potential
    return float(np.ptp(total) / sim.kinetic.max()), float(np.ptp(sim.psi))


def test_energy_is_kept_in_free_motion(free_case, free_coeffs) -> None:
    drift, swing = _free_drift(free_case, free_coeffs)
    assert swing > 3.0  # through half a turn and more: the whole range of I(theta) is visited
    assert drift <= FREE_ENERGY.value


def test_the_energy_check_sees_a_wrong_sign_of_c(free_case, free_coeffs) -> None:
    """Deliberate fault: ``C`` with the wrong sign (the ``C theta_dot^2`` term added instead of
    subtracted)."""
    wrong = replace(free_coeffs, velocity=-free_coeffs.velocity)
    assert _free_drift(free_case, wrong)[0] > 1e3 * FREE_ENERGY.value


def _driven(case, coeffs: Coefficients | None = None):
    """1 s under a drive torque law, input damping and the case's output torque."""
    return simulate(case, 1.0, torque="0.5 + 0.1*sin(psi) - 0.02*psidot", damping=0.01, samples=201,
                    coeffs=coeffs)


def _work_energy(sim) -> float:
    scale = max(np.abs(sim.kinetic).max(), np.abs(sim.work_drive).max(), np.abs(sim.work_output).max())
    return float(np.abs(sim.energy_residual()).max() / scale)


def test_work_energy_balance_under_a_drive_torque(kind: str) -> None:
    sim = _driven(linkage_case(kind))
    assert np.abs(sim.work_output).max() > 0.1 and np.abs(sim.dissipated).max() > 1e-3  # every term works
    assert _work_energy(sim) <= WORK_ENERGY.value
    # the inverse dynamics along the motion needs the motor torque less the bearing's damping
    assert_allclose(sim.table.columns["drive_torque"], sim.torque - 0.01 * sim.psi_dot,
                    atol=1e-9 * np.abs(sim.torque).max(), rtol=0)
    assert (sim.table.status == "ok").all()


def test_the_work_energy_check_sees_a_wrong_output_ratio(kind: str) -> None:
    """Deliberate fault: the output link's rate with the wrong sign (its torque's work has the wrong sign)."""
    case = linkage_case(kind)
    c = coefficients(case)
    assert _work_energy(_driven(case, replace(c, ratio=-c.ratio))) > 1e3 * WORK_ENERGY.value


def _output_virtual_work(kind: str, c: Coefficients) -> float:
    """Worst |Q(T) - Q(0) + T G| over |T| max |G|: the output torque's share of the load term is its
    virtual work."""
    torque = linkage_case(kind).output_torque
    unloaded = coefficients(replace(linkage_case(kind), output_torque=0.0))
    worst = np.abs(c.load - unloaded.load + torque * c.ratio).max()
    return float(worst / abs(torque) / np.abs(c.ratio).max())


def test_the_output_torque_does_virtual_work_through_the_output_ratio(kind: str) -> None:
    c = coefficients(linkage_case(kind))
    assert _output_virtual_work(kind, c) <= OUTPUT_VIRTUAL_WORK.value
    assert _output_virtual_work(kind, replace(c, ratio=-c.ratio)) > 0.1  # deliberate fault: seen


def _vee(skew: np.ndarray) -> np.ndarray:
    return 0.5 * np.stack([skew[:, 2, 1] - skew[:, 1, 2], skew[:, 0, 2] - skew[:, 2, 0],
                           skew[:, 1, 0] - skew[:, 0, 1]], axis=1)


def finite_difference_inertia(case, theta: np.ndarray, h: float = 1e-5) -> np.ndarray:
    """``sum(m |dG/dtheta|^2 + w' I_world w)`` ``(n,)`` from the poses at ``theta +- h`` alone (rates 0):
    ``dG/dtheta`` and ``w^ = dR/dtheta R'`` by central differences.  The RSSR coupler's spin about its axis
    is a gauge (``docs/conventions.md``, "RSSR"), so its ``w`` is taken normal to the axis."""
    zero = np.zeros(2 * theta.size)
    poses = CrankState(np.concatenate([theta + h, theta - h]), zero, zero, zero, zero, zero)
    an = at_states(inverse_case(case), poses)
    n, total = theta.size, np.zeros(theta.size)
    for k, (body, m) in enumerate(zip(case.bodies, an.motions)):
        mid = 0.5 * (m.rotation[:n] + m.rotation[n:])
        w = _vee((m.rotation[:n] - m.rotation[n:]) / (2 * h) @ np.swapaxes(mid, 1, 2))
        if isinstance(case, RssrCase) and k == 1:
            u = mid[:, :, 0] / np.linalg.norm(mid[:, :, 0], axis=1, keepdims=True)
            w -= np.einsum("ni,ni->n", w, u)[:, None] * u
        v = (m.com[:n] - m.com[n:]) / (2 * h)
        total += body.mass * np.einsum("ni,ni->n", v, v) + np.einsum(
            "ni,nij,nj->n", w, mid @ body.inertia @ np.swapaxes(mid, 1, 2), w)
    return total


def test_the_generalized_inertia_is_that_of_the_bodies(kind: str) -> None:
    case = linkage_case(kind)
    c = coefficients(case, 73)  # every 5 deg
    theta, inertia = c.theta[:-1], c.inertia[:-1]
    peak = inertia.max()
    assert_allclose(finite_difference_inertia(case, theta), inertia,
                    atol=INERTIA_FINITE_DIFFERENCE.value * peak, rtol=0)
    kinetic = energy(case, theta, np.ones_like(theta)) - energy(case, theta, np.zeros_like(theta))
    assert_allclose(2 * kinetic, inertia, atol=INERTIA_KINETIC.value * peak, rtol=0)


def test_the_inertia_check_sees_a_wrong_difference(kind: str) -> None:
    """Deliberate fault: the inertia taken as (unit acceleration) - (unit rate) instead of - (at rest)."""
    case = linkage_case(kind)
    c = coefficients(case, 73)
    wrong = c.inertia[:-1] - c.velocity[:-1]
    worst = np.abs(finite_difference_inertia(case, c.theta[:-1]) - wrong).max() / c.inertia.max()
    assert worst > 1e3 * INERTIA_FINITE_DIFFERENCE.value


def _half_derivative(c: Coefficients) -> float:
    d_inertia = c.spline().derivative()(c.theta)[:, 0]
    return float(np.abs(d_inertia / 2 - c.velocity).max() / np.abs(c.velocity).max())


def test_c_is_half_the_derivative_of_the_inertia(free_coeffs: Coefficients) -> None:
    assert _half_derivative(free_coeffs) <= HALF_DERIVATIVE.value
    assert _half_derivative(replace(free_coeffs, velocity=-free_coeffs.velocity)) > 1.0  # fault: seen


def test_a_linkage_whose_input_does_not_turn_is_refused() -> None:
    case = linkage_case("rssr")
    rocker = replace(case, geometry=replace(case.geometry, a1=0.3))
    with pytest.raises(ValueError, match="does not turn fully [(]no_assembly: the coupler cannot reach the "
                       "output crank at crank angles [0-9.]+[.][.][0-9.]+ deg[)]"):
        coefficients(rocker, 37)


def test_a_drive_torque_may_not_name_the_slider() -> None:
    with pytest.raises(ValueError, match="torque: '2[*]s4dot' uses s4dot, the slider crank's slider"):
        drive_load("2*s4dot", 0.0)
    assert drive_load("2*psidot + t", 0.0)(1.0, 0.0, 3.0, np.nan, np.nan) == 7.0


def test_an_rssr_case_in_drive_torque_mode_is_driven_by_its_torque() -> None:
    """Its ``drive_torque`` is the default torque and no output torque acts: the inverse dynamics along the
    motion (output torque 0 given) returns the applied torque."""
    case = replace(linkage_case("rssr"), drive_torque=0.5, output_torque=None)
    assert loads(case) == (0.5, 0.0)
    sim = simulate(case, 0.2, samples=21)
    assert (sim.torque == 0.5).all() and (sim.work_output == 0.0).all()
    assert_allclose(sim.table.columns["drive_torque"], 0.5, rtol=0, atol=1e-9)
    assert _work_energy(sim) <= WORK_ENERGY.value


def _spline_midpoints(kind: str) -> float:
    """Worst miss of the table's spline at its grid's midpoints (direct solves on the 0.25 deg grid)."""
    c, fine = coefficients(linkage_case(kind)), coefficients(linkage_case(kind), 2 * POINTS - 1)
    data = fine.stacked()
    return float((np.abs(c.spline()(fine.theta[1::2]) - data[1::2]) / np.abs(data).max(axis=0)).max())


def test_the_coefficient_spline_is_exact_to_rounding(kind: str, monkeypatch: pytest.MonkeyPatch) -> None:
    assert _spline_midpoints(kind) <= SPLINE_MIDPOINTS.value
    monkeypatch.setattr(forward_dynamics, "SPLINE_DEGREE", 3)  # deliberate fault: a cubic spline
    assert _spline_midpoints(kind) > 1e3 * SPLINE_MIDPOINTS.value


@pytest.mark.parametrize("branch", [1, -1])
def test_the_simulated_table_is_the_solved_one_at_each_simulated_state(kind: str, branch: int) -> None:
    """Oracle: each simulated state (theta1, its rate and acceleration) solved again by ``dualmech solve``'s
    path, the raw case table with its ``[mechanism]`` options (the branch) and its ``[motion]`` set to that
    state.  The slider crank's simulate dropped its universal joint's moment on the way (issue 30); here
    every option of the case must reach the table along the motion, on both branches."""
    raw = copy.deepcopy(read_linkage(kind))
    raw["mechanism"]["branch"] = branch
    sim = simulate(linkage_case(raw), 0.2, torque=1.0, damping=0.05, samples=6)
    spec = table_spec(kind, linkage_case(raw))
    rows = []
    for psi, rate, accel in zip(sim.psi, sim.psi_dot, sim.psi_ddot):
        deg = float(np.degrees(psi))
        raw["motion"] = {"crank_rpm": float(rate * 30.0 / np.pi), "crank_accel": float(accel),
                         "angles_deg": {"start": deg, "stop": deg + 0.5, "step": 1.0}}
        rows.append(solve_linkage(raw))
    assert all(len(r) == 1 and r.status[0] == "ok" for r in rows) and (sim.table.status == "ok").all()
    assert sim.table.meta["branch"] == branch
    solved = {c: np.array([r[c][0] for r in rows]) for c in spec.columns}
    for c in spec.columns:
        group = [g for g in spec.columns if spec.unit_group(g) == spec.unit_group(c)]
        scale = 1.0 if c.endswith("residual") else max(np.abs(solved[g]).max() for g in group)
        assert_allclose(sim.table[c], solved[c], rtol=0, atol=SIMULATED_VS_SOLVED.value * scale, err_msg=c)


#: The analysis at given input states against the closed-form oracle there, relative to each quantity's peak.
STATES_VS_ORACLE = Tolerance(
    1e-12, "the same pose, rates and reactions by two engines (the loop engine by continuation, the "
    "closed-form pipeline row by row): round-off; measured 6.2e-15 (RSSR, the output crank's centre of "
    "mass velocity), 5.2e-15 (RCCC, j1_fy)")


def _oracle(case, crank: CrankState):
    """The closed-form pipeline's analysis at ``crank`` (``tests/linkage_oracles.py``): its table, output
    rate and motions."""
    if isinstance(case, RssrCase):
        an = analyze_rssr(case, crank=crank)
        return rssr_to_table(an), an.phi_dot, an.motions
    an = analyze_rccc(case, crank=crank)
    return rccc_to_table(an), -an.q_dot[:, 4], an.motions


def _states_vs_oracle(kind: str) -> dict[str, float]:
    """Worst difference of :func:`at_states` from the oracle at 40 states over three turns in random order
    (random rates and accelerations), per motion field, the output rate and the table's columns, each over
    its peak in the oracle (the residuals absolutely)."""
    case = inverse_case(linkage_case(kind))
    rng = np.random.default_rng(7)
    theta = rng.permutation(np.linspace(-2 * np.pi, 4 * np.pi, 40))
    zero = np.zeros_like(theta)
    crank = CrankState(theta, zero, rng.uniform(-20, 20, 40), zero, rng.uniform(-300, 300, 40), zero)
    ours = at_states(case, crank)
    table, rate, motions = _oracle(case, crank)
    worst = {"output_rate": float(np.abs(ours.output_rate - rate).max() / np.abs(rate).max())}
    for k, (m, o) in enumerate(zip(ours.motions, motions)):
        for f in ("rotation", "origin", "com", "com_vel", "com_acc", "omega", "omega_dot"):
            ref = getattr(o, f)
            worst[f"link{k + 1}.{f}"] = float(np.abs(getattr(m, f) - ref).max() / max(np.abs(ref).max(), 1.0))
    spec = table_spec(kind, case)
    for c in spec.columns:
        group = [g for g in spec.columns if spec.unit_group(g) == spec.unit_group(c)]
        scale = 1.0 if c.endswith("residual") else max(np.abs(table[g]).max() for g in group)
        worst[c] = float(np.abs(ours.table[c] - table[c]).max() / scale)
    assert list(ours.table.status) == list(table.status) == ["ok"] * 40
    assert ours.table.meta["branch"] == table.meta["branch"] and ours.table.meta["messages"] == []
    return worst


def test_the_analysis_at_given_states_is_the_closed_form_ones(kind: str) -> None:
    """Oracle: the closed-form pipeline at the same input states, every link's motion in the mechanism's own
    body frames (``docs/conventions.md``, "RSSR", "RCCC": the RSSR's output crank frame at ``Q4``, x toward
    ``P3``; its coupler's completed as its estimate completes it), the output rate and every column.  Seen
    failing on deliberate faults in ``models/loop/preset_dynamics.py`` (the report of the change says
    which)."""
    worst = _states_vs_oracle(kind)
    assert max(worst.values()) <= STATES_VS_ORACLE.value, {k: v for k, v in worst.items() if v > 1e-13}
