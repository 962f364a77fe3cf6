"""Unit-independent verdicts: the same cases written in other length units give the same verdict on every
check.

Two cases of the thesis matrix (a4 = 30 in, S1 = 3.5 in; drive-torque and slider-load mode) are rewritten with
the length unit divided by ``s`` for ``s`` in 1e-6, 1e-3, 1, 1e3 (:func:`scaled_case`), solved by all four
engines, and judged with :func:`dualmech.validation.compare.compare_case` and the matrix's own tolerances.
Every engine must report the same status words at every scale, every check must pass at every scale, and
the in-house answers must be the unscaled ones in the new unit.

The crank-angle step (7 deg) is coarse to keep the test short, but it keeps the row at 119 deg, 0.0017 deg
from a dead centre of the torque case (transmission 2.9e-5), where the reactions carry a condition factor
of 3.4e4: there, before the judges' inverse dynamics were put in the case's own length scale, Pinocchio
differed from the in-house solver by 6.4e-8 of the reaction scale at s = 1e-6 (1.3e-11 at s = 1), MuJoCo by
7.9e-10.
"""

from __future__ import annotations

import copy
import importlib

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from dualmech.core.inertia import BodyInertia
from dualmech.core.status import RATES_GIVEN, Status
from dualmech.core.table import FORCE_COLUMNS, MOMENT_COLUMNS
from dualmech.models.case import case_from_dict
from dualmech.validation.compare import compare_case
from dualmech.validation.matrix import load_matrix
from tests.tolerances import UNIT_CHANGE

#: Length-unit factors: a length x is written x * s (s = 1e-6: inches -> micro-inches ... as a user would).
SCALES = (1e-6, 1e-3, 1.0, 1e3)
CASE_IDS = ("torque_a4=30_S1=3.5", "force_a4=30_S1=3.5")
ENGINES = {"dualmech": "dualmech.models.slider_crank.analysis", "pinocchio":
"dualmech.validation.judges.pinocchio_slider_crank.engine",
           "mujoco": "dualmech.validation.judges.mujoco_slider_crank.engine",
           "mujoco-sim": "dualmech.validation.judges.mujoco_slider_crank.sim"}
LIBRARY = {"pinocchio": "pinocchio", "mujoco": "mujoco", "mujoco-sim": "mujoco"}
ANGLES = {"start": 0.0, "stop": 360.0, "step": 7.0}

#: Powers of the length unit in each input key (mass and time units are kept).
_LENGTH_POWER = {
    ("geometry", "crank_length"): 1, ("geometry", "rod_length"): 1, ("geometry", "slider_offset"): 1,
    ("geometry", "crank_axial_shift"): 1, ("motion", "axial_amplitude"): 1,
    ("bodies", "crank_radius"): 1, ("bodies", "rod_radius"): 1, ("bodies", "slider_side"): 1,
    ("bodies", "density"): -3, ("bodies", "weight_density"): -2, ("bodies", "gravity_constant"): 1,
    ("loads", "drive_torque"): 2, ("loads", "slider_force"): 1, ("loads", "gravity"): 1,
}


def scaled_case(raw: dict, s: float) -> dict:
    """The case table ``raw`` with its length unit changed so that every length reads ``s`` times larger.

    The mass and time units are kept, so a mass (F·s²/L) is unchanged; a force (mass·L/s²) reads ``s``
    times larger, a moment ``s²``, a density (mass/L³) ``s⁻³``, a weight density (F/L³) ``s⁻²``, an
    acceleration (``gravity``, ``gravity_constant``) ``s``; angles, ``crank_rpm`` and ``crank_accel``
    (rad/s²) are unchanged.  Explicit body tables (``bodies.crank.mass`` ...) are not supported here.
    """
    out = copy.deepcopy(raw)
    for (table, key), power in _LENGTH_POWER.items():
        value = out.get(table, {}).get(key)
        if value is not None:
            out[table][key] = [v * s**power for v in value] if isinstance(value, list) else value * s**power
    assert not any(isinstance(v, dict) for v in out.get("bodies", {}).values()), "explicit bodies not scaled"
    out["motion"]["angles_deg"] = dict(ANGLES)
    out["name"] = f"{raw['name']}-x{s:g}"
    return out


@pytest.fixture(scope="module")
def runs():
    """{case id: (matrix case, {scale: {engine: ResultTable}})} for every engine available here."""
    solvers = {}
    for engine, module in ENGINES.items():
        if engine in LIBRARY:
            pytest.importorskip(LIBRARY[engine])
        solvers[engine] = importlib.import_module(module).solve_case
    matrix = load_matrix()
    cases = {mc.id: mc for mc in matrix.cases}
    out = {}
    for cid in CASE_IDS:
        mc = cases[cid]
        out[cid] = (mc, {s: {e: solve(case_from_dict(scaled_case(mc.raw, s))) for e, solve in solvers.items()}
                         for s in SCALES})
    return matrix, out


@pytest.mark.parametrize("cid", CASE_IDS)
def test_statuses_are_identical_at_every_scale(runs, cid):
    _, by_case = runs
    _, tables = by_case[cid]
    for engine in ENGINES:
        words = {s: np.asarray(tables[s][engine].status, dtype=str) for s in SCALES}
        for s in SCALES:
            assert_array_equal(words[s], words[1.0], err_msg=f"{engine} at scale {s:g}")
        assert np.isin(words[1.0], list(RATES_GIVEN)).all(), (engine, set(words[1.0]))


@pytest.mark.parametrize("cid", CASE_IDS)
def test_every_check_gives_the_same_verdict_at_every_scale(runs, cid):
    matrix, by_case = runs
    mc, tables = by_case[cid]
    verdicts = {}
    for s in SCALES:
        ref = tables[s][matrix.reference]
        for engine in matrix.judges:
            checks = compare_case(mc.id, mc.mode, ref, tables[s][engine], matrix.quantities,
                                  matrix.tolerances[engine], mc.expect)
            failed = [(c.quantity, f"{c.max_rel:.3g}", c.detail) for c in checks if not c.passed]
            assert not failed, (engine, f"scale {s:g}", failed[:3])
            verdicts[s, engine] = [(c.quantity, c.passed) for c in checks]
    for (s, engine), verdict in verdicts.items():
        assert verdict == verdicts[1.0, engine], (engine, s)


@pytest.mark.parametrize("cid", CASE_IDS)
def test_in_house_answers_change_unit_and_nothing_else(runs, cid):
    """The reference at scale s is the unscaled answer in the new unit (relative to each group's scale)."""
    _, by_case = runs
    _, tables = by_case[cid]
    base = tables[1.0]["dualmech"]
    ok = np.asarray(base.status, dtype=str) == Status.OK
    condition = np.abs(base["transmission"]) if cid.startswith("torque") else np.ones(len(base))
    groups = (("length", 1, ("S1", "S4")), ("velocity", 1, ("S4_dot",)), ("acceleration", 1, ("S4_ddot",)),
              ("force", 1, FORCE_COLUMNS), ("moment", 2, MOMENT_COLUMNS))  # one scale per unit group
    for s in SCALES:
        table = tables[s]["dualmech"]
        for group, power, columns in groups:
            weight = condition[ok] if group in ("force", "moment") else 1.0
            scale = max(np.max(np.abs(base[name][ok]) * weight) for name in columns)
            for name in columns:
                got, want = table[name][ok] / s**power, base[name][ok]
                assert_allclose(got * weight, want * weight, rtol=0, atol=UNIT_CHANGE * scale,
                                err_msg=f"{name} at scale {s:g}")
        for name in ("transmission", "closure_condition"):
            assert_allclose(table[name][ok], base[name][ok], rtol=0, atol=UNIT_CHANGE, err_msg=name)


@pytest.mark.parametrize("flaw", ["asymmetric", "negative", "triangle"])
def test_mass_property_checks_give_the_same_verdict_in_every_unit(flaw):
    """A flawed inertia tensor (flaw 1e-6 of its size) is refused whatever the length unit (inertia ~ s^2)."""
    rng = np.random.default_rng(11)
    moments = rng.uniform(1.0, 2.0, 3)
    base = np.diag(moments)
    if flaw == "asymmetric":
        base[0, 1] += 1e-6 * moments.max()
    elif flaw == "negative":
        base[2, 2] = -1e-6 * moments.max()
        base[0, 0] = base[1, 1] = moments.max()
    else:
        base = np.diag([1.0, 1.0, 2.0 + 1e-6])
    for s in SCALES:
        with pytest.raises(ValueError, match="inertia"):
            BodyInertia(1.0, np.zeros(3), base * s**2)
