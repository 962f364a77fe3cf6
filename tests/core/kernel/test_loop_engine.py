"""The compiled loop engine against the numpy solver: the same statuses row by row, and every column within
KERNEL_VS_NUMPY_LOOP of its peak, on every preset of ``models/loop/presets.py`` and on random tables.

The joint reactions are one least-squares solution per position, whose rounding scales with its largest
unknown and with 1/|t| near a dead centre (t the transmission): each force or moment column is held to the
peak of all forces or moments of the case (the validation gate's unit groups), widened to
LOOP_REACTIONS_ROUNDING / |t| (as the loop engine's own tests); a kinematic column nil in theory (the ground
link's twist) to NIL_COLUMN of its array's peak.  Near an edge of assembly (closure condition c) positions,
rates and accelerations carry rounding times 1/c, 1/c^2, 1/c^3 (:func:`_edge_gains`)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st

from dualmech.core.continuation import closure_jacobian, search_assembly
from dualmech.core.kernel import loop_engine, pool
from dualmech.models.case import load_case, preset_names
from dualmech.models.linkages import read_linkage
from dualmech.models.linkages.rccc_case import rccc_from_dict
from dualmech.models.linkages.rssr_case import rssr_from_dict
from dualmech.models.loop.description import LoopMechanism
from dualmech.models.loop.engine import LoopAnalysis, analyze_loop
from dualmech.models.loop.presets import (
    rccc_start,
    rccc_table,
    rssr_start,
    rssr_table,
    slider_crank_start,
    slider_crank_table,
)
from dualmech.models.loop.translate import drive_state, to_loop
from dualmech.models.slider_crank.analysis import analyze
from tests.models.loop.test_engine import VARIANTS as ENGINE_VARIANTS
from tests.models.loop.test_engine import _case as engine_case
from tests.models.loop.test_random_tables import TOPOLOGIES, random_table
from tests.tolerances import (
    KERNEL_VS_NUMPY_LOOP,
    LOOP_CLOSURE,
    LOOP_EDGE_ROUNDING,
    LOOP_REACTIONS_ROUNDING,
    NIL_COLUMN,
)

#: Slider-crank variants beyond the presets: the loop engine's own (a revolute crank, a gap of 131 unassembled
#: positions, the slider load given instead of the drive torque) and a universal joint on a thesis case.
VARIANTS = [*ENGINE_VARIANTS, "universal"]


def _slider_crank(name: str) -> tuple[LoopMechanism, object]:
    if name == "universal":
        case = load_case("thesis/a4-20-s1-3.5").with_values({"joints.rod_slider": "universal"})
    else:
        case = engine_case(name)
    return slider_crank_table(case), slider_crank_start(case, analyze(case).s4[0])


def _linkage(name: str) -> tuple[LoopMechanism, object]:
    kind, mode, branch = name.split("-", 2)
    data = read_linkage(kind)
    data = {**data, "mechanism": {**data["mechanism"], "branch": int(branch)}}
    if mode == "torque":
        data = {**data, "loads": {**{k: v for k, v in data["loads"].items() if k != "output_torque"},
                                  "drive_torque": 3.0}}
    if kind == "rssr":
        case = rssr_from_dict(data)
        return rssr_table(case), rssr_start(case)
    case = rccc_from_dict(data)
    return rccc_table(case), rccc_start(case)


def _close(name: str, mine: np.ndarray, ref: np.ndarray, rows: np.ndarray, scale: float,
           gain: np.ndarray | float = 1.0) -> None:
    """``mine`` within KERNEL_VS_NUMPY_LOOP (times ``gain`` per row) of ``scale`` on ``rows``."""
    if rows.any():
        atol = KERNEL_VS_NUMPY_LOOP * scale * (gain[rows] if isinstance(gain, np.ndarray) else gain)
        assert (np.abs(mine[rows] - ref[rows]) <= atol).all(), \
            f"{name}: {np.abs(mine[rows] - ref[rows]).max():.3g} off, allowed {np.min(atol):.3g}"


def _columns(name: str, mine: np.ndarray, ref: np.ndarray, rows: np.ndarray,
             gain: np.ndarray | float = 1.0) -> None:
    """Every column of ``(n, ...)`` arrays against its own peak, at least NIL_COLUMN of the array's."""
    flat_mine, flat_ref = mine.reshape(mine.shape[0], -1), ref.reshape(ref.shape[0], -1)
    group = np.abs(flat_ref[rows]).max(initial=0.0)
    for c in range(flat_ref.shape[1]):
        peak = max(np.abs(flat_ref[rows, c]).max(initial=0.0), NIL_COLUMN * group)
        _close(f"{name}[{c}]", flat_mine[:, c], flat_ref[:, c], rows, peak, gain)


def _edge_gains(mine: LoopAnalysis, ref: LoopAnalysis) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per row, how much the closure's conditioning widens the tolerance of positions, rates and
    accelerations: the two engines' poses are apart by up to their two closure residuals, which reach them
    times 1/c, 1/c^2, 1/c^3 (c the smallest over the largest singular value of the closure Jacobian with
    its columns scaled to unit length: each unknown is compared to its own peak, so its unit must not count;
    unscaled, a slide's column over the length scale made c ~0.01 at every row of the slider crank's table);
    at least LOOP_EDGE_ROUNDING, as the loop engine's own tests.  (A random RRSRR, seed 34909, closes a row
    to 1.5e-13 in one engine and 8.2e-14 in the other, its floor of rounding: at c = 0.1 its rates are
    1.3e-12 of their peak apart.)"""
    jac = closure_jacobian(ref.loop, ref.drive.values, ref.state)
    sv = np.linalg.svd(jac / np.linalg.norm(jac, axis=-2, keepdims=True), compute_uv=False)
    c = sv[:, -1] / sv[:, 0]
    apart = np.maximum(LOOP_EDGE_ROUNDING, np.nan_to_num(mine.residual) + np.nan_to_num(ref.residual))
    return tuple(np.maximum(1.0, apart / KERNEL_VS_NUMPY_LOOP / c**k) for k in (1, 2, 3))


def _ball_rates(an: LoopAnalysis, q: np.ndarray) -> np.ndarray:
    """Rates ``(n, K)`` with each ball's in world axes (the axes of the frame before it carry a spun link's
    spin, see :func:`_link_axes`)."""
    out, k = q.copy(), len(an.loop.unknowns)
    for b, r in enumerate(an.loop.spherical_rows):
        axes = an.chain.frames[r - 1].re if r else np.eye(3)
        out[:, k + 3 * b:k + 3 * b + 3] = np.einsum("nij,nj->ni", axes, q[:, k + 3 * b:k + 3 * b + 3])
    return out


def _wound(mine: LoopAnalysis, ref: LoopAnalysis) -> np.ndarray:
    """``mine``'s scalar unknowns, each angle turned by the whole turns that bring it nearest ``ref``'s: a
    Newton step from a start near a singular pose may wind an angle by turns, differently in each engine
    (measured: 20 turns of eta3 at the first position of the universal variant), the pose is the same."""
    angles = np.array([not name.startswith("s") for name in ref.loop.unknowns], dtype=bool)
    turns = np.round((mine.state.scalars - ref.state.scalars) / (2 * np.pi)) * angles
    return mine.state.scalars - 2 * np.pi * turns


def _link_axes(an: LoopAnalysis) -> np.ndarray:
    """The frames' rotations ``(n, R, 3, 3)``, only the x axis (the link's line) after a spin-gauged ball: the
    spin of an S-S link is not closed by the loop (its gauge fixes its rate only), each engine carries the
    stations' spin, which rounding near an edge of assembly moves (measured 2.6e-10)."""
    axes = np.stack([f.re for f in an.chain.frames], axis=1).copy()
    axes[:, list(an.loop.spin_gauges), :, 1:] = 0.0
    return axes


def assert_same(mine: LoopAnalysis, ref: LoopAnalysis) -> None:
    """Statuses row by row, then every column on the rows where the numpy solver gives it."""
    np.testing.assert_array_equal(mine.status.astype(str), ref.status.astype(str))
    closed = np.isin(ref.status, ("ok", "dead_centre"))
    ok = ref.status == "ok"
    position, rate, accel = _edge_gains(mine, ref)
    _columns("scalars", _wound(mine, ref), ref.state.scalars, closed, position)
    _close("link axes", _link_axes(mine), _link_axes(ref), closed, 1.0, position[:, None, None, None])
    # closed as tightly as the numpy solver: below LOOP_CLOSURE, or (an ill-conditioned random table whose
    # refine stops at ~8e-13 in both, seed 1291 RRSRR) no worse than twice its residual
    assert (mine.residual[closed] < np.maximum(LOOP_CLOSURE, 2.0 * ref.residual[closed])).all()
    _columns("q_dot", _ball_rates(mine, mine.rates.q_dot), _ball_rates(ref, ref.rates.q_dot), closed, rate)
    _columns("q_ddot", _ball_rates(mine, mine.rates.q_ddot), _ball_rates(ref, ref.rates.q_ddot), closed,
             accel)
    for what, gain in (("link_twist", rate), ("link_accel", accel)):
        _columns(what, np.stack([t.stacked() for t in getattr(mine.rates, what)], axis=1),
                 np.stack([t.stacked() for t in getattr(ref.rates, what)], axis=1), closed, gain)
    w, r = mine.wrenches, ref.wrenches
    _columns("transmission", w.transmission, r.transmission, closed, accel)
    # lengths: a point moves by its pose's error times the loop's extent, whatever its own coordinate (a
    # joint's point 0.037 from an axis, on a loop 0.4 long: 8.7e-14 apart at the row above)
    points, want = w.point.reshape(w.point.shape[0], -1), r.point.reshape(r.point.shape[0], -1)
    extent = np.abs(want[ok]).max(initial=0.0)
    for c in range(want.shape[1]):
        _close(f"point[{c}]", points[:, c], want[:, c], ok, extent, position)
    # reactions: one least-squares solve per row, its rounding scaled by the largest unknown of a unit and
    # by 1/|t| near a dead centre
    gain = np.maximum(accel, LOOP_REACTIONS_ROUNDING / KERNEL_VS_NUMPY_LOOP / np.abs(r.transmission))
    # the same solve's misfit, relative to the equations' size: rounding noise (or the real misfit of a
    # spinning link), which grows as the reactions' beside a dead centre (7e-12 at |t| = 6.4e-6)
    _close("dynamics residual", w.residual, r.residual, ok, 1.0, gain)
    peak = {"f": np.abs(r.force[ok]).max(initial=0.0), "m": np.abs(r.moment[ok]).max(initial=0.0)}
    for what in ("force", "moment"):
        for j in range(r.force.shape[1]):
            for c in range(3):
                _close(f"{what}[{j}, {c}]", getattr(w, what)[:, j, c], getattr(r, what)[:, j, c], ok,
                       peak[what[0]], gain)
    assert w.efforts.keys() == r.efforts.keys()
    for key, value in r.efforts.items():  # at least its unit's peak: an idle slide's force is nil
        _close(key, w.efforts[key], value, ok, max(np.abs(value[ok]).max(initial=0.0), peak[
            "f" if key.startswith("s") else "m"]), gain)
    for row, (got, want) in enumerate(zip(w.components, r.components)):
        assert got.keys() == want.keys()
        if row - 1 in ref.loop.spin_gauges:  # axes of a spun link (_link_axes): its world force is held
            continue
        for key, value in want.items():
            _close(f"joint {row + 1} {key}", got[key], value, ok, peak[key[0]], gain)


@pytest.mark.parametrize("name", preset_names() + VARIANTS)
def test_slider_crank(name: str) -> None:
    mech, start = _slider_crank(name)
    assert_same(analyze_loop(mech, start), analyze_loop(mech, start, compiled=False))


@pytest.mark.parametrize("name", ["rssr-torque-1", "rssr-output-1", "rssr-output--1", "rccc-output-1",
                                  "rccc-output--1"])
def test_linkages(name: str) -> None:
    mech, start = _linkage(name)
    assert_same(analyze_loop(mech, start), analyze_loop(mech, start, compiled=False))


def test_start_searched() -> None:
    """Without a start pose both search the same one (find_start) and agree."""
    mech, _ = _linkage("rssr-output-1")
    assert_same(analyze_loop(mech), analyze_loop(mech, compiled=False))


def test_start_in_the_middle() -> None:
    """A start pose at a later position: the stations are closed backward from it too."""
    mech, _ = _linkage("rssr-output-1")
    at = 100
    ref = analyze_loop(mech, compiled=False)
    start = ref.state.take(slice(at, at + 1))
    assert_same(analyze_loop(mech, start, at), analyze_loop(mech, start, at, compiled=False))


def test_start_that_does_not_close() -> None:
    """A start at a position that cannot assemble: the same one-line error."""
    mech, start = _slider_crank("no-assembly-gap")
    at = int(np.flatnonzero(analyze_loop(mech, start, compiled=False).status == "no_assembly")[0])
    with pytest.raises(ValueError, match=f"does not close at position {at + 1}") as compiled:
        analyze_loop(mech, start, at)
    with pytest.raises(ValueError) as numpy:
        analyze_loop(mech, start, at, compiled=False)
    assert str(compiled.value) == str(numpy.value)


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), topology=st.sampled_from(TOPOLOGIES))
@example(seed=1291, topology="RRSRR")  # the refine stops at 8.4e-13 in both engines
@example(seed=34909, topology="RRSRR")  # closed to 1.5e-13 and 8.2e-14 at c = 0.1: rates 1.3e-12 apart
def test_random_tables(seed: int, topology: str) -> None:
    """Random tables of every topology where they assemble at every position (the test tables' stretch of
    the drive at 64 positions).  Across a gap of assembly a station may need the DFP search, whose end
    rounding can move to another basin in either engine, and every position closed from that station with
    it (measured: a random RSCR's 25 rows after its gap, ``branch_jump`` in one engine, ``ok`` in the other):
    the presets' gap (``no-assembly-gap``) is held instead."""
    mech = random_table(seed, topology)
    drive = mech.drive
    mech = dataclasses.replace(mech, drive=dataclasses.replace(
        drive, positions=np.linspace(drive.positions[0], drive.positions[-1], 64)))
    found = search_assembly(to_loop(mech), drive_state(mech).take(slice(0, 1)).values, seed % 1000)
    assume(found.scalars.shape[0] > 0)
    start = found.take(slice(0, 1))
    ref = analyze_loop(mech, start, compiled=False)
    assume(np.isin(ref.status, ("ok", "dead_centre")).all())
    assert_same(analyze_loop(mech, start), ref)


@pytest.mark.parametrize("block", [1, 180])  # as many blocks as the threads take; two blocks
def test_answers_do_not_depend_on_the_blocks(monkeypatch: pytest.MonkeyPatch, block: int) -> None:
    """Blocks of positions on the threads, one of them on the stations' scratch (whatever its remembered
    turns): every output the same to the bit as one block's, the no-assembly gap and its repairs included."""
    mech, start = _slider_crank("no-assembly-gap")
    monkeypatch.setattr(loop_engine, "BLOCK", 10**9)
    one = analyze_loop(mech, start)
    monkeypatch.setattr(loop_engine, "BLOCK", block)
    many = analyze_loop(mech, start)
    assert (many.status == one.status).all()
    pairs = {"state": (many.state.scalars, one.state.scalars),
             "q_ddot": (many.rates.q_ddot, one.rates.q_ddot),
             "force": (many.wrenches.force, one.wrenches.force),
             "moment": (many.wrenches.moment, one.wrenches.moment),
             "transmission": (many.wrenches.transmission, one.wrenches.transmission),
             "iterations": (many.iterations, one.iterations)}
    for name, (mine, ref) in pairs.items():
        np.testing.assert_array_equal(mine, ref, err_msg=name)


def test_scratch_given_back_is_reused_with_the_same_answers(monkeypatch: pytest.MonkeyPatch) -> None:
    """A case solved on the scratch another case of the same sizes gave back (pool.take_scratch): no scratch
    made, every output the same to the bit as on fresh scratch, the no-assembly gap's repairs included."""
    mech, start = _slider_crank("no-assembly-gap")
    other, other_start = _slider_crank("thesis/a4-20-s1-3.5")
    monkeypatch.setattr(loop_engine, "BLOCK", 60)  # several blocks: several sets
    monkeypatch.setattr(pool, "_SPARE", {})
    fresh = analyze_loop(mech, start)
    analyze_loop(other, other_start)
    made = []
    monkeypatch.setattr(loop_engine, "make_work", lambda fl: made.append(fl))  # would fail if called
    reused = analyze_loop(mech, start)
    assert not made
    assert (reused.status == fresh.status).all()
    for name in ("state", "rates", "wrenches"):
        for mine, ref in zip(_arrays(getattr(reused, name)), _arrays(getattr(fresh, name))):
            np.testing.assert_array_equal(mine, ref, err_msg=name)
    np.testing.assert_array_equal(reused.iterations, fresh.iterations)


def _arrays(record: object) -> list[np.ndarray]:
    """Every array of a result record (its fields, duals' parts, dicts' values), in order."""
    if isinstance(record, np.ndarray):
        return [record]
    if isinstance(record, dict):
        return [a for v in record.values() for a in _arrays(v)]
    if isinstance(record, (list, tuple)):
        return [a for v in record for a in _arrays(v)]
    if dataclasses.is_dataclass(record) or hasattr(record, "__dict__"):
        return [a for v in vars(record).values() for a in _arrays(v)]
    return []


def test_a_fine_grid_is_closed_from_the_positions_before() -> None:
    """On a fine even grid (0.01 deg) the kernel estimates a position from the two before it
    (``loop_engine_nb._estimate``): one Newton step and the refine's at nearly every position, at least one
    step fewer on average than the numpy solver from the stations 15 deg apart, and the same answers."""
    case = load_case("thesis/a4-20-s1-3.5")
    first = analyze(case.with_values({"motion.angles_deg": {"start": 0.0, "stop": 1.0, "step": 1.0}}))
    case = case.with_values({"motion.angles_deg": {"start": 0.0, "stop": 360.0, "step": 0.01}})
    mech, start = slider_crank_table(case), slider_crank_start(case, first.s4[0])
    mine, ref = analyze_loop(mech, start), analyze_loop(mech, start, compiled=False)
    assert_same(mine, ref)
    assert mine.iterations.mean() <= ref.iterations.mean() - 1.0, (mine.iterations.mean(),
                                                                   ref.iterations.mean())
