"""The loop description: screws are the derivatives of the loop product (thesis eq. 8-17)."""

import numpy as np
from numpy.testing import assert_allclose

from dualmech.core.loop import LoopState, closure_error, closure_residual, evaluate, jacobian, rodrigues
from dualmech.models.case import load_case
from dualmech.models.slider_crank import LOOP, Batch, analyze, state_from_slider
from tests.tolerances import FINITE_DIFFERENCE


def _batch(n=5, seed=0):
    rng = np.random.default_rng(seed)
    case = load_case("a4-20-alpha-232").with_values({"geometry.crank_axial_shift": 2.0})
    angles = rng.uniform(0, 360, n)
    return Batch.of([case], [case.motion.state(2.0, angles)]), rng


def test_jacobian_is_derivative_of_closure_error():
    """Column j of J is the derivative of the closure error along unknown j (eq. 11-17), by central differences.

    Checked away from closure (random slider positions), where the screw alone would not do.
    """
    batch, rng = _batch()
    state = state_from_slider(batch, rng.uniform(30, 50, len(batch)))
    chain = evaluate(LOOP, batch.inputs(), state)
    jac = jacobian(chain, LOOP)
    h = 1e-6
    for j in range(LOOP.n_unknown):
        step = np.zeros((len(batch), LOOP.n_unknown))
        step[:, j] = h
        plus = closure_error(evaluate(LOOP, batch.inputs(), state.retract(step, LOOP)), LOOP)
        minus = closure_error(evaluate(LOOP, batch.inputs(), state.retract(-step, LOOP)), LOOP)
        assert_allclose((plus - minus) / (2 * h), jac[:, :, j], rtol=0, atol=FINITE_DIFFERENCE)


def test_jacobian_at_closure_is_the_screws():
    """At closure the columns are the unknowns' screws (Plücker lines of the joint axes)."""
    case = load_case("a4-20-alpha-232")
    an = analyze(case)
    batch = Batch.of([case], [an.crank])
    from dualmech.models.slider_crank import close_loop

    state, *_ = close_loop(batch)
    chain = evaluate(LOOP, batch.inputs(), state)
    jac = jacobian(chain, LOOP)
    for s in chain.screws:
        if s.var[0] == "unknown":
            expected = np.concatenate([s.line.re, s.line.du / batch.a2[:, None]], axis=1)
            assert_allclose(jac[:, :, s.var[1]], expected, rtol=0, atol=1e-12)


def test_residual_sees_half_turn_that_skew_part_misses():
    """A loop product rotated by pi has no skew part but is not closed (the reason for eq. 22)."""
    batch, rng = _batch(1)
    state = state_from_slider(batch, np.array([40.0]))
    flipped = LoopState(state.scalars, state.rotations.copy())
    flipped.rotations[:, 1] = flipped.rotations[:, 1] @ rodrigues(np.array([np.pi, 0, 0]))
    chain = evaluate(LOOP, batch.inputs(), flipped)
    assert closure_residual(chain, LOOP)[0] > 1.0


def test_rodrigues_is_a_rotation():
    rng = np.random.default_rng(3)
    w = rng.normal(size=(20, 3))
    w[0] = 1e-12  # the small-angle branch
    r = rodrigues(w)
    assert_allclose(r @ np.swapaxes(r, 1, 2), np.broadcast_to(np.eye(3), r.shape), atol=1e-14)
    axis = w / np.linalg.norm(w, axis=1, keepdims=True)
    assert_allclose(np.einsum("nij,nj->ni", r, axis), axis, atol=1e-14)
