"""The in-house engine of the RSSR and the RCCC (the loop engine on their preset tables, restarted past gaps,
read back) against the closed-form oracle (``tests/linkage_oracles.py``: the closed-form start,
Newton at every row alone, Newton-Euler by SVD least squares): every column and status word, row by row,
on both branches, both RSSR load modes, cases with no-assembly gaps, and rows 1e-9 deg from an edge of
assembly and at a dead centre."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from dualmech.core.status import ASSEMBLED, Status, is_status
from dualmech.models.linkages import rccc, read_linkage, rssr
from dualmech.models.linkages.rccc_case import RcccCase, rccc_from_dict
from dualmech.models.linkages.rssr_case import RssrCase, rssr_from_dict
from dualmech.models.loop.preset_engine import solve_rccc, solve_rssr
from dualmech.models.tables import LinkageTable
from tests import linkage_oracles
from tests.linkage_cases import bundled, random_rccc, random_rssr
from tests.models.linkages.test_rssr import _at_dead_centre
from tests.models.linkages.test_rssr import _edge as _rssr_edge
from tests.tolerances import (
    LINKAGE_DYNAMICS_RESIDUAL,
    LOOP_CLOSURE,
    LOOP_EDGE_ROUNDING,
    LOOP_REACTIONS_ROUNDING,
    LOOP_VS_OWN_ENGINE,
    PRESET_AT_ASSEMBLY_LIMIT,
)


def _rssr(branch: int = 1, torque: float | None = None) -> RssrCase:
    data = bundled()
    data["mechanism"]["branch"] = branch
    if torque is not None:
        del data["loads"]["output_torque"]
        data["loads"]["drive_torque"] = torque
    return rssr_from_dict(data)


def _rccc(branch: int = 1) -> RcccCase:
    data = read_linkage("rccc")
    data["mechanism"]["branch"] = branch
    return rccc_from_dict(data)


#: Bundled cases on both branches and load modes; random ones with no-assembly gaps (RSSR 8, 11, 124; RCCC 4,
#: 7, 111: 111 restarts twice, next to assembly limits at |t| = 0.066) and one near a dead centre (RSSR 21 in
#: drive-torque mode, |t1| = 9.7e-5 at 175 deg).
CASES = {
    "rssr": lambda: _rssr(), "rssr-branch-1": lambda: _rssr(-1), "rssr-torque": lambda: _rssr(torque=3.0),
    "rccc": lambda: _rccc(), "rccc-branch-1": lambda: _rccc(-1),
    "rssr-8-torque": lambda: rssr_from_dict(random_rssr(np.random.default_rng(8), "torque")),
    "rssr-11": lambda: rssr_from_dict(random_rssr(np.random.default_rng(11))),
    "rssr-21-torque": lambda: rssr_from_dict(random_rssr(np.random.default_rng(21), "torque")),
    "rssr-124": lambda: rssr_from_dict(random_rssr(np.random.default_rng(124))),
    **{f"rccc-{seed}": (lambda seed=seed: rccc_from_dict(random_rccc(np.random.default_rng(seed), step=5.0)))
       for seed in (4, 7, 111)},
}


def _closed_form(case: RssrCase | RcccCase) -> LinkageTable:
    """The oracle: the closed-form pipeline's table (kept in ``models/linkages/`` for forward dynamics)."""
    if isinstance(case, RssrCase):
        return linkage_oracles.rssr_to_table(linkage_oracles.analyze_rssr(case))
    return linkage_oracles.rccc_to_table(linkage_oracles.analyze_rccc(case))


def _in_house(case: RssrCase | RcccCase) -> LinkageTable:
    return solve_rssr(case) if isinstance(case, RssrCase) else solve_rccc(case)


def assert_same_table(ours: LinkageTable, oracle: LinkageTable, case: RssrCase | RcccCase) -> None:
    """Status words identical row by row; every column NaN on the same rows; each column within
    LOOP_VS_OWN_ENGINE of its unit group's peak, or the rounding the conditioning of the row amplifies if
    larger, as for the loop engine against the slider crank's: next to an assembly limit LOOP_EDGE_ROUNDING
    / |t4|^3, for the reactions also LOOP_REACTIONS_ROUNDING / |t1| next to a dead centre; the pose of an
    ``assembly_limit`` row within PRESET_AT_ASSEMBLY_LIMIT of itself;
    the residuals rounding; the messages and branch the oracle's, an iteration count per row."""
    assert_array_equal(np.asarray(ours.status, dtype=str), np.asarray(oracle.status, dtype=str))
    assert list(ours.columns) == list(oracle.columns)
    for c in oracle.columns:
        assert_array_equal(np.isnan(ours[c]), np.isnan(oracle[c]), err_msg=c)
    spec = rssr.SPEC if isinstance(case, RssrCase) else rccc.SPEC
    t_out = np.abs(oracle["transmission_out"])
    limit = oracle.status == Status.ASSEMBLY_LIMIT.value
    t_in = np.abs(oracle["transmission_in"]) if "transmission_in" in oracle.columns else np.ones_like(t_out)
    with np.errstate(divide="ignore"):
        edge = LOOP_EDGE_ROUNDING / t_out**3
        rounding = np.maximum(LOOP_REACTIONS_ROUNDING / t_in, edge)
    compared = [c for c in (*spec.kinematics, *spec.forces, *spec.moments) if c != "dynamics_residual"]
    for c in compared:
        group = [d for d in compared if spec.unit_group(d) == spec.unit_group(c)]
        values = np.abs([oracle[d] for d in group])
        peak = np.nanmax(values) if np.isfinite(values).any() else 1.0  # a group no row gives: any scale
        rows = ~np.isnan(oracle[c]) & ~limit
        tol = np.maximum(LOOP_VS_OWN_ENGINE, (edge if c in spec.kinematics else rounding)[rows])
        assert_allclose((ours[c][rows] - oracle[c][rows]) / (tol * peak), 0.0, rtol=0, atol=1.0, err_msg=c)
        assert_allclose(ours[c][limit], oracle[c][limit], rtol=PRESET_AT_ASSEMBLY_LIMIT,
                        atol=PRESET_AT_ASSEMBLY_LIMIT, err_msg=c)
    closed = is_status(ours.status, *ASSEMBLED)
    assert np.all(ours["residual"][closed & ~limit] <= LOOP_CLOSURE)
    assert np.all(ours["residual"][limit] <= rssr.LIMIT_CLOSURE.value)
    ok = ours.status == Status.OK.value
    assert np.all(ours["dynamics_residual"][ok] <= LINKAGE_DYNAMICS_RESIDUAL.value)
    assert ours.meta.keys() == oracle.meta.keys()
    assert ours.meta["messages"] == oracle.meta["messages"] and ours.meta["branch"] == oracle.meta["branch"]
    assert ours.meta["iterations"].shape == (len(ours),)


@pytest.mark.parametrize("name", CASES)
def test_the_in_house_table_is_the_closed_forms(name: str) -> None:
    case = CASES[name]()
    ours = _in_house(case)
    assert_same_table(ours, _closed_form(case), case)
    if name.startswith(("rssr-8", "rssr-11", "rssr-124", "rccc-4", "rccc-7", "rccc-111")):
        gap = ours.status == Status.NO_ASSEMBLY.value
        assert (~gap & np.r_[False, gap[:-1]]).any()  # rows that assemble after a gap: a restart there


def _rccc_edge(case: RcccCase) -> tuple[float, float]:
    """Crank angles (deg) 1e-9 deg inside and outside an edge of the RCCC's spherical part."""
    from scipy.optimize import brentq

    grid = _closed_form(case)
    missing = grid.status == Status.NO_ASSEMBLY.value
    k = int(np.flatnonzero(np.diff(missing.astype(int)))[0])
    deg = grid["theta1_deg"]

    def reach(d: float) -> float:
        return float(rccc.spherical_estimate(case.geometry, np.radians([d]), case.branch)[1][0] - 1.0)

    edge = brentq(reach, deg[k], deg[k + 1], xtol=1e-13)
    toward = -1.0 if reach(deg[k]) < 0 else 1.0
    return edge + toward * 1e-9, edge - toward * 1e-9


def _at(case, degrees: list[float]):
    return replace(case, motion=replace(case.motion, angles_deg=np.asarray(degrees, dtype=float)))


@pytest.mark.parametrize("kind", ["rssr", "rccc"])
def test_rows_next_to_an_edge_of_assembly(kind: str) -> None:
    """1e-9 deg inside an edge: ``assembly_limit`` (pose given, rates not), outside: ``no_assembly``, as the
    closed form says; and the two rows in the other order (a run that starts outside the edge)."""
    if kind == "rssr":
        case = rssr_from_dict(random_rssr(np.random.default_rng(11)))
        inside, outside = _rssr_edge(case)
    else:
        case = rccc_from_dict(random_rccc(np.random.default_rng(4)))
        inside, outside = _rccc_edge(case)
    for angles in ([inside, outside], [outside, inside]):
        near = _at(case, angles)
        ours = _in_house(near)
        assert sorted(ours.status) == [Status.ASSEMBLY_LIMIT.value, Status.NO_ASSEMBLY.value]
        assert_same_table(ours, _closed_form(near), near)


def test_a_dead_centre_in_drive_torque_mode() -> None:
    """At the crank angle where ``t1`` changes sign: ``dead_centre`` (kinematics given, reactions not), 5 deg
    on ``ok``; in output-torque mode both ``ok``: the closed form's words and numbers."""
    case = rssr_from_dict(random_rssr(np.random.default_rng(3), "torque"))
    deg = _at_dead_centre(case)
    at = _at(case, [deg, deg + 5.0])
    ours = _in_house(at)
    assert list(ours.status) == [Status.DEAD_CENTRE.value, Status.OK.value]
    assert_same_table(ours, _closed_form(at), at)
    output_mode = replace(at, drive_torque=None, output_torque=1.0)
    assert list(_in_house(output_mode).status) == [Status.OK.value, Status.OK.value]
    assert_same_table(_in_house(output_mode), _closed_form(output_mode), output_mode)
