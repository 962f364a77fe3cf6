"""What the kernel does for speed may not change an answer: its pseudo-inverse, its warm starts.

The kernel runs without numba's runtime (no allocation), so its pseudo-inverse is its own
(one-sided Jacobi, :mod:`dualmech.core.kernel.linalg_nb`); positions start from their
predecessor's state (:func:`dualmech.models.slider_crank.kernel_nb.warm_start`) in chains that begin at
fixed positions of each case, so every bit of a result is independent of threads and chunks.
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from dualmech.core.kernel.linalg_nb import pseudo_inverse
from dualmech.models.case import load_case
from dualmech.models.slider_crank import kernel as slider_crank_kernel

#: The pseudo-inverse against LAPACK's (SVD): both backward stable, so they agree to a few units of
#: round-off of the matrix's condition (measured 3e-15 of |A+| on these 7x7 matrices).
PINV_AGREEMENT = 1e-12


@pytest.mark.parametrize("rank", [7, 5, 1, 0])
def test_pseudo_inverse_is_numpys(rank: int) -> None:
    rng = np.random.default_rng(rank)
    k = 7
    a = rng.normal(size=(k, rank)) @ rng.normal(size=(rank, k)) if rank else np.zeros((k, k))
    out, u, v = np.empty((k, k)), np.empty((k, k)), np.empty((k, k))
    pseudo_inverse(a, out, u, v)
    expected = np.linalg.pinv(a)
    assert_allclose(out, expected, rtol=0, atol=PINV_AGREEMENT * max(np.abs(expected).max(), 1.0))


def test_results_do_not_depend_on_chunks_or_threads(monkeypatch: pytest.MonkeyPatch) -> None:
    """Warm-start chains begin at fixed positions: streamed in small chunks, or on one thread, the
    answer is the same to the last bit as in one piece."""
    grid = {"motion.angles_deg": {"start": 0.0, "stop": 360.0, "step": 0.25}}
    case = load_case("a4-30-s1-3.5").with_values(grid)
    whole = slider_crank_kernel.solve_case(case)
    streamed = [  # the chunks share one buffer: copy each out
        {k: v.copy() for k, v in c.columns.items()} for c in slider_crank_kernel.iter_chunks(case, 150)
    ]
    monkeypatch.setattr(slider_crank_kernel, "threads", lambda: 1)
    single = slider_crank_kernel.solve_case(case)
    for name, col in whole.columns.items():
        parts = np.concatenate([c[name] for c in streamed])
        assert_allclose(parts, col, rtol=0, atol=0, equal_nan=True, err_msg=name)
        assert_allclose(single[name], col, rtol=0, atol=0, equal_nan=True, err_msg=name)


def test_warm_starts_take_fewer_iterations() -> None:
    """On a fine grid a warm start closes in one or two Newton steps; cold starts (a coarse grid,
    beyond ``WARM_SPAN``) take the estimate's three."""
    case = load_case("a4-30-s1-3.5")
    fine = slider_crank_kernel.solve_case(
        case.with_values({"motion.angles_deg": {"start": 0.0, "stop": 360.0, "step": 0.1}})
    )
    coarse = slider_crank_kernel.solve_case(
        case.with_values({"motion.angles_deg": {"start": 0.0, "stop": 360.0, "step": 3.0}})
    )
    assert fine.meta["iterations"].mean() < 0.8 * coarse.meta["iterations"].mean()


def test_chunks_take_their_buffers_in_turn() -> None:
    """With ``buffers=2`` chunk ``k + 1`` is computed into the other buffer (the pipelined solve still
    writes chunk ``k``), chunk ``k + 2`` into chunk ``k``'s (memory stays two chunks), with the same
    bits as one buffer reused.  (With the one buffer of before, chunks ``k`` and ``k + 1`` share it.)"""
    grid = {"motion.angles_deg": {"start": 0.0, "stop": 360.0, "step": 0.25}}
    case = load_case("a4-30-s1-3.5").with_values(grid)
    one = [{k: v.copy() for k, v in c.columns.items()} for c in slider_crank_kernel.iter_chunks(case, 200)]
    two = [dict(c.columns) for c in slider_crank_kernel.iter_chunks(case, 200, buffers=2)]
    assert len(two) == len(one) == 8
    def same_buffer(a: dict, b: dict) -> bool:  # a partial last chunk uses the first part of its buffer
        return any(np.shares_memory(x, y) for x in a.values() for y in b.values())

    assert all(not same_buffer(a, b) for a, b in zip(two, two[1:]))
    assert all(same_buffer(a, b) for a, b in zip(two, two[2:]))
    for k, (a, b) in enumerate(zip(one, slider_crank_kernel.iter_chunks(case, 200, buffers=2))):
        for name, col in a.items():
            assert_allclose(b.columns[name], col, rtol=0, atol=0, equal_nan=True, err_msg=f"{k} {name}")
    with pytest.raises(ValueError, match="buffers: expected at least 1, got 0"):
        next(slider_crank_kernel.iter_chunks(case, 200, buffers=0))


def test_chunks_begun_ahead_keep_their_bits_and_buffers() -> None:
    """With the kernel one chunk ahead (``ahead=1``, as the streamed solve runs it) chunk ``k`` is in
    buffer ``k % 3`` and has the same bits as the chunks computed one at a time; positions split into
    blocks on both threads (chunks of 1,000 positions).  ``ahead`` must leave a buffer to read."""
    grid = {"motion.angles_deg": {"start": 0.0, "stop": 360.0, "step": 0.05}}
    case = load_case("a4-30-s1-3.5").with_values(grid)
    one = [{k: v.copy() for k, v in c.columns.items()} for c in slider_crank_kernel.iter_chunks(case, 1000)]
    ahead = [dict(c.columns) for c in slider_crank_kernel.iter_chunks(case, 1000, buffers=3, ahead=1)]
    assert len(ahead) == len(one) == 8
    s4 = [c["S4"] for c in ahead]
    assert all(np.shares_memory(a, b) == (k % 3 == 0) for a in s4[:1] for k, b in enumerate(s4[1:], 1))
    for k, (a, b) in enumerate(zip(one, slider_crank_kernel.iter_chunks(case, 1000, buffers=3, ahead=1))):
        for name, col in a.items():
            assert_allclose(b.columns[name], col, rtol=0, atol=0, equal_nan=True, err_msg=f"{k} {name}")
    with pytest.raises(ValueError, match=r"ahead: expected 0 to 1 \(fewer than the 2 buffers\), got 2"):
        next(slider_crank_kernel.iter_chunks(case, 200, buffers=2, ahead=2))


def test_remembered_turns_are_fresh_turns() -> None:
    """The joint factors remembered from the last evaluation (``Work.turns``) are reused only for the
    same angle and slide: after an evaluation of another design (same twist, other slider offset), the
    loop evaluates to the same bits as with nothing remembered."""
    from dualmech.core.kernel.closure_nb import make_work
    from dualmech.core.kernel.loop_nb import evaluate, flatten, value_names
    from dualmech.models.slider_crank.loop import LOOP

    fl, names = flatten(LOOP), value_names(LOOP)
    x = np.concatenate([[40.0], np.eye(3).ravel(), np.eye(3).ravel()])

    def frames(values: dict[str, float], turns: np.ndarray) -> np.ndarray:
        w = make_work(fl)
        vals = np.array([values[n] for n in names])
        evaluate(fl, vals, x, w.frames, w.lines, turns)
        return w.frames.copy()

    design = {"theta1": 0.3, "S1": 2.0, "a1": 12.0, "a2": 50.0, "a4": 10.0, "alpha4": 4.7}
    other = {**design, "a4": 30.0, "S1": 3.0}  # the same angles, other slides
    turns = np.full((len(LOOP.rows), 3, 20), np.nan)
    frames(other, turns)
    assert_allclose(frames(design, turns), frames(design, np.full_like(turns, np.nan)), rtol=0, atol=0)
