"""The closure solver: Newton, its DFP fallback, and the no-assembly verdict."""

import numpy as np
from numpy.testing import assert_allclose

from dualmech.core.closure import ClosureStatus, solve_closure
from dualmech.models.case import load_case
from dualmech.models.slider_crank.closure import planar_estimate, state_from_slider
from dualmech.models.slider_crank.loop import LOOP, Batch
from tests.oracles import assembly_margin, exact_slider_motion
from tests.tolerances import S4_VS_CLOSED_FORM


def _batch(case):
    return Batch.of([case], [case.own_crank_states()])


def test_newton_converges_quadratically_from_plane_geometry():
    case = load_case("a4-20-alpha-310")
    batch = _batch(case)
    res = solve_closure(LOOP, batch.inputs(), state_from_slider(batch, planar_estimate(batch)))
    assert (res.status == ClosureStatus.OK).all()
    assert res.iterations.max() <= 5 and not res.used_dfp.any()
    s4, _, _ = exact_slider_motion(case, batch.crank.theta)
    assert_allclose(res.state.scalars[:, 0], s4, rtol=0, atol=S4_VS_CLOSED_FORM * case.geometry.rod_length)


def test_dfp_takes_over_when_newton_is_cut_short():
    """With a single Newton iteration allowed, DFP (then a Newton polish) must still close the loop."""
    case = load_case("a4-30-s1-9").with_values(
        {"motion.angles_deg": {"start": 0.0, "stop": 360.0, "step": 20.0}}
    )
    batch = _batch(case)
    rng = np.random.default_rng(5)
    guess = state_from_slider(batch, planar_estimate(batch) + rng.uniform(-4, 4, len(batch)))
    res = solve_closure(LOOP, batch.inputs(), guess, max_newton=0)
    assert res.used_dfp.all()
    assert (res.status == ClosureStatus.OK).all()
    s4, _, _ = exact_slider_motion(case, batch.crank.theta)
    assert_allclose(res.state.scalars[:, 0], s4, rtol=0, atol=S4_VS_CLOSED_FORM * case.geometry.rod_length)


def test_unreachable_positions_are_no_assembly_not_failures():
    case = load_case("a4-30-s1-3.5").with_values(
        {
            "geometry.slider_offset": 45.0,
            "geometry.crank_axial_shift": 0.0,
            "motion.angles_deg": {"start": 0.0, "stop": 360.0, "step": 10.0},
        }
    )
    batch = _batch(case)
    res = solve_closure(LOOP, batch.inputs(), state_from_slider(batch, planar_estimate(batch)))
    cannot = assembly_margin(case, batch.crank.theta) < 0
    assert cannot.any()
    assert (res.status[cannot] == ClosureStatus.NO_ASSEMBLY).all()
    assert (res.residual[cannot] > 1e-3).all()
