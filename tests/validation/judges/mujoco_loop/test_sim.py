"""MuJoCo's simulation of a loop table against the rigid generated judge on the same table.

Both judges start from the joints' ``start`` values written into the table (rounded, as a user writes them:
:func:`tests.validation.judges.mujoco_loop.test_mujoco_loop.with_start`).  At the rows both call ``ok`` every
column is compared with the rigid judge's (``docs/conventions.md``, "Loop tables: the simulated loop judge"):
coordinates within :data:`~dualmech.validation.tolerances.LOOP_SIM_POSITIONS` (angles in rad, slides over the
table's length); rates within :data:`~dualmech.validation.tolerances.SIM_VELOCITY` times the semi-implicit
Euler lag ``dt/2`` times the peak acceleration; accelerations, efforts and joint wrenches within
:data:`~dualmech.validation.tolerances.LOOP_SIM_DYNAMICS` of their unit group's peak (accelerations with
slides over the length; forces; moments).
"""

from __future__ import annotations

import dataclasses
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from dualmech.core.continuation import search_assembly
from dualmech.models.loop.description import Load, LoopMechanism
from dualmech.models.loop.translate import drive_state, to_loop
from dualmech.validation.judges.mujoco_loop import solve_loop
from dualmech.validation.judges.mujoco_loop.engine import LoopTable
from dualmech.validation.judges.mujoco_loop.sim_mjcf import HALF_BODY, loop_sim_mjcf
from dualmech.validation.judges.mujoco_loop.sim_plan import plan, survey
from dualmech.validation.judges.mujoco_loop.simulation import solve_loop_sim
from dualmech.validation.tolerances import (
    LOOP_SIM_DYNAMICS,
    LOOP_SIM_POSITIONS,
    MATRIX_SIM_KINEMATICS,
    SIM_VELOCITY,
)
from tests.models.loop.test_random_tables import random_table
from tests.validation.judges.mujoco_loop.test_mujoco_loop import _preset, _size, with_start


def _kind(name: str) -> tuple[str, float | None]:
    """``(group, unit)`` of a column: coordinates, rates and accelerations (``unit`` 1 for an angle, None for
    a slide: over the table's length), forces and moments."""
    if name.startswith("joint"):
        return ("force" if name[-2] == "f" else "moment"), 1.0
    if name.startswith("effort_"):
        return ("force" if name[len("effort_")] == "s" else "moment"), 1.0
    base, _, order = name.partition("_")
    return order or "position", (None if base.startswith("s") else 1.0)


def ratios(sim: LoopTable, rigid: LoopTable, size: float) -> dict[str, float]:
    """Each column's largest difference over its bound (module docstring), on the rows both call ok."""
    ok = (sim.status == "ok") & (rigid.status == "ok")
    assert ok.any()
    scaled = {}
    for name in rigid.columns:
        group, unit = _kind(name)
        unit = size if unit is None else unit
        scaled[name] = (group, sim.columns[name][ok] / unit, rigid.columns[name][ok] / unit)
    peaks: dict[str, float] = {}
    for group, _, ref in scaled.values():
        peaks[group] = max(peaks.get(group, 0.0), float(np.abs(ref).max()))
    out = {}
    for name, (group, mine, ref) in scaled.items():
        diff = np.abs(mine - ref)
        if group == "position":
            diff = np.abs(np.angle(np.exp(1j * (mine - ref)))) if _kind(name)[1] == 1.0 else diff
            bound = LOOP_SIM_POSITIONS.value
        elif group == "dot":
            bound = SIM_VELOCITY.value * 0.5 * sim.meta["timestep"] * peaks["ddot"]
        else:
            bound = LOOP_SIM_DYNAMICS.value * peaks[group]
        out[name] = float(diff.max()) / bound
    return out


def assert_agrees(sim: LoopTable, rigid: LoopTable, size: float) -> None:
    """Statuses equal but where the simulation's wider dead-centre band flags a row the rigid judge calls
    ok (at most 1 % of the rows); every column within its bound."""
    differ = sim.status != rigid.status
    assert ((sim.status[differ] == "dead_centre") & (rigid.status[differ] == "ok")).all()
    assert differ.sum() <= 0.01 * differ.size
    worst = max(ratios(sim, rigid, size).items(), key=lambda item: item[1])
    assert worst[1] <= 1.0, f"{worst[0]}: {worst[1]:.3g} of its bound"


PRESETS = ("thesis/ideal", "thesis/a4-30-s1-3.5", "iftomm/spatial-slider-crank", "rssr", "rssr-torque",
           "rccc")


def _table(name: str) -> LoopMechanism:
    mech, start = _preset(name)
    return with_start(mech, start)


@pytest.mark.parametrize("name", PRESETS)
def test_presets_agree_with_the_rigid_judge(name: str) -> None:
    mech = _table(name)
    sim = solve_loop_sim(mech)
    assert_agrees(sim, solve_loop(mech), _size(mech))
    assert sim.meta["timestep"] > 0 and sim.meta["runin_steps"] >= 128 and sim.meta["max_lag"] < 1e-5


@pytest.mark.parametrize("seed", [1, 2])
def test_the_run_in_outlasts_the_weld(seed: int) -> None:
    """Random RSUR tables (a U joint: weld damping ratio 4, whose slow pole lasts ~63 steps): a run-in of
    12 servo time constants alone (128 steps here) left the U joint's accelerations 2.0 to 2.5 times
    their bound, whatever the step; the run-in also spans 12 of the weld's slow time constants."""
    mech = random_table(seed, "RSUR")
    found = search_assembly(to_loop(mech), drive_state(mech).take(slice(0, 1)).values, seed)
    table = with_start(mech, found.take(slice(0, 1)))
    assert_agrees(solve_loop_sim(table), solve_loop(table), _size(table))


def _faulty(mech: LoopMechanism, edit) -> LoopTable:
    """The simulation of ``mech`` with its MJCF edited in place by ``edit(root)`` (same settings)."""
    settings, _, _ = plan(mech, survey(mech))
    root = ET.fromstring(loop_sim_mjcf(mech, settings))
    edit(root)
    return solve_loop_sim(mech, xml=ET.tostring(root, encoding="unicode"))


def _flip_load(root: ET.Element) -> None:
    next(m for m in root.iter("motor")).set("gear", "-1")


def _swap_inertia(root: ET.Element) -> None:
    inertial = next(b for b in root.iter("body") if b.get("name") == "link3").find("inertial")
    i = inertial.get("fullinertia").split()
    i[0], i[2] = i[2], i[0]
    inertial.set("fullinertia", " ".join(i))


@pytest.mark.parametrize(("name", "edit"), [("rssr", _flip_load), ("rccc", _swap_inertia)])
def test_a_fault_is_caught(name: str, edit) -> None:
    """The comparison is not vacuous: the output torque applied with the wrong sign (RSSR), or the output
    link's inertia axes x and z swapped (RCCC), leaves the simulation far outside its bounds."""
    mech = _table(name)
    assert max(ratios(_faulty(mech, edit), solve_loop(mech), _size(mech)).values()) > 10.0


def test_a_spherical_cut_joint() -> None:
    """The RSSR's table turned to end at a ball (R R S S: the output link is the ground, the crank joint 2
    driven, 5-degree rows at constant speed; no start values: the rigid judge searches): the ground half
    turns on a ball, and agrees."""
    mech, _ = _preset("rssr")
    j, b = mech.joints, mech.bodies
    rows = np.radians(np.arange(0.0, 360.0, 5.0))
    drive = dataclasses.replace(mech.drive, joint=1, positions=rows, accel=0.0)
    turned = LoopMechanism("ball-last", (j[3], j[0], j[1], j[2]), drive, (b[2], b[0], b[1]),
                           (Load(0, "theta", 1.5),), mech.gravity)
    assert_agrees(solve_loop_sim(turned), solve_loop(turned), _size(turned))


def _heavy_half(root: ET.Element) -> None:
    inertial = next(b for b in root.iter("body") if b.get("name") == HALF_BODY).find("inertial")
    inertial.set("mass", repr(10.0 * float(inertial.get("mass"))))


def test_the_ground_half_is_not_weighed() -> None:
    """The ground half's mass and weight go into the weld alone (``sim_mjcf``'s docstring): ten times as
    heavy, under gravity, the RSSR still agrees."""
    mech = _table("rssr")
    assert np.linalg.norm(mech.gravity) > 0
    assert_agrees(_faulty(mech, _heavy_half), solve_loop(mech), _size(mech))


def test_the_cut_joint_cannot_be_driven() -> None:
    mech = _table("rssr")
    driven = dataclasses.replace(mech, drive=dataclasses.replace(mech.drive, joint=3),
                                 loads=(Load(0, "theta", 1.0),))
    with pytest.raises(ValueError, match=r"^drive.joint: .*got 4 \(the cut's joint"):
        solve_loop_sim(driven)
    with pytest.raises(ValueError, match="steps_per_degree: expected a positive integer, got 0"):
        solve_loop_sim(mech, steps_per_degree=0)


def test_an_accelerating_drive_keeps_its_rates_within_the_gate() -> None:
    """A slow drive under a large acceleration (``|accel| (1 deg) / speed^2`` = 0.3): the rate error grows as
    ``|accel| dt / |speed|``, so the step follows the acceleration too
    (:data:`~dualmech.models.mjcf_settings.ACCEL_SPEED_FRACTION`).  Every rate within the gate's
    :data:`~dualmech.validation.tolerances.MATRIX_SIM_KINEMATICS` of its peak.  Seen failing before, at a
    step from the speed alone: the drive's rate erred by 1.23 times that (and a random RSSR of the linkage
    tests, seed 18, by 1.08 in its output rate; 0.06 since)."""
    mech = _table("rssr")
    speed = -1.5
    accel = 0.3 * speed**2 / np.radians(1.0)
    mech = dataclasses.replace(mech, drive=dataclasses.replace(mech.drive, speed=speed, accel=accel))
    sim, rigid = solve_loop_sim(mech), solve_loop(mech)
    ok = (sim.status == "ok") & (rigid.status == "ok")
    assert ok.sum() >= 0.9 * ok.size
    for name in (c for c in rigid.columns if c.endswith("_dot")):
        peak = np.abs(rigid.columns[name][ok]).max()
        worst = np.abs(sim.columns[name][ok] - rigid.columns[name][ok]).max()
        assert worst <= MATRIX_SIM_KINEMATICS.value * peak, f"{name}: {worst / peak:.3g} of its peak"


def test_the_step_is_one_degree_of_the_fastest_joint() -> None:
    """The bundled general 7R turns its joints up to 2.5 times as fast as its drive on its sharp turns: the
    survey's ``fastest`` is the largest of the rigid judge's joint rates over the drive's (every joint an R:
    rad per rad), and the step is the drive's degree over it.  Seen failing before: at the drive's degree the
    simulation's rates erred by 1.15e-3 of the rates' peak (``theta6_dot``), over the gate's
    :data:`~dualmech.validation.tolerances.MATRIX_SIM_KINEMATICS`; at the fastest joint's, by 3.9e-4."""
    from dualmech.models.catalogue import load_mechanism
    from dualmech.validation.judges.mujoco_loop.sim_plan import timestep

    mech = load_mechanism("7r")
    sv, rigid = survey(mech), solve_loop(mech)
    ok = rigid.status == "ok"
    rates = np.array([rigid.columns[c][ok] for c in rigid.columns if c.endswith("_dot")])
    np.testing.assert_allclose(sv.fastest, np.abs(rates).max() / abs(mech.drive.speed), rtol=1e-9, atol=0)
    assert sv.fastest > 2.0
    settings, _, _ = plan(mech, sv)
    step = timestep(mech) / sv.fastest  # the rows' grid may shorten it a little (sim_plan.schedule)
    assert 0.9 * step <= settings.timestep <= step * (1.0 + 1e-12), (settings.timestep, step)
    sim = solve_loop_sim(mech)
    both = ok & (sim.status == "ok")
    names = [c for c in rigid.columns if c.endswith("_dot")]
    peak = max(np.abs(rigid.columns[name][both]).max() for name in names)  # the gate's: the unit group's
    for name in names:
        worst = np.abs(sim.columns[name][both] - rigid.columns[name][both]).max()
        assert worst <= MATRIX_SIM_KINEMATICS.value * peak, f"{name}: {worst / peak:.3g} of the rates' peak"
