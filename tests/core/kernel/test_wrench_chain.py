"""The Newton-Euler systems solved along the chain (:mod:`dualmech.core.kernel.wrench_chain_nb`) against the
Householder QR of the whole system (:func:`dualmech.core.kernel.wrenches_nb._householder_solve`, itself held
to numpy's in ``test_wrenches.py``): the unknowns, the transmission ``|R_kk| / |a_k|`` and the residual, on
the loop tables whose system is square and on those one equation longer for an S-S link's idle spin (least
squares with a misfit), at their closed positions; and the fall-back where the chain's system is singular."""

from __future__ import annotations

import numpy as np
import pytest

from dualmech.core.kernel.closure_nb import make_work, residual_at
from dualmech.core.kernel.loop_engine import _by_value, wrench_spec
from dualmech.core.kernel.loop_nb import flatten, value_names
from dualmech.core.kernel.rates_nb import solve_rates
from dualmech.core.kernel.wrench_chain_nb import chain_solve
from dualmech.core.kernel.wrench_system_nb import first_effort
from dualmech.core.kernel.wrenches_nb import _householder_solve, joint_wrenches, make_wrench_work
from dualmech.models.case import load_case
from dualmech.models.linkages import linkage_case
from dualmech.models.loop.engine import analyze_loop, efforts_of
from dualmech.models.loop.presets import loop_table_of, slider_crank_start, slider_crank_table
from dualmech.models.slider_crank.analysis import analyze
from tests.tolerances import CHAIN_VS_QR


def _systems(name: str, off_axis: bool = False):
    """Per closed position (every second): the kernel's loop, wrench columns and scratch, evaluated there
    with its rates; ``name`` a bundled linkage or a slider-crank case (as a table); ``off_axis``: its first
    S-S link's centre of mass moved off the link's axis."""
    if name.startswith("thesis/"):
        case = load_case(name)
        mech = slider_crank_table(case)
        an = analyze_loop(mech, slider_crank_start(case, analyze(case).s4[0]))
    else:
        mech = loop_table_of(linkage_case(name))
        an = analyze_loop(mech)
    loop, n = an.loop, an.state.scalars.shape[0]
    fl, names = flatten(loop), value_names(loop)
    vals, vdot, vddot = (_by_value(names, d, n) for d in (an.drive.values, an.drive.rates, an.drive.accels))
    efforts, solved = efforts_of(mech, n)
    spec, given, labels = wrench_spec(fl, loop, mech.bodies, mech.gravity, efforts, solved, n)
    xs = np.concatenate([an.state.scalars, an.state.rotations.reshape(n, -1)], axis=1)
    w, ww = make_work(fl), make_wrench_work(len(loop.rows), len(labels), fl.screws.shape[0])
    if off_axis:  # the S-S link's centre of mass off the line of its balls: its spin equation has a misfit
        com = spec.com.copy()
        com[fl.gauges[0]] += np.array([0.0, 0.3, 0.2]) * (1.0 if fl.scale < 0 else vals[0, fl.scale])
        spec = spec._replace(com=com)
    for i in np.flatnonzero(an.status == "ok")[::2]:
        residual_at(fl, vals[i], xs[i], w)
        solve_rates(fl, vdot[i], vddot[i], w, 0.0)
        yield fl, spec, vals[i], xs[i], given[i], w, ww


@pytest.mark.parametrize(("name", "off_axis"), [
    ("7r", False), ("rscr", False), ("rsrc", False), ("rccc", False), ("rssr", False),
    ("thesis/a4-20-s1-3.5", False), ("rssr", True), ("thesis/a4-20-s1-3.5", True)])
def test_the_chain_solves_as_the_qr(name: str, off_axis: bool) -> None:
    """Square systems, and an S-S link's (RSSR, the slider crank's rod), whose spin equation holds with an
    axisymmetric link and leaves the least squares a misfit without (``off_axis``: checked to be no rounding);
    the chain's answers are the QR's either way, to rounding times the condition: 1/|t| near a dead centre
    (the slider crank's t = 4e-4: 6.8e-13 of the peak, 2.6e-15 times t)."""
    seen, misfit = 0, 0.0
    for fl, spec, vals, x, given, w, ww in _systems(name, off_axis):
        residual, transmission = joint_wrenches(fl, spec, vals, x, given, w, ww)
        assert ww.a.shape[0] == ww.a.shape[1] + fl.gauges.size
        chained = np.zeros(ww.x.size)
        assert not np.isnan(chain_solve(fl, spec.columns, first_effort(spec.columns), w.lines, w.axes, ww.a,
                                        ww.b, ww.points, ww.axes, 1.0 if fl.scale < 0 else vals[fl.scale],
                                        ww.chain, chained))  # the chain solved it, not the fall-back
        np.testing.assert_array_equal(chained, ww.x)
        qr_residual, qr_transmission = _householder_solve(ww.a, ww.b, spec.columns, ww.qr, ww.qb, ww.x)
        gain = max(1.0, 1.0 / qr_transmission)  # rounding times the condition, near a dead centre 1/|t|
        np.testing.assert_allclose(chained, ww.x, rtol=0, atol=CHAIN_VS_QR * gain * np.abs(ww.x).max())
        np.testing.assert_allclose(transmission, qr_transmission, rtol=CHAIN_VS_QR * gain, atol=0)
        np.testing.assert_allclose(residual, qr_residual, rtol=0, atol=CHAIN_VS_QR * gain)
        misfit = max(misfit, qr_residual)
        seen += 1
    assert seen >= 10
    assert misfit > 1e-6 if off_axis else misfit < 1e3 * CHAIN_VS_QR


def test_a_singular_chain_falls_back_to_the_qr() -> None:
    """Screws that cannot carry a wrench (all nil): the chain's system has a zero pivot, NaN, and
    ``joint_wrenches`` solves by QR instead."""
    fl, spec, vals, x, given, w, ww = next(_systems("rccc"))
    joint_wrenches(fl, spec, vals, x, given, w, ww)
    lines = np.zeros_like(w.lines)
    assert np.isnan(chain_solve(fl, spec.columns, 12, lines, w.axes, ww.a, ww.b, ww.points, ww.axes, 1.0,
                                ww.chain, np.zeros(ww.x.size)))
