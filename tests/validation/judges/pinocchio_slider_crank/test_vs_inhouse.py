"""Pinocchio judge against the in-house solver: the done-when of issue 4.

Every bundled thesis case and seeded random geometries, both load modes,
gravity on and off.  Per case (``validation/tolerances.py``, Pinocchio section):

* statuses identical row by row;
* S4, S4_dot, S4_ddot, transmission on rows both engines assemble:
  ``|J - R| <= PINOCCHIO_KINEMATICS * max|R|``;
* every reaction column on rows both engines call ``ok``:
  ``|J - R| <= PINOCCHIO_REACTIONS * s_g * c_i`` with ``c_i = 1/|t_i|`` in drive-torque
  mode (else 1) and ``s_g`` the largest ``|R|/c`` over the force (moment) columns.
"""

import importlib.util

import numpy as np
import pytest

from dualmech.core.table import FORCE_COLUMNS, MOMENT_COLUMNS
from dualmech.models.case import load_case, preset_names, with_loads
from dualmech.validation.tolerances import PINOCCHIO_KINEMATICS, PINOCCHIO_REACTIONS
from tests.pinocchio_oracles import random_case

pytest.importorskip("pinocchio")
if importlib.util.find_spec("dualmech.models.slider_crank.analysis") is None:  # skip only if truly absent
    pytest.skip("the in-house engine dualmech.models.slider_crank.analysis is not there yet",
                allow_module_level=True)

from dualmech.models.slider_crank.analysis import solve_case as inhouse_solve  # noqa: E402
from dualmech.validation.judges.pinocchio_slider_crank.engine import solve_case as pinocchio_solve  # noqa: E402

GRAVITY = np.array([3.0, -50.0, -386.4])


def _cases():
    out = []
    for name in (n for n in preset_names() if n.startswith("thesis/")):
        base = load_case(name)
        for mode_case in (base, with_loads(base, drive_torque=None, slider_force=-250.0)):
            for g in (np.zeros(3), GRAVITY):
                out.append(with_loads(mode_case, gravity=g))
    for seed in range(6):
        rng = np.random.default_rng(400 + seed)
        reach = 0.7 if seed >= 4 else 1.3  # the last two pairs have arcs without assembly
        out += [random_case(rng, "torque", reach=reach), random_case(rng, "force", reach=reach)]
    return out


CASES = _cases()


def _relative_differences(case, ref, judge):
    """Worst relative difference per column, as defined in the module docstring."""
    assembled = np.isin(ref.status, ["ok", "dead_centre"])
    both_ok = ref.status == "ok"
    out = {}
    for col in ("S4", "S4_dot", "S4_ddot", "transmission"):
        scale = np.abs(ref[col][assembled]).max()
        out[col] = np.abs(judge[col][assembled] - ref[col][assembled]).max() / scale
    cond = 1.0 / np.abs(ref["transmission"]) if case.loads.mode == "torque" else np.ones(len(ref))
    for group in (FORCE_COLUMNS, MOMENT_COLUMNS):
        scale = max(np.abs(ref[c][both_ok] / cond[both_ok]).max() for c in group)
        for col in group:
            out[col] = (np.abs(judge[col][both_ok] - ref[col][both_ok]) / cond[both_ok]).max() / scale
    return out


@pytest.mark.parametrize("case", CASES, ids=[f"{i}-{c.name}-{c.loads.mode}" for i, c in enumerate(CASES)])
def test_pinocchio_agrees_with_the_inhouse_solver(case):
    ref, judge = inhouse_solve(case), pinocchio_solve(case)
    assert np.array_equal(ref.status, judge.status), [
        (float(t), r, j) for t, r, j in zip(ref["theta1_deg"], ref.status, judge.status) if r != j][:5]
    assert (ref.status == "ok").sum() > 0
    diffs = _relative_differences(case, ref, judge)
    kin = {c: d for c, d in diffs.items() if c in ("S4", "S4_dot", "S4_ddot", "transmission")}
    reactions = {c: d for c, d in diffs.items() if c not in kin}
    assert max(kin.values()) <= PINOCCHIO_KINEMATICS.value, kin
    assert max(reactions.values()) <= PINOCCHIO_REACTIONS.value, reactions


#: Single crank angles where the two engines once disagreed on the status (150-case random sweep): the
#: in-house solver said branch_jump / not_converged. Fixed by a second, branch-seeking estimate and by
#: starting DFP from the better of estimate and stalled Newton point; kept as regression probes.
STATUS_PROBES = [
    # first angle after an arc without assembly: a valid assembly on the conventions' branch exists
    ({"crank_length": 7.334849, "rod_length": 11.99893, "slider_offset": -4.969617,
      "slider_twist_deg": 150.666754, "crank_axial_shift": 4.836862}, 197.6588, "ok"),
    # deep inside an arc without assembly (a2^2 - distance^2 = -0.138 a2^2)
    ({"crank_length": 3.514155, "rod_length": 17.621966, "slider_offset": 21.540939,
      "slider_twist_deg": 311.44419, "crank_axial_shift": -0.119143}, 217.0466, "no_assembly"),
]


def _probe(geometry, theta):
    return load_case("a4-30-s1-3.5").with_values(
        {"geometry": geometry, "motion.angles_deg": {"start": theta, "stop": theta + 0.5, "step": 1.0}})


@pytest.mark.parametrize("geometry, theta, expected", STATUS_PROBES, ids=["after-gap", "inside-gap"])
def test_pinocchio_status_at_the_probes(geometry, theta, expected):
    from tests.oracles import assembly_margin

    case = _probe(geometry, theta)
    table = pinocchio_solve(case)
    assert table.status[0] == expected
    assert (assembly_margin(case, np.radians([theta]))[0] < 0) == (expected == "no_assembly")


@pytest.mark.parametrize("geometry, theta, expected", STATUS_PROBES, ids=["after-gap", "inside-gap"])
def test_inhouse_status_at_the_probes(geometry, theta, expected):
    assert inhouse_solve(_probe(geometry, theta)).status[0] == expected
