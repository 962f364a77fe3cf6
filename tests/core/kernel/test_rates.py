"""The compiled rates from the branch sign's factorization against a fresh one (:func:`dualmech.core.kernel.
rates_nb.solve_rates`, ``factored``): the closure Jacobian with its dual rows over the length scale, factored
once for the branch, solves the same rates and accelerations as the rate equations' own matrix."""

from __future__ import annotations

import numpy as np
import pytest

from dualmech.core.kernel.closure_nb import make_work, residual_at
from dualmech.core.kernel.continuation_nb import branch_sign
from dualmech.core.kernel.loop_engine import _by_value
from dualmech.core.kernel.loop_nb import flatten, length_scale, value_names
from dualmech.core.kernel.rates_nb import solve_rates
from dualmech.models.loop.engine import analyze_loop
from tests.core.kernel.test_loop_engine import _linkage, _slider_crank
from tests.tolerances import REUSED_FACTORS

OUTPUTS = ("q_dot", "q_ddot", "twists", "accels")


def _rates(fl, vdot: np.ndarray, vddot: np.ndarray, w, factored: float) -> list[np.ndarray]:
    solve_rates(fl, vdot, vddot, w, factored)
    return [getattr(w, name).copy() for name in OUTPUTS]


@pytest.mark.parametrize("name", ["slider", "rssr-output-1", "rccc-output-1"])
def test_the_branch_signs_factors_solve_the_rates(name: str) -> None:
    mech, start = _slider_crank("thesis/a4-20-s1-3.5") if name == "slider" else _linkage(name)
    an = analyze_loop(mech, start)
    fl, names = flatten(an.loop), value_names(an.loop)
    n = an.state.scalars.shape[0]
    vals, vdot, vddot = (_by_value(names, d, n) for d in (an.drive.values, an.drive.rates, an.drive.accels))
    xs = np.concatenate([an.state.scalars, an.state.rotations.reshape(n, -1)], axis=1)
    w = make_work(fl)
    scales = []
    for i in range(0, n, 7):
        residual_at(fl, vals[i], xs[i], w)
        assert branch_sign(fl, vals[i], xs[i], w) != 0
        scales.append(length_scale(fl, vals[i]))
        reused = _rates(fl, vdot[i], vddot[i], w, scales[-1])
        fresh = _rates(fl, vdot[i], vddot[i], w, 0.0)
        for what, mine, ref in zip(OUTPUTS, reused, fresh):
            np.testing.assert_allclose(mine, ref, rtol=0, atol=REUSED_FACTORS * np.abs(ref).max(),
                                       err_msg=f"{what} at position {i}")
    assert np.abs(np.log(scales)).min() > 0.1  # a scale far from 1: the dual rows' division is seen
