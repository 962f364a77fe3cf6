"""The square Newton-Euler systems solved along the chain (:mod:`dualmech.core.kernel.wrench_chain_nb`)
against the Householder QR of the whole system (:func:`dualmech.core.kernel.wrenches_nb._householder_solve`,
itself held to numpy's in ``test_wrenches.py``): the unknowns and the transmission ``|R_kk| / |a_k|``, on the
loop tables whose system is square, at their closed positions; and the fall-back where the chain's system is
singular."""

from __future__ import annotations

import numpy as np
import pytest

from dualmech.core.kernel.closure_nb import make_work, residual_at
from dualmech.core.kernel.loop_engine import _by_value, wrench_spec
from dualmech.core.kernel.loop_nb import flatten, value_names
from dualmech.core.kernel.rates_nb import solve_rates
from dualmech.core.kernel.wrench_chain_nb import chain_solve
from dualmech.core.kernel.wrenches_nb import _householder_solve, joint_wrenches, make_wrench_work
from dualmech.models.linkages import linkage_case
from dualmech.models.loop.engine import analyze_loop, efforts_of
from dualmech.models.loop.presets import loop_table_of
from tests.tolerances import CHAIN_VS_QR


def _systems(name: str):
    """Per closed position (every second): the kernel's loop, wrench columns and scratch, evaluated there
    with its rates."""
    mech = loop_table_of(linkage_case(name))
    an = analyze_loop(mech)
    loop, n = an.loop, an.state.scalars.shape[0]
    fl, names = flatten(loop), value_names(loop)
    vals, vdot, vddot = (_by_value(names, d, n) for d in (an.drive.values, an.drive.rates, an.drive.accels))
    efforts, solved = efforts_of(mech, n)
    spec, given, labels = wrench_spec(fl, loop, mech.bodies, mech.gravity, efforts, solved, n)
    xs = np.concatenate([an.state.scalars, an.state.rotations.reshape(n, -1)], axis=1)
    w, ww = make_work(fl), make_wrench_work(len(loop.rows), len(labels), fl.screws.shape[0])
    for i in np.flatnonzero(an.status == "ok")[::2]:
        residual_at(fl, vals[i], xs[i], w)
        solve_rates(fl, vdot[i], vddot[i], w, 0.0)
        yield fl, spec, vals[i], xs[i], given[i], w, ww


@pytest.mark.parametrize("name", ["7r", "rscr", "rsrc", "rccc"])
def test_the_chain_solves_a_square_system_as_the_qr(name: str) -> None:
    seen = 0
    for fl, spec, vals, x, given, w, ww in _systems(name):
        _, transmission = joint_wrenches(fl, spec, vals, x, given, w, ww)
        assert ww.a.shape[0] == ww.a.shape[1]
        chained = ww.x.copy()
        _, qr_transmission = _householder_solve(ww.a, ww.b, spec.columns, ww.qr, ww.qb, ww.x)
        np.testing.assert_allclose(chained, ww.x, rtol=0, atol=CHAIN_VS_QR * np.abs(ww.x).max())
        np.testing.assert_allclose(transmission, qr_transmission, rtol=CHAIN_VS_QR, atol=0)
        seen += 1
    assert seen >= 10


def test_a_singular_chain_falls_back_to_the_qr() -> None:
    """Screws that cannot carry a wrench (all nil): the chain's system has a zero pivot, NaN, and
    ``joint_wrenches`` solves by QR instead."""
    fl, spec, vals, x, given, w, ww = next(_systems("rccc"))
    joint_wrenches(fl, spec, vals, x, given, w, ww)
    lines = np.zeros_like(w.lines)
    assert np.isnan(chain_solve(fl.screws, spec.columns, 12, lines, ww.a, ww.b, ww.points, ww.axes, 1.0,
                                ww.chain, np.zeros(ww.x.size)))
