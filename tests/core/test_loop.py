"""The loop description: screws are the derivatives of the loop product (thesis eq. 8-17)."""

import numpy as np
from numpy.testing import assert_allclose

from dualmech.core.closure import _objective
from dualmech.core.loop import LoopState, closure_error, closure_residual, evaluate, rodrigues, screw_jacobian
from dualmech.models.case import load_case
from dualmech.models.slider_crank.closure import close_loop, state_from_slider
from dualmech.models.slider_crank.loop import LOOP, Batch
from tests.tolerances import FINITE_DIFFERENCE


def _batch(n=5, seed=0):
    rng = np.random.default_rng(seed)
    case = load_case("a4-20-alpha-232").with_values({"geometry.crank_axial_shift": 2.0})
    angles = rng.uniform(0, 360, n)
    return Batch.of([case], [case.motion.state(2.0, angles)]), rng


def test_screws_are_the_derivative_of_the_closure_error_at_closure():
    """At a closed position the screw columns (eq. 11-17) are d(error)/dx, by central differences."""
    batch, _ = _batch()
    state, status, _, _ = close_loop(batch)
    assert (status == "ok").all()
    chain = evaluate(LOOP, batch.inputs(), state)
    jac = screw_jacobian(chain, LOOP)
    h = 1e-6
    for j in range(LOOP.n_unknown):
        step = np.zeros((len(batch), LOOP.n_unknown))
        step[:, j] = h
        plus = closure_error(evaluate(LOOP, batch.inputs(), state.retract(step, LOOP)), LOOP)
        minus = closure_error(evaluate(LOOP, batch.inputs(), state.retract(-step, LOOP)), LOOP)
        assert_allclose((plus - minus) / (2 * h), jac[:, :, j], rtol=0, atol=FINITE_DIFFERENCE)


def test_dfp_gradient_is_the_derivative_of_its_objective_away_from_closure():
    """The DFP objective 1/2 |B - I|^2 and its gradient, checked where the loop is open."""
    batch, rng = _batch()
    state = state_from_slider(batch, rng.uniform(30, 50, len(batch)))
    f, grad, *_ = _objective(LOOP, batch.inputs(), state)
    assert (f > 1e-6).all()  # really open
    h = 1e-6
    for j in range(LOOP.n_unknown):
        step = np.zeros((len(batch), LOOP.n_unknown))
        step[:, j] = h
        f_p = _objective(LOOP, batch.inputs(), state.retract(step, LOOP))[0]
        f_m = _objective(LOOP, batch.inputs(), state.retract(-step, LOOP))[0]
        assert_allclose((f_p - f_m) / (2 * h), grad[:, j], rtol=0, atol=FINITE_DIFFERENCE)


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
    assert_allclose(r @ np.swapaxes(r, 1, 2), np.broadcast_to(np.eye(3), r.shape), rtol=0, atol=1e-14)
    axis = w / np.linalg.norm(w, axis=1, keepdims=True)
    assert_allclose(np.einsum("nij,nj->ni", r, axis), axis, rtol=0, atol=1e-14)
