"""Continuation closure of any table: interpolated starts, searched assemblies, the branch by the Jacobian's
sign, branch jumps flagged (on the RSSR's table, whose closed form gives both branches)."""

from __future__ import annotations

import numpy as np
import pytest

from dualmech.core import continuation
from dualmech.core.closure import ClosureStatus, solve_closure
from dualmech.core.continuation import branch_sign, continue_closure, interpolate, search_assembly
from dualmech.core.loop import LoopState, closure_residual, evaluate, rodrigues
from dualmech.models.linkages import read_linkage
from dualmech.models.linkages.rssr import closed_form_phi, estimate
from dualmech.models.linkages.rssr_case import rssr_from_dict
from dualmech.models.slider_crank.loop import LOOP as SLIDER_CRANK
from tests.linkage_oracles import RSSR_LOOP as LOOP
from tests.linkage_oracles import rssr_loop_values as loop_values
from tests.tolerances import LOOP_CLOSURE, LOOP_VS_OWN_ENGINE

GEOMETRY = rssr_from_dict(read_linkage("rssr")).geometry


def _closed(theta: np.ndarray, branch: int) -> tuple[dict, LoopState]:
    values = loop_values(GEOMETRY, theta)
    guess = estimate(GEOMETRY, theta, closed_form_phi(GEOMETRY, theta, branch)[0])
    res = solve_closure(LOOP, values, guess)
    assert (res.status == ClosureStatus.OK).all()
    return values, res.state


def test_interpolate_ends_and_middle() -> None:
    rng = np.random.default_rng(1)
    a = LoopState(rng.normal(size=(4, 2)), rodrigues(rng.normal(size=(4, 2, 3)) * 0.5))
    b = LoopState(rng.normal(size=(4, 2)), rodrigues(rng.normal(size=(4, 2, 3)) * 0.5))
    for t, want in ((0.0, a), (1.0, b)):
        got = interpolate(a, b, np.full(4, t))
        np.testing.assert_allclose(got.scalars, want.scalars, rtol=0, atol=1e-15)
        np.testing.assert_allclose(got.rotations, want.rotations, rtol=0, atol=1e-12)
    half = interpolate(a, b, np.full(4, 0.5)).rotations
    # halfway: the same turn takes a to the middle and the middle to b
    np.testing.assert_allclose(half @ np.swapaxes(a.rotations, -1, -2),
                               b.rotations @ np.swapaxes(half, -1, -2), rtol=0, atol=1e-12)


def test_the_two_branches_have_opposite_signs() -> None:
    theta = np.radians(np.arange(0.0, 360.0, 30.0))
    values, up = _closed(theta, 1)
    _, down = _closed(theta, -1)
    signs = branch_sign(LOOP, values, up)
    assert (signs != 0).all() and (signs == signs[0]).all()
    np.testing.assert_array_equal(branch_sign(LOOP, values, down), -signs)


def test_search_finds_both_assemblies() -> None:
    values = loop_values(GEOMETRY, np.array([0.3]))
    found = search_assembly(LOOP, values, seed=3)
    many = {k: np.repeat(v, found.scalars.shape[0]) for k, v in values.items()}
    np.testing.assert_array_less(closure_residual(evaluate(LOOP, many, found), LOOP), LOOP_CLOSURE)
    assert set(branch_sign(LOOP, many, found)) == {-1, 1}


def test_follows_the_start_branch_and_flags_a_jump(monkeypatch: pytest.MonkeyPatch) -> None:
    theta = np.radians(np.arange(0.0, 360.0, 5.0))
    values, down = _closed(theta, -1)
    _, up = _closed(theta, 1)
    result = continue_closure(LOOP, values, up.take(slice(0, 1)))
    assert (result.status == ClosureStatus.OK).all() and not result.branch_jump.any()
    turn = np.mod(result.state.scalars - up.scalars + np.pi, 2 * np.pi) - np.pi  # the angle, modulo 2 pi
    np.testing.assert_allclose(turn, 0.0, rtol=0, atol=LOOP_VS_OWN_ENGINE)
    # a batch start on the other branch at position 7 closes there; it is closed again from its neighbour,
    # on the start's branch (as every position between two stations too far apart for their interpolation)
    real = continuation.interpolate
    monkeypatch.setattr(continuation, "interpolate",
                        lambda a, b, t: real(a, b, t).put(np.array([7]), down.take(np.array([7]))))
    repaired = continue_closure(LOOP, values, up.take(slice(0, 1)))
    assert (repaired.status == ClosureStatus.OK).all() and not repaired.branch_jump.any()
    np.testing.assert_allclose(repaired.state.scalars, result.state.scalars, rtol=0, atol=LOOP_VS_OWN_ENGINE)
    # where no neighbour reaches the start's branch either, the jump is reported, not followed
    real_one = continuation._close_one
    monkeypatch.setattr(continuation, "_close_one",
                        lambda loop, inputs, i, guess, branch: None if i == 7 else
                        real_one(loop, inputs, i, guess, branch))
    jumped = continue_closure(LOOP, values, up.take(slice(0, 1)))
    np.testing.assert_array_equal(np.flatnonzero(jumped.branch_jump), [7])


def test_a_start_that_does_not_close_is_refused() -> None:
    far = loop_values(GEOMETRY, np.array([0.0]))
    far["a2"] = far["a2"] * 10.0  # the coupler is far too long: no assembly
    with pytest.raises(ValueError, match="^start: the loop does not close at position 1 "):
        continue_closure(LOOP, far, estimate(GEOMETRY, np.array([0.0]), np.array([0.0])))


def test_search_scales_the_slides_whatever_their_names() -> None:
    """The random starts draw slides within the given size and angles within pi, by the slot a variable sits
    in, not by its name (the slider crank's own table calls its slide ``S4``)."""
    assert continuation._slides(SLIDER_CRANK).tolist() == [True]
    assert continuation._slides(LOOP).tolist() == [False]  # the RSSR's theta4


def test_the_walk_crosses_a_lock_but_not_an_edge_of_assembly() -> None:
    """:func:`~dualmech.core.continuation.cross_lock` on the slider crank's table: through a universal
    joint's lock (180 deg, a4 = a1) it reaches the next row smoothly, on the determinant's other sign; by a
    turning point of the drive (1e-6 a2 inside -60 deg) it walks between rows well inside, but not past the
    edge, where the loop does not close."""
    from dualmech.models.loop.engine import analyze_loop
    from tests.models.loop.test_condition import TURNING_A4, _slider_crank
    from tests.models.loop.test_engine import LOCK_A4, LOCK_TWIST

    _, lock = _slider_crank(LOCK_A4, {"start": 178.0, "stop": 182.5, "step": 2.0}, universal=True,
                            twist=LOCK_TWIST)
    an = analyze_loop(lock)
    values, first = an.drive.values, an.state.take(slice(0, 1))
    crossed = continuation.cross_lock(an.loop, values, 0, 2, first, 17)
    assert crossed is not None
    at, start = ({k: v[r:r + 1] for k, v in values.items()} for r in (2, 0))
    assert branch_sign(an.loop, at, crossed)[0] == -branch_sign(an.loop, start, first)[0]
    assert closure_residual(evaluate(an.loop, at, crossed), an.loop)[0] < LOOP_CLOSURE
    _, edge = _slider_crank(TURNING_A4, {"start": -62.0, "stop": -58.5, "step": 1.0})
    an = analyze_loop(edge)
    assert list(an.status[:3]) == ["ok"] * 3
    assert continuation.cross_lock(an.loop, an.drive.values, 0, 1, an.state.take(slice(0, 1))) is not None
    assert continuation.cross_lock(an.loop, an.drive.values, 1, 3, an.state.take(slice(1, 2))) is None


@pytest.mark.parametrize("jump", [0.0, 0.3])
def test_the_walk_refuses_a_step_off_its_secant(monkeypatch, jump: float) -> None:
    """The smoothness rule alone, on closures scripted along a straight path of the slider crank table's
    unknown (``s4`` = the walk's fraction): a smooth walk is taken; one whose fifth closure lands ``jump``
    (30 % of the path; each step is 1/9 of it) off the path (another assembly) is refused."""
    from dualmech.core.closure import ClosureResult
    from dualmech.models.loop.translate import drive_state, to_loop
    from tests.models.loop.test_condition import _slider_crank

    _, mechanism = _slider_crank(30.0, {"start": 0.0, "stop": 10.5, "step": 10.0})
    loop, values = to_loop(mechanism), drive_state(mechanism).values
    rotations = np.broadcast_to(np.eye(3), (1, len(loop.spherical_rows), 3, 3)).copy()
    calls, length = [], values["length_scale"][0]

    def scripted(loop_, at, guess):
        calls.append(at)
        s = (len(calls) / 9 + (jump if len(calls) == 5 else 0.0)) * length
        state = LoopState(np.array([[s]]), rotations)
        return ClosureResult(state, np.array([ClosureStatus.OK]), np.zeros(1, int), np.zeros(1),
                             np.zeros(1, bool))

    monkeypatch.setattr(continuation, "solve_closure", scripted)
    start = LoopState(np.zeros((1, 1)), rotations)
    walked = continuation.cross_lock(loop, values, 0, 1, start, 9)
    assert (walked is None) == (jump > 0.0)
