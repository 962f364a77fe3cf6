"""Near a universal joint's lock (issue 30, defect 3): the simulation judge's tolerance follows the measured
conditioning, within a bounded neighbourhood, says so, and still fails a wrong engine there.

The reproduction: a design whose rod passes 0.66 deg from the slider axis (just outside the 0.57 deg
``joint_lock`` band) with a universal joint at the slider.  Before the law, 7 of its mujoco-sim checks
failed at 0.2-0.87 % against 0.1 % at theta1 = 179-183 deg, and no check said why.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import replace

import numpy as np
import pytest
from numpy.testing import assert_allclose

from dualmech.models.case import case_from_dict
from dualmech.models.slider_crank.analysis import solve_case
from dualmech.validation.compare import NEAR_JOINT_LOCK, compare_case, lock_factor, lock_rate
from dualmech.validation.matrix import parse
from dualmech.validation.tolerances import (
    JOINT_LOCK_NEIGHBOURHOOD,
    SIM_JOINT_LOCK_CAP,
)

pytest.importorskip("mujoco")

#: Angle of the rod to the slider axis at its closest (deg): 0.66, 0.09 deg outside the lock band.
CLOSEST_DEG = 0.66
#: The sweep's central difference of psi against kappa: step 1e-3 deg, error ~ h^2 psi''' ~ 1e-6 of kappa;
#: atan2 rounding ~ eps / h ~ 1e-11.
KAPPA_VS_DIFFERENCE = 1e-5


#: The reproduction as a case file: the thesis's bodies and speed, alpha4 = 220 deg, S1 = 0, a4 = a1 + a2
#: sin(0.66 deg): the crank pin passes the slider line at theta1 = 180 deg, the rod 0.66 deg from the slider
#: axis.
NEAR_LOCK_TOML = """
name = "near-joint-lock"
units = "inch-lbf-s"
[joints]
rod_slider = "{rod_slider}"
[geometry]
crank_length = 12.0
rod_length = 50.0
slider_offset = {offset!r}
slider_twist_deg = 220.0
crank_axial_shift = 0.0
[motion]
crank_rpm = 50.0
angles_deg = {{ start = {start!r}, stop = {stop!r}, step = {step!r} }}
[bodies]
crank_radius = 1.5
rod_radius = 1.0
slider_side = 3.0
weight_density = 0.28
gravity_constant = 386.4
[loads]
drive_torque = 100.0
gravity = [0.0, 0.0, 0.0]
"""


def near_lock_text(start: float = 150.0, stop: float = 210.0, step: float = 1.0,
                   rod_slider: str = "universal") -> str:
    """:data:`NEAR_LOCK_TOML` at crank angles ``start .. stop`` (exclusive) by ``step`` (deg)."""
    offset = 12.0 + 50.0 * math.sin(math.radians(CLOSEST_DEG))
    return NEAR_LOCK_TOML.format(rod_slider=rod_slider, offset=offset, start=start, stop=stop, step=step)


def near_lock_case(start: float = 150.0, stop: float = 210.0, step: float = 1.0,
                   rod_slider: str = "universal"):
    """The case of :func:`near_lock_text`."""
    return case_from_dict(tomllib.loads(near_lock_text(start, stop, step, rod_slider)))


@pytest.fixture(scope="module")
def judged():
    """The case, the in-house table, the simulation judge's table and the design matrix's tolerances."""
    from dualmech.validation.judges.mujoco_slider_crank.sim import solve_case as simulate

    case = near_lock_case()
    tolerances = parse.design_matrix("thesis/a4-30-s1-3.5").tolerances
    return case, solve_case(case), simulate(case), tolerances


def _checks(judged, tolerances: dict, judge=None):
    case, ref, sim, _ = judged
    quantities = tuple(q for q in tolerances if q in ref.columns)
    return compare_case("near-lock", "torque", ref, sim if judge is None else judge, quantities, tolerances,
                        lock=lock_rate(case, ref))


def test_the_near_lock_design_passes_and_every_widened_check_says_why(judged) -> None:
    _, ref, _, tolerances = judged
    sine = np.sqrt(1.0 - ref["closure_condition"] ** 2)
    assert_allclose(np.degrees(np.arcsin(sine.min())), CLOSEST_DEG, rtol=1e-9, atol=0)
    assert (ref.status == "ok").all()  # outside the lock band: every row is judged
    sim_tolerances = tolerances["mujoco-sim"]
    unwidened = {**sim_tolerances, "joint_lock_cap": replace(sim_tolerances["joint_lock_cap"], value=1.0)}
    before = [c for c in _checks(judged, unwidened) if not c.passed]
    assert len(before) >= 5 and all(175 <= c.worst_theta_deg <= 185 for c in before)
    after = _checks(judged, tolerances["mujoco-sim"])
    assert all(c.passed for c in after), [c.detail for c in after if not c.passed]
    widened = [c for c in after if c.near_joint_lock]
    assert {c.quantity for c in before} <= {c.quantity for c in widened}
    assert all(NEAR_JOINT_LOCK in c.detail and "joint_lock_cap" in c.detail for c in widened)
    assert not any(c.near_joint_lock for c in after if c.quantity in ("S1", "S4", "status", "stroke"))


def test_a_wrong_engine_still_fails_near_the_lock(judged) -> None:
    """The simulation's table with a ball joint's reactions (the universal joint's moment lost, as defect 2)
    on the widened rows only: the widening must not excuse it there."""
    case, ref, sim, tolerances = judged
    factor = lock_factor(lock_rate(case, ref), ref["closure_condition"], SIM_JOINT_LOCK_CAP.value)
    near = factor > 1
    assert 0 < near.sum() < len(ref)
    ball = solve_case(near_lock_case(rod_slider="ball"))
    columns = {c: (np.where(near, ball[c], sim[c]) if c.startswith(("j", "drive", "slider_load")) else sim[c])
               for c in sim.columns}
    wrong = replace(sim, columns=columns)
    failed = [c for c in _checks(judged, tolerances["mujoco-sim"], wrong) if not c.passed]
    assert failed and all(c.near_joint_lock for c in failed)
    assert all(near[np.flatnonzero(ref["theta1_deg"] == c.worst_theta_deg)[0]] for c in failed)


def test_the_widening_is_bounded_to_the_neighbourhood_and_the_cap() -> None:
    case = near_lock_case(start=0.0, stop=360.0, step=0.5)
    ref = solve_case(case)
    rate = lock_rate(case, ref)
    condition = ref["closure_condition"]
    factor = lock_factor(rate, condition, SIM_JOINT_LOCK_CAP.value)
    sine = np.sqrt(1.0 - condition**2)
    assert (factor[sine >= JOINT_LOCK_NEIGHBOURHOOD.value] == 1.0).all()
    assert factor.max() == SIM_JOINT_LOCK_CAP.value and (factor >= 1.0).all()
    assert (lock_factor(rate, condition, 1.0) == 1.0).all()  # the rigid judges' cap: no widening
    widened = ref["theta1_deg"][factor > 1]
    assert widened.min() > 170 and widened.max() < 190
    ball = near_lock_case(rod_slider="ball")
    assert (lock_rate(ball, solve_case(ball)) == 0.0).all()


def test_kappa_is_the_turning_rate_of_the_joint_cross() -> None:
    """kappa against a central difference of the cross's angle psi about k4 (the rod's projection on the
    plane normal to k4), from the in-house poses 1e-3 deg apart."""
    h = 1e-3
    centres = np.array([150.0, 176.0, 179.0, 180.5, 183.0, 200.0])
    case = near_lock_case()
    k4 = case.geometry.k4
    e1 = np.cross(k4, [1.0, 0.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(k4, e1)

    def psi(angles: np.ndarray) -> np.ndarray:
        one = case.with_parts(motion=replace(case.motion, angles_deg=angles))
        t = solve_case(one)
        th = np.radians(angles)
        p2 = np.stack([12.0 * np.cos(th), 12.0 * np.sin(th), t["S1"]], -1)
        u = case.geometry.foot - t["S4"][:, None] * k4 - p2
        return np.arctan2(u @ e2, u @ e1)

    dpsi = np.unwrap(psi(centres + h) - psi(centres - h), period=2 * np.pi) / np.radians(2 * h)
    one = case.with_parts(motion=replace(case.motion, angles_deg=centres))
    assert_allclose(lock_rate(one, solve_case(one)), np.abs(dpsi), rtol=KAPPA_VS_DIFFERENCE, atol=0)


def test_validate_names_the_lock_in_its_summary_and_report(tmp_path) -> None:
    """``dualmech validate`` of the reproduction (a whole revolution, the users' 1 deg step): PASS, and the
    summary and both reports say "near joint lock" for the widened checks (before: FAIL, 7 checks, no
    reason)."""
    from click.testing import CliRunner

    from dualmech.cli import main

    path = tmp_path / "near-lock.toml"
    path.write_text(near_lock_text(start=0.0, stop=360.0))
    out = tmp_path / "run"
    result = CliRunner().invoke(main, ["validate", str(path), "-o", str(out), "--jobs", "1",
                                       "--engines", "dualmech,mujoco-sim"])
    assert result.exit_code == 0, result.output
    assert "PASS" in result.output and f"{NEAR_JOINT_LOCK}: " in result.output
    for report in ("report.md", "report.html"):
        text = (out / report).read_text()
        assert text.count("mujoco-sim") and "Near joint lock" in text and NEAR_JOINT_LOCK in text, report
