"""The RSSR's and RCCC's outputs no other test compared with an oracle: the in-house table's crank angles,
branch, iterations and messages, every rigid engine's closure and Newton-Euler residuals (against each other
and the table's own pose), and MuJoCo's simulated table against the in-house engine at its states (the
inventory of every engine's outputs is ``tests/test_outputs_have_oracles.py``)."""

from __future__ import annotations

import re

import numpy as np
import pytest
from numpy.testing import assert_allclose

from dualmech.models.linkages import linkage_case, rccc, rssr, solve_linkage
from dualmech.models.linkages.forward_dynamics import MECHANISMS
from dualmech.validation.engines import solve_linkage as solve_linkage_by
from dualmech.validation.linkages.gate import judge_tolerances, relative_differences
from dualmech.validation.tolerances import SIM_STROKE
from tests.tolerances import LINKAGE_DYNAMICS_RESIDUAL, ROW_SPACING, S4_VS_CLOSED_FORM


@pytest.mark.parametrize("kind", ["rssr", "rccc"])
def test_linkage_meta(kind: str) -> None:
    """``theta1_deg`` the case's angles; ``branch`` the case's; ``residual`` bounds the loop gap of the
    table's own pose (the RSSR: ``|P3 - P2| - a2``) and is round-off; ``iterations`` per row: none for the
    RSSR, whose start is its exact closed form, one for the RCCC, whose spherical start is corrected once on
    the bundled case; ``messages`` name the no_assembly rows, if any."""
    case = linkage_case(kind)
    table = solve_linkage(kind)
    assert_allclose(table["theta1_deg"], case.motion.angles_deg, rtol=0, atol=1e-12)
    assert table.meta["branch"] == case.branch
    assembled = table.status != "no_assembly"
    assert np.nanmax(table["residual"][assembled]) <= S4_VS_CLOSED_FORM
    iterations = table.meta["iterations"]  # the RSSR starts at its closed form: no Newton step is needed
    assert iterations.shape == (len(table),) and np.all(iterations[assembled] == (0 if kind == "rssr" else 1))
    assert bool(table.meta["messages"]) == (not assembled.all())
    if kind == "rssr":
        assert np.all(_rssr_gap(case, table)[assembled] <= table["residual"][assembled] + S4_VS_CLOSED_FORM)

@pytest.mark.parametrize("kind", ["rssr", "rccc"])
def test_linkage_residuals_of_every_rigid_engine(kind: str) -> None:
    """Each rigid engine's ``dynamics_residual`` (its Newton-Euler least squares' relative residual) is
    round-off, as the other engines' are on the same rows (another engine: a report that read 0.45 where the
    others read 1e-15, the slider crank's defect of issue 30, fails); ``residual`` (the closure gap over the
    length scale) is round-off for all of them; ``theta1_deg`` the case's angles.  The RSSR's ``residual``
    also bounds the loop gap of each table's own pose, ``| |P3 - P2| - a2 | / a2``."""
    case = linkage_case(kind)
    tables = {engine: solve_linkage_by(kind, engine) for engine in ("dualmech", "pinocchio", "mujoco")}
    reference = tables["dualmech"]["dynamics_residual"]
    for engine, table in tables.items():
        assert (table.status == "ok").all(), engine
        assert_allclose(table["theta1_deg"], case.motion.angles_deg, rtol=0, atol=1e-12, err_msg=engine)
        assert_allclose(table["dynamics_residual"], reference, rtol=0, atol=LINKAGE_DYNAMICS_RESIDUAL.value,
                        err_msg=engine)
        assert np.max(table["residual"]) <= S4_VS_CLOSED_FORM, engine
        if kind == "rssr":
            gap = _rssr_gap(case, table)
            assert np.all(gap <= table["residual"] + S4_VS_CLOSED_FORM), engine


def _rssr_gap(case, table) -> np.ndarray:
    """``| |P3 - P2| - a2 | / a2`` of an RSSR table's own pose: ``P2 = (a1 cos theta1, a1 sin theta1, s1)``,
    ``P3 = Q4 + a3 G4 (cos phi4, sin phi4, 0)`` (``docs/conventions.md``, "RSSR"), ``(n,)``."""
    g = case.geometry
    theta, phi = np.radians(table["theta1_deg"]), np.radians(table["phi4_deg"])
    p2 = np.stack([g.a1 * np.cos(theta), g.a1 * np.sin(theta), np.full_like(theta, g.s1)], 1)
    p3 = g.foot + g.a3 * np.stack([np.cos(phi), np.sin(phi), 0 * phi], 1) @ g.ground_rotation().T
    return np.abs(np.linalg.norm(p3 - p2, axis=1) - g.a2) / g.a2


@pytest.mark.parametrize("kind, spec", [("rssr", rssr.SPEC), ("rccc", rccc.SPEC)])
def test_linkage_simulation_tables(kind: str, spec) -> None:
    """MuJoCo's simulation of a linkage (its table at the simulated input states ``meta["crank"]``): every
    column it gives (``meta["gives"]``) against the in-house engine at those states within the simulated
    judge's tolerances, the same status words, NaN in every column it does not give; ``theta1_deg`` the
    states' angles; ``residual`` (its soft loop's gap) within the simulation's ``SIM_STROKE`` and bounding
    the RSSR's pose gap; the RCCC's ``dynamics_residual`` round-off as the in-house one; ``messages``: the
    time between rows, from the states' angles and rates, is the stated steps times the stated step."""
    case = linkage_case(kind)
    table = solve_linkage_by(kind, "mujoco-sim")
    crank, gives = table.meta["crank"], table.meta["gives"]
    mech = MECHANISMS[kind]
    reference = mech.table(mech.analyze(case, crank))
    np.testing.assert_array_equal(table.status, reference.status)
    compared = tuple(c for c in (*spec.kinematics, *spec.forces, *spec.moments) if c in gives)
    assert set(gives) == set(compared)
    tolerances = judge_tolerances("mujoco-sim")
    for c, r in relative_differences(reference, table, spec, compared).items():
        group = "kinematics" if c in spec.kinematics else "reactions"
        assert np.max(r) <= tolerances[group].value, (c, float(np.max(r)))
    diagnostics = ("theta1_deg", "residual", "dynamics_residual")
    assert all(np.isnan(table[c]).all() for c in spec.columns if c not in gives and c not in diagnostics)
    assert_allclose(table["theta1_deg"], np.degrees(crank.theta), rtol=1e-15)
    assert np.max(table["residual"]) <= SIM_STROKE.value
    if kind == "rssr":
        assert np.all(_rssr_gap(case, table) <= table["residual"] + S4_VS_CLOSED_FORM)
    else:
        assert_allclose(table["dynamics_residual"], reference["dynamics_residual"], rtol=0,
                        atol=LINKAGE_DYNAMICS_RESIDUAL.value)
    (message,) = table.meta["messages"]
    found = re.fullmatch(r"simulated (\S+) s at dt = (\S+) s, a row every (\d+) steps, .*", message)
    duration, dt, steps = float(found[1]), float(found[2]), int(found[3])
    between = 2 * np.diff(crank.theta) / (crank.theta_dot[1:] + crank.theta_dot[:-1])
    assert_allclose(between, steps * dt, rtol=ROW_SPACING)
    assert len(table) * steps * dt <= duration
