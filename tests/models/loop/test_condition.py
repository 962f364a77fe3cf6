"""The closure condition of a loop table's pose (``models/loop/condition.py``) and its assembly-limit rule.

Oracles: the in-house engine's own chain (``core/loop.py``: its elementary screws and joint points, a forward
kinematics apart from the condition's), the slider crank's closed form (its edge of assembly, where the rod is
normal to the slider line, thesis eq. 3.12's square root vanishing), and the invariance of a scale-free
measure to the unit of length.
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
from dualmech.core.thresholds import LOOP_LIMIT_CONDITION
from dualmech.models.linkages import linkage_case, read_linkage
from dualmech.models.loop.columns import limit_words
from dualmech.models.loop.condition import closure_condition
from dualmech.models.loop.engine import analyze_loop
from dualmech.models.loop.presets import loop_table_of, slider_crank_start, slider_crank_table, started
from dualmech.models.loop.table import analysis_columns, solve_loop_table
from tests.models.loop.test_random_tables import TOPOLOGIES, first_assembly, random_table
from tests.oracles import exact_slider_motion
from tests.validation.test_engine_statuses import A1, A2, _case

PRESETS = ("rscr", "rsrc", "7r", "rssr", "rccc")


def _slider_crank(a4: float, angles: dict, universal: bool = False):
    """The slider crank's table (planar: twist 270 deg, S1 = 0) started at its closed-form pose."""
    case = _case(a4, angles)
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


def test_rows_below_the_band_are_assembly_limits_of_every_word_that_gives_rates() -> None:
    """``ok`` and ``dead_centre`` rows below the band become ``assembly_limit``; other words stay; a
    mechanism with its own rule (``limits`` false) keeps its words but still gives its condition."""
    _, mechanism = _slider_crank(A2 - A1 - 1e-6 * A2, {"start": -2.0, "stop": 2.1, "step": 1.0})
    table = solve_loop_table(mechanism)
    cols = {c: table[c] for c in table.columns}
    words = np.array(["ok", "dead_centre", "ok", "branch_jump", "ok"], dtype=object)
    condition, status = limit_words(mechanism, cols, words)
    assert condition[2] < LOOP_LIMIT_CONDITION.value < condition[[0, 1, 4]].min()
    assert list(status) == ["ok", "dead_centre", "assembly_limit", "branch_jump", "ok"]
    below = np.full(5, Status.DEAD_CENTRE.value, dtype=object)
    assert limit_words(mechanism, cols, below)[1][2] == Status.ASSEMBLY_LIMIT
    own_condition, own = limit_words(replace(mechanism, limits=False), cols, words)
    assert list(own) == list(words)
    assert_allclose(own_condition[[0, 1, 2, 4]], condition[[0, 1, 2, 4]], rtol=0, atol=0)


def test_the_in_house_table_flags_the_limit_and_gives_no_rates_there() -> None:
    """1e-6 a2 inside the edge: the row at theta1 = 0 is ``assembly_limit`` with its pose and condition and
    no rates or reactions; its neighbours are ``ok``."""
    _, mechanism = _slider_crank(A2 - A1 - 1e-6 * A2, {"start": -2.0, "stop": 2.1, "step": 1.0})
    table = solve_loop_table(mechanism)
    assert list(table.status) == ["ok", "ok", "assembly_limit", "ok", "ok"]
    assert np.isfinite(table["s4"]).all() and table["closure_condition"][2] < LOOP_LIMIT_CONDITION.value
    assert np.isnan(table["s4_dot"][2]) and np.isnan(table["effort_theta1"][2])
    assert np.isfinite(table["s4_dot"][[0, 1, 3, 4]]).all()
