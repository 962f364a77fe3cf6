"""Forward dynamics of a loop table (``models/loop/forward_dynamics.py``).

Identities first (energy of free motion, the work-energy balance), then the same motion from other
constructions: the RSSR's and RCCC's own forward dynamics on their preset tables, the slider crank's
(generalized inertia from ``core/generalized_inertia.py``) on its table with a cylindrical crank under the
axial law, and the drive effort re-solved at the simulated states by the Pinocchio judge built from the
table alone.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from numpy.testing import assert_allclose

from dualmech.core.thresholds import Tolerance
from dualmech.models.case import load_case
from dualmech.models.linkages import linkage_case
from dualmech.models.loop import forward_dynamics as fd
from dualmech.models.loop import preset_dynamics
from dualmech.models.loop.description import Drive, Joint, LoopMechanism
from dualmech.models.loop.presets import loop_table_of, slider_crank_start, slider_crank_table
from dualmech.models.slider_crank import forward_dynamics as slider_crank_fd
from dualmech.models.slider_crank.analysis import analyze
from dualmech.validation.judges.pinocchio_loop.engine import solve_loop as pinocchio_solve

#: Loop tables of the bundled cases whose drive turns fully (the 7R's has a gap: its range, below).
TURNING = ("rscr", "rsrc")
#: Free motion (no loads, no drive effort, gravity on, 1 s): peak-to-peak T + V over the peak kinetic energy.
FREE_ENERGY = Tolerance(
    1e-9, "DOP853's global error at rtol = atol = 1e-12 on a table interpolated to ~1e-12 (the linkages' "
    "FREE_ENERGY); measured 2.8e-11 (rscr, 1.8 turns), 6.8e-11 (rsrc, 3.6 turns), 2.7e-11 (7r, its range)")
#: Work-energy balance under a drive effort, damping and the given loads, over the largest energy or work.
WORK_ENERGY = Tolerance(
    1e-9, "the same integrator error (the works are integrated with the motion); measured 3.5e-12 (rscr), "
    "5.0e-12 (rsrc)")
#: The same mechanism simulated by two constructions, relative to each quantity's peak over the motion.
SAME_MOTION = Tolerance(
    1e-11, "two coefficient tables of the same dynamics, each interpolated to ~1e-13, integrated at "
    "rtol = 1e-12 along the same path; measured <= 6.4e-13 (RSSR), 8.7e-14 (RCCC), 8.8e-14 (slider crank)")
#: The simulated drive effort against the Pinocchio judge's inverse dynamics at the simulated states,
#: relative to the peak effort.
JUDGE_EFFORT = Tolerance(
    1e-9, "the judge closes to its own tolerance (~1e-12 of the lengths) and solves the constrained inverse "
    "dynamics by least squares; the simulated acceleration is the ODE's own; measured 3.7e-13 (rscr), "
    "1.0e-12 (7r)")

#: The drive effort the in-house engine solves at a simulated state against the applied one less damping,
#: relative to its peak.
SPLINE_EFFORT = Tolerance(
    1e-9, "the simulated acceleration comes from the coefficients' degree-7 spline (off by ~1e-12 of each "
    "coefficient's peak), the table's effort from a direct solve; measured 1.9e-11 (rsrc)")


def _free(mechanism: LoopMechanism) -> LoopMechanism:
    """``mechanism`` with every load 0 and no drive effort: free motion under gravity."""
    loads = tuple(replace(load, value=0.0) for load in mechanism.loads)
    return replace(mechanism, drive=replace(mechanism.drive, effort=None), loads=loads)


@pytest.mark.parametrize("name", TURNING)
def test_free_motion_keeps_its_energy(name: str) -> None:
    sim = fd.simulate(_free(linkage_case(name)), 1.0, torque=0.0, samples=201)
    total = sim.kinetic + sim.potential
    assert np.ptp(total) / np.abs(sim.kinetic).max() < FREE_ENERGY.value
    assert_allclose(sim.work_drive, 0.0, atol=0.0)
    assert_allclose(sim.work_loads, 0.0, atol=0.0)


@pytest.mark.parametrize("name", TURNING)
def test_work_energy_balance_under_loads(name: str) -> None:
    sim = fd.simulate(linkage_case(name), 0.5, torque="0.3*sin(5*t) - 0.01*psidot", damping=0.002,
                      samples=201)
    scale = max(np.abs(sim.kinetic).max(), np.abs(sim.work_drive).max(), np.abs(sim.work_loads).max())
    assert np.abs(sim.energy_residual()).max() / scale < WORK_ENERGY.value
    assert np.abs(sim.work_loads).max() > 0.0 and np.abs(sim.dissipated).max() > 0.0
    assert (sim.table.status == "ok").all()


def _relative(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a - b).max() / np.abs(a).max())


@pytest.mark.parametrize("kind", ["rssr", "rccc"])
def test_linkage_presets_move_as_their_own_forward_dynamics(kind: str) -> None:
    """The RSSR (RCCC) case by its own forward dynamics and as its loop table, started on the case's branch
    (:func:`~dualmech.models.loop.presets.loop_table_of`): the same motion."""
    case = linkage_case(kind)
    own = preset_dynamics.simulate(case, 0.5, torque="0.5*sin(t)", damping=0.01, samples=101)
    loop = fd.simulate(loop_table_of(case), 0.5, torque="0.5*sin(t)", damping=0.01, samples=101)
    for name in ("psi", "psi_dot", "psi_ddot", "kinetic", "potential", "work_drive", "dissipated"):
        assert _relative(getattr(own, name), getattr(loop, name)) < SAME_MOTION.value, name
    assert _relative(own.work_output, loop.work_loads) < SAME_MOTION.value


def test_cylindrical_crank_moves_as_the_slider_cranks_forward_dynamics() -> None:
    """A C joint driven by its angle under the axial law (a workless cam): the slider crank's own forward
    dynamics (generalized inertia, Sinatra-Angeles) and its loop table give the same motion."""
    case = load_case("thesis/a4-30-s1-3.5").with_values(
        {"motion.axial_amplitude": 2.0, "motion.axial_cycles": 2.0, "loads.gravity": [0.0, -386.4, 0.0]})
    start = slider_crank_start(case, analyze(case).s4[0])
    own = slider_crank_fd.simulate(case, 0.5, torque="100*sin(3*t)", damping=0.5, samples=101)
    loop = fd.simulate(slider_crank_table(case), 0.5, torque="100*sin(3*t)", damping=0.5, samples=101,
                       start=start)
    for name in ("psi", "psi_dot", "psi_ddot", "kinetic", "potential", "work_drive", "dissipated"):
        assert _relative(getattr(own, name), getattr(loop, name)) < SAME_MOTION.value, name


def test_drive_effort_agrees_with_the_pinocchio_judge_at_the_simulated_states() -> None:
    """Each of a few simulated states re-solved by the Pinocchio judge (its own model, closure and inverse
    dynamics): the drive effort it needs is the applied one less the bearing's damping."""
    mechanism = linkage_case("rscr")
    damping = 0.002
    sim = fd.simulate(mechanism, 0.1, torque="0.3*sin(5*t)", damping=damping, samples=5)
    start = float(mechanism.drive.positions[0])
    peak = float(np.abs(sim.effort).max())
    for k in range(sim.t.shape[0]):
        target = start + np.angle(np.exp(1j * (sim.psi[k] - start)))  # the nearest turn
        path = np.linspace(start, target, 2 + int(np.degrees(abs(target - start))))
        drive = Drive(0, "theta", path, float(sim.psi_dot[k]), float(sim.psi_ddot[k]))
        judged = pinocchio_solve(replace(fd.free_mechanism(mechanism), drive=drive))
        assert judged.status[-1] == "ok"
        expected = sim.effort[k] - damping * sim.psi_dot[k]
        assert_allclose(judged.efforts["theta1"][-1], expected, rtol=0.0, atol=JUDGE_EFFORT.value * peak)


def test_trajectory_table_is_the_in_house_solve_at_each_state() -> None:
    """The table at each sample is the in-house engine's at that state: the key is the unwrapped drive
    angle, the rates the simulated ones, the drive effort the applied one less damping."""
    mechanism = linkage_case("rsrc")
    sim = fd.simulate(mechanism, 0.3, torque=2.0, damping=0.01, samples=31)
    cols = sim.table.columns
    assert_allclose(cols["theta1_deg"], np.degrees(sim.psi), rtol=0.0, atol=0.0)
    assert_allclose(cols["theta1_dot"], sim.psi_dot, rtol=0.0, atol=0.0)
    peak = float(np.abs(cols["effort_theta1"]).max())
    assert_allclose(cols["effort_theta1"], 2.0 - 0.01 * sim.psi_dot, rtol=0.0,
                    atol=SPLINE_EFFORT.value * peak)
    assert list(sim.columns())[:2] == ["t", "theta1_deg"]


def test_a_drive_that_does_not_turn_fully_moves_in_its_range() -> None:
    """The 7R does not turn fully (a gap past 249.5 deg): its table spans its drive positions, 0-240 deg,
    refined where the pose turns sharply; free motion keeps its energy, the Pinocchio judge needs the
    simulated drive effort, and leaving the range is one line."""
    mechanism = linkage_case("7r")
    c = fd.coefficients(mechanism)
    assert not c.periodic
    assert_allclose(c.theta[[0, -1]], mechanism.drive.positions[[0, -1]], rtol=0.0, atol=0.0)
    assert fd.interpolation_error(c) <= fd.INTERPOLATION_TARGET
    free = fd.simulate(_free(mechanism), 0.5, torque=0.0, psi0=np.radians(100.0), psidot0=3.0, samples=101)
    assert np.ptp(free.kinetic + free.potential) / np.abs(free.kinetic).max() < FREE_ENERGY.value
    sim = fd.simulate(mechanism, 0.5, torque="1.5*sin(4*t)", damping=0.05, psi0=np.radians(100.0),
                      psidot0=3.0, samples=5, coeffs=c)
    peak = float(np.abs(sim.effort).max())
    for k in range(sim.t.shape[0]):
        path = np.linspace(0.0, sim.psi[k], 2 + int(np.degrees(abs(sim.psi[k]))))
        drive = Drive(0, "theta", path, float(sim.psi_dot[k]), float(sim.psi_ddot[k]))
        judged = pinocchio_solve(replace(fd.free_mechanism(mechanism), drive=drive))
        assert judged.status[-1] == "ok"
        assert_allclose(judged.efforts["theta1"][-1], sim.effort[k] - 0.05 * sim.psi_dot[k], rtol=0.0,
                        atol=JUDGE_EFFORT.value * peak)
    with pytest.raises(ValueError, match=r"^simulate: the drive reached -.* deg, outside 0..240 deg, "):
        fd.simulate(mechanism, 3.0, torque=0.0, coeffs=c)


def test_a_drive_past_its_gap_is_refused() -> None:
    mechanism = linkage_case("7r")
    past = replace(mechanism, drive=replace(mechanism.drive, positions=np.radians([0.0, 300.0])))
    with pytest.raises(ValueError, match=r"^simulate: '7r' neither turns fully \(statuses .*\) nor assembles "
                                         r"over its drive positions 0..300 deg .*needs one of them$"):
        fd.coefficients(past)


def test_a_drive_by_a_slide_is_refused() -> None:
    joints = (Joint("P", a=0.1), Joint("R", a=0.3), Joint("R", a=0.2), Joint("R", alpha=np.pi / 2))
    rscr = linkage_case("rscr")
    mechanism = LoopMechanism("slid", joints, Drive(0, "s", np.array([0.1, 0.2]), 1.0), rscr.bodies)
    with pytest.raises(ValueError, match=r"^simulate: 'slid' is driven at joint\[1\]'s slide \(P\); .*R or C "
                                         r"joint$"):
        fd.simulate(mechanism, 0.1)


def test_an_axial_law_that_does_not_repeat_each_turn_is_refused() -> None:
    mechanism = slider_crank_table(load_case("thesis/a4-30-s1-3.5").with_values(
        {"motion.axial_amplitude": 1.0, "motion.axial_cycles": 1.5}))
    with pytest.raises(ValueError, match=r"drive.axial_cycles = 1.5 does not repeat"):
        fd.simulate(mechanism, 0.1)
