"""The closed-form RCCC pipeline (Yang 1971; the forward dynamics' analysis and the oracle of the in-house
engine, ``tests/models/loop/test_preset_engine.py``): the dual-number Newton finds the slides from the
spherical estimate, rates match finite differences, the reactions balance power, statuses are honest (its
judges: ``tests/validation/judges/presets/test_rccc_judges.py``)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.optimize import brentq

from dualmech.core.loop import LoopState
from dualmech.core.status import Status
from dualmech.models.inputs import CaseError
from dualmech.models.linkages import read_linkage, solve_linkage
from dualmech.models.linkages.rccc import SPEC, estimate, spherical_estimate
from dualmech.models.linkages.rccc_case import RcccCase, rccc_from_dict
from tests.linkage_cases import random_rccc
from tests.linkage_oracles import analyze_rccc
from tests.linkage_oracles import rccc_to_table as to_table
from tests.tolerances import (
    LINKAGE_CLOSED_FORM,
    LINKAGE_FINITE_DIFFERENCE,
    LINKAGE_POWER_BALANCE,
)


def _bundled() -> RcccCase:
    return rccc_from_dict(read_linkage("rccc"))


def _at(case: RcccCase, degrees: np.ndarray) -> RcccCase:
    return replace(case, motion=replace(case.motion, angles_deg=np.asarray(degrees, dtype=float)))


@pytest.mark.parametrize("key, value, words", [
    ("coupler_twist_deg", 180.0, ["geometry.coupler_twist_deg", "180.0", "parallel", "skew axes"]),
    ("output_link", "0.2", ["geometry.output_link", "'0.2'", "length"]),
    ("crank_length", 1.0, ["geometry.crank_length", "unknown key", "input_link"]),
])
def test_bad_input_is_one_line(key: str, value: object, words: list[str]) -> None:
    data = read_linkage("rccc")
    data["geometry"][key] = value
    with pytest.raises(CaseError) as err:
        rccc_from_dict(data)
    assert "\n" not in str(err.value) and all(w in str(err.value) for w in words), str(err.value)


def test_newton_finds_the_slides_and_corrects_the_angles() -> None:
    """From the spherical estimate (slides 0) one dual Newton step finds the slides (the dual part is linear);
    from angles 0.1-0.2 rad off, Newton (not the estimate) lands on the same pose."""
    rng = np.random.default_rng(4)
    case = _bundled()
    exact = analyze_rccc(case)
    assert (exact.status == Status.OK).all() and (np.abs(exact.q[:, 5]) > 0.1).all()
    theta = exact.crank.theta
    z3, _ = spherical_estimate(case.geometry, theta, case.branch)
    start = estimate(case.geometry, theta, z3).scalars
    error = rng.uniform(0.1, 0.2, (theta.size, 3)) * rng.choice([-1.0, 1.0], (theta.size, 3))
    start[:, [0, 2, 4]] += error
    moved = analyze_rccc(case, LoopState(start, np.zeros((theta.size, 0, 3, 3))))
    assert (moved.iterations >= 3).all() and (moved.status == Status.OK).all()
    wrapped = moved.q - exact.q
    wrapped[:, [0, 2, 4]] = np.mod(wrapped[:, [0, 2, 4]] + math.pi, 2 * math.pi) - math.pi
    assert_allclose(wrapped, 0.0, rtol=0, atol=LINKAGE_CLOSED_FORM.value)


def test_rates_match_finite_differences() -> None:
    case = _bundled()
    deg = case.motion.angles_deg
    h = 1e-4
    runs = [analyze_rccc(_at(case, deg + math.degrees(k * h))) for k in (-1, 0, 1)]
    an = runs[1]
    w, wd = an.crank.theta_dot, an.crank.theta_ddot
    for col, wrap in ((4, True), (5, False)):
        f = [r.q[:, col] for r in runs]
        d = (lambda x: np.mod(x + math.pi, 2 * math.pi) - math.pi) if wrap else (lambda x: x)
        d1, d2 = d(f[2] - f[0]) / (2 * h), (d(f[2] - f[1]) - d(f[1] - f[0])) / h**2
        for got, want in ((an.q_dot[:, col], d1 * w), (an.q_ddot[:, col], d2 * w**2 + d1 * wd)):
            tol = LINKAGE_FINITE_DIFFERENCE.value
            assert_allclose(got, want, rtol=tol, atol=tol * np.abs(want).max())


def test_reactions_balance_power() -> None:
    """Drive power + output power (link 3 turns at -theta4_dot about z4) + weight power = dT/dt: the
    cylinders' zero axial force and moment make every joint ideal."""
    an = analyze_rccc(rccc_from_dict(random_rccc(np.random.default_rng(1))))
    assert (an.status == Status.OK).all()
    r = an.reactions
    alpha41 = an.case.geometry.alpha[3]
    z4 = np.array([0.0, math.sin(alpha41), math.cos(alpha41)])  # the ground's axis of joint 4
    terms = [r.moment["j1"][:, 2] * an.crank.theta_dot,
             -(r.moment["j4"] @ z4) * an.q_dot[:, 4]]
    for body, m in zip(an.case.bodies, an.motions):
        i_world = m.rotation @ body.inertia @ np.swapaxes(m.rotation, 1, 2)
        terms += [body.mass * m.com_vel @ an.case.gravity,
                  -body.mass * np.einsum("ni,ni->n", m.com_vel, m.com_acc)
                  - np.einsum("ni,nij,nj->n", m.omega, i_world, m.omega_dot)]
    residual = np.sum(terms, axis=0) / np.abs(np.stack(terms)).max(axis=0)
    assert_allclose(residual, 0.0, rtol=0, atol=LINKAGE_POWER_BALANCE.value)


def test_edges_of_assembly_and_branches() -> None:
    """1e-9 deg inside the edge of the spherical part: assembly_limit (pose given, rates not); outside:
    no_assembly; the other branch's estimate: branch_jump."""
    case = rccc_from_dict(random_rccc(np.random.default_rng(4)))
    table = to_table(analyze_rccc(case))
    missing = table.status == Status.NO_ASSEMBLY
    assert 0 < missing.sum() < missing.size
    assert table.meta["messages"][0].startswith("no_assembly: the axes' cones about z2 and z4 do not meet at")
    k = int(np.flatnonzero(np.diff(missing.astype(int)))[0])
    deg = table["theta1_deg"]

    def reach(d: float) -> float:
        return float(spherical_estimate(case.geometry, np.radians([d]), case.branch)[1][0] - 1.0)

    edge = brentq(reach, deg[k], deg[k + 1], xtol=1e-13)
    toward = -1.0 if reach(deg[k]) < 0 else 1.0
    near = to_table(analyze_rccc(_at(case, [edge + toward * 1e-9, edge - toward * 1e-9])))
    assert list(near.status) == [Status.ASSEMBLY_LIMIT, Status.NO_ASSEMBLY]
    assert np.isfinite(near["theta4_deg"][0]) and np.isnan(near["theta4_dot"][0])
    bundled = _bundled()
    theta = bundled.motion.state(0.0).theta
    other = estimate(bundled.geometry, theta, spherical_estimate(bundled.geometry, theta, -bundled.branch)[0])
    assert (analyze_rccc(bundled, other).status == Status.BRANCH_JUMP).all()


def test_solve_linkage_reads_the_bundled_rccc() -> None:
    table = solve_linkage("rccc")
    assert table.columns.keys() == set(SPEC.columns) and (table.status == Status.OK).all()
