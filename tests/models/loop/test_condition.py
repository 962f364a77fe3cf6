"""The closure condition of a loop table's pose (``models/loop/condition.py``) and its assembly-limit rule.

Oracles: numpy's singular values (LAPACK) for the eigenvalue solver, the in-house engine's own chain
(``core/loop.py``: its elementary screws and joint points, a forward kinematics apart from the condition's),
the slider crank's closed form (its edge of assembly, where the rod is normal to the slider line, thesis
eq. 3.12's square root vanishing), and the invariance of a scale-free measure to the unit of length.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from dualmech.core.loop_reactions import joint_points
from dualmech.core.status import Status
from dualmech.core.thresholds import LOOP_LIMIT_CONDITION, LOOP_LOCK_CONDITION
from dualmech.models.linkages import linkage_case, read_linkage
from dualmech.models.loop.columns import limit_words, loop_spec
from dualmech.models.loop.condition import _condition_rows, closure_condition, drive_condition
from dualmech.models.loop.engine import analyze_loop
from dualmech.models.loop.presets import loop_table_of, slider_crank_start, slider_crank_table, started
from dualmech.models.loop.table import analysis_columns, solve_loop_table
from tests.models.loop.test_random_tables import TOPOLOGIES, first_assembly, random_table
from tests.oracles import exact_slider_motion
from tests.validation.test_engine_statuses import A1, A2, _case

PRESETS = ("rscr", "rsrc", "7r", "rssr", "rccc")


def _slider_crank(a4: float, angles: dict, universal: bool = False, twist: float = 270.0):
    """The slider crank's table (S1 = 0; planar at the default twist) started at its closed-form pose."""
    case = _case(a4, angles, twist=twist)
    if universal:
        case = case.with_values({"joints.rod_slider": "universal"})
    s4 = exact_slider_motion(case, np.radians(case.motion.angles_deg[:1]))[0]
    return case, started(slider_crank_table(case), slider_crank_start(case, float(s4[0]), 0))


def _chain_condition(mechanism, start=None) -> np.ndarray:
    """The condition from the in-house engine's chain: its unknowns' elementary screws (a turn's line
    ``(a, p x a)``, a slide's ``(0, a)``) and its joint points."""
    an = analyze_loop(mechanism, start)
    points = joint_points(an.chain, an.loop, an.drive.values)
    centre = points.mean(axis=1)
    size = np.sqrt(np.mean(np.sum((points - centre[:, None]) ** 2, axis=2), axis=1))[:, None]
    columns = []
    for screw in an.chain.screws:
        if screw.var[0] != "unknown":
            continue
        a, m = screw.line.re, screw.line.du
        slide = np.abs(a).max() == 0.0
        columns.append(np.concatenate([a, m if slide else (m - np.cross(centre, a)) / size], axis=1))
    sigma = np.linalg.svd(np.stack(columns, axis=2), compute_uv=False)
    return sigma[:, 5] / sigma[:, 0]


@pytest.mark.parametrize("name", PRESETS + ("slider-crank", "slider-crank-universal"))
def test_the_condition_of_a_pose_is_the_chains(name: str) -> None:
    """The pose's forward kinematics (walked from both ends to the balls) gives the chain's condition."""
    if name.startswith("slider-crank"):
        angles = {"start": 0.0, "stop": 360.0, "step": 30.0}
        mechanism = _slider_crank(30.0, angles, name == "slider-crank-universal")[1]
    else:
        mechanism = loop_table_of(linkage_case(read_linkage(name)))
    an = analyze_loop(mechanism)
    mine = closure_condition(mechanism, analysis_columns(an))
    assert np.isfinite(mine).all() and (mine > 0.0).all()
    assert_allclose(mine, _chain_condition(mechanism), rtol=0, atol=1e-12)


@settings(max_examples=20)
@given(seed=st.integers(0, 2**32 - 1), topology=st.sampled_from(TOPOLOGIES))
def test_the_condition_of_a_random_tables_pose_is_the_chains(seed: int, topology: str) -> None:
    """Any joint types in any order (U, P and C joints, balls at any place): the same as the chain's."""
    mechanism = random_table(seed, topology)
    found = first_assembly(mechanism, seed)
    assume(found is not None)
    an = analyze_loop(mechanism, found)
    ok = an.status == "ok"
    mine = closure_condition(mechanism, analysis_columns(an))
    assert_allclose(mine[ok], _chain_condition(mechanism, found)[ok], rtol=0, atol=1e-12)


def test_the_condition_does_not_depend_on_the_unit_of_length() -> None:
    """Every length times 1000 (and the start's slides): the same condition, to rounding."""
    mechanism = linkage_case(read_linkage("rscr"))
    k = 1000.0
    joints = tuple(replace(j, a=k * j.a, s=k * j.s, start=tuple(v * k if j.type == "C" and i == 1 else v
                                                                 for i, v in enumerate(j.start)))
                   for j in mechanism.joints)
    bodies = tuple(replace(b, com=k * b.com, inertia=k * k * b.inertia) for b in mechanism.bodies)
    scaled = replace(mechanism, joints=joints, bodies=bodies, gravity=k * mechanism.gravity)
    mine = solve_loop_table(mechanism)["closure_condition"]
    assert_allclose(solve_loop_table(scaled)["closure_condition"], mine, rtol=1e-12, atol=0)


def test_the_condition_vanishes_at_the_slider_cranks_edge_of_assembly() -> None:
    """At a4 = a2 - a1 the rod is normal to the slider line at theta1 = 0 (closed form: the rod's reach
    ``rho = a1 cos(theta) + a4`` equals a2 there): the condition is zero there to the closure's rounding,
    and grows like the closed form's ``sqrt(a2^2 - rho^2)`` (its ratio to it steady) away from it."""
    case, mechanism = _slider_crank(A2 - A1, {"start": 1.0, "stop": 10.0, "step": 1.0})
    pose = {"theta1": np.zeros(1), "s4": exact_slider_motion(case, np.zeros(1))[0]}
    assert closure_condition(mechanism, pose)[0] < 1e-7
    theta = np.radians(case.motion.angles_deg)
    rho = A1 * np.cos(theta) + (A2 - A1)
    exact = np.sqrt(A2**2 - rho**2) / A2
    table = solve_loop_table(mechanism)
    ratio = table["closure_condition"] / exact
    assert_allclose(ratio, ratio[0], rtol=0.05, atol=0)


#: ``a4`` of the slider crank whose edge of assembly is 1e-6 a2 beyond theta1 = -60 deg: the reach
#: ``rho = a1 cos(theta) + a4`` is ``a2 (1 - 1e-6)`` there and grows toward -55 deg (no assembly), with a
#: non-zero slope: a turning point of the drive.
TURNING_A4 = A2 * (1.0 - 1e-6) - A1 * np.cos(np.radians(60.0))
#: ``a4`` of the slider crank whose reach touches 1e-6 a2 short of a2 at theta1 = 0, where it is greatest
#: (zero slope): the drive moves on through the rod's normal pose, with bounded rates.
TOUCHING_A4 = A2 - A1 - 1e-6 * A2


def test_rows_below_the_band_are_assembly_limits_of_every_word_that_gives_rates() -> None:
    """``ok`` and ``dead_centre`` rows below the band become ``assembly_limit``; other words stay; a
    mechanism with its own rule (``limits`` false) keeps its words but still gives its condition."""
    _, mechanism = _slider_crank(TURNING_A4, {"start": -64.0, "stop": -59.5, "step": 1.0})
    table = solve_loop_table(mechanism)
    cols = {c: table[c] for c in table.columns}
    words = np.array(["ok", "dead_centre", "ok", "branch_jump", "ok"], dtype=object)
    condition, status = limit_words(mechanism, cols, words)
    assert condition[4] < LOOP_LIMIT_CONDITION.value < condition[:3].min()
    assert list(status) == ["ok", "dead_centre", "ok", "branch_jump", "assembly_limit"]
    below = np.full(5, Status.DEAD_CENTRE.value, dtype=object)
    assert limit_words(mechanism, cols, below)[1][4] == Status.ASSEMBLY_LIMIT
    own_condition, own = limit_words(replace(mechanism, limits=False), cols, words)
    assert list(own) == list(words)
    assert_allclose(own_condition[[0, 1, 2, 4]], condition[[0, 1, 2, 4]], rtol=0, atol=0)


def test_the_in_house_table_flags_the_limit_and_gives_no_rates_there() -> None:
    """1e-6 a2 inside a turning point of the drive: the row at theta1 = -60 deg is ``assembly_limit`` with
    its pose and condition and no rates or reactions; the rows before are ``ok``; past it the loop does not
    close."""
    _, mechanism = _slider_crank(TURNING_A4, {"start": -64.0, "stop": -54.5, "step": 1.0})
    table = solve_loop_table(mechanism)
    assert list(table.status) == ["ok"] * 4 + ["assembly_limit"] + ["no_assembly"] * 5
    assert np.isfinite(table["s4"][:5]).all() and table["closure_condition"][4] < LOOP_LIMIT_CONDITION.value
    assert np.isnan(table["s4_dot"][4]) and np.isnan(table["effort_theta1"][4])
    assert np.isfinite(table["s4_dot"][:4]).all()


def test_the_drive_condition_tells_a_lock_from_an_assembly_limit() -> None:
    """Oracle: the closed form's slider rate ``dS4/dtheta1``.  At a turning point of the drive it is
    unbounded (the drive's twist leaves the solved freedoms' span: ``c_d`` stays far above the band while
    ``c`` vanishes); where the reach touches its greatest value (zero slope) it stays bounded (the drive
    moves on: ``c_d`` vanishes with ``c``)."""
    for a4, angle, bounded in ((TURNING_A4, -60.0, False), (TOUCHING_A4, 0.0, True)):
        case, mechanism = _slider_crank(a4, {"start": angle, "stop": angle + 0.5, "step": 1.0})
        theta = np.radians([angle])
        s4, s4_dot, _ = exact_slider_motion(case, theta)
        pose = {"theta1": theta, "s4": s4}
        rate = abs(s4_dot[0] / case.motion.speed) / A2  # dS4/dtheta1 over a2
        c, c_d = closure_condition(mechanism, pose)[0], drive_condition(mechanism, pose)[0]
        assert c < LOOP_LIMIT_CONDITION.value
        if bounded:
            assert rate < 1.0 and c_d < LOOP_LOCK_CONDITION.value
        else:
            assert rate > 100.0 and c_d > 10 * LOOP_LOCK_CONDITION.value


def test_a_touching_edge_is_a_joint_lock_and_gives_no_value() -> None:
    """Where the drive moves on through the rod's normal pose (``TOUCHING_A4``), the row is ``joint_lock``:
    no pose, condition, rate or reaction (at a lock a coordinate is not determined, near it each carries the
    closure's rounding over ``c``); its neighbours are ``ok`` on the same branch (the closed form's S4)."""
    case, mechanism = _slider_crank(TOUCHING_A4, {"start": -2.0, "stop": 2.1, "step": 1.0})
    table = solve_loop_table(mechanism)
    assert list(table.status) == ["ok", "ok", "joint_lock", "ok", "ok"]
    spec = loop_spec(mechanism)
    assert all(np.isnan(table[c][2]) for c in spec.pose + spec.rates + spec.reactions)
    ok = np.array([0, 1, 3, 4])
    s4 = exact_slider_motion(case, np.radians(table["theta1_deg"]))[0]
    assert_allclose(table["s4"][ok], s4[ok], rtol=0, atol=1e-9 * A2)


@pytest.mark.parametrize("m", [6, 7, 8])
def test_the_eigenvalue_solver_gives_numpys_singular_value_ratio(m: int) -> None:
    """Random columns (seeded), some rows scaled by 1e3 or 1e-3, some with two columns nearly the same
    (c ~ 1e-9): the ratio of the extreme singular values.  The Gram matrix squares them: ``c^2`` is found
    to a few ulps of 1, so ``c`` to ``~eps / c^2`` relative (bound: 50 eps / c^2, 2e-10 at the band's 1e-3)
    and to ``~sqrt(eps)`` absolute near 0 (bound 5e-8, far below the band)."""
    rng = np.random.default_rng(m)
    jac = rng.normal(size=(3000, m, 6))
    jac[::3, 1] = jac[::3, 0] * (1.0 + 1e-9 * rng.normal(size=(1000, 6)))
    jac[1::5] *= 1e3
    jac[2::7] *= 1e-3
    sv = np.linalg.svd(jac, compute_uv=False)
    exact = sv[:, 5] / sv[:, 0]
    mine = _condition_rows(jac)
    assert_allclose(mine, exact, rtol=0, atol=5e-8)
    wide = exact > 1e-3
    assert wide.sum() > 1000
    bound = 50 * np.finfo(float).eps / exact[wide] ** 2 * exact[wide]
    assert (np.abs(mine[wide] - exact[wide]) <= bound).all()
