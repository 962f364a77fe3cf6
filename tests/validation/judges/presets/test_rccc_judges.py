"""The RCCC judged by Pinocchio and rigid MuJoCo: both agree with the in-house engine on the bundled and
random cases, statuses row by row; deliberate faults are seen."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from dualmech.core.dual import Dual
from dualmech.core.reactions import momentum_rate
from dualmech.core.status import Status
from dualmech.models.linkages import read_linkage
from dualmech.models.linkages.rccc import SPEC
from dualmech.models.linkages.rccc_case import RcccCase, rccc_from_dict
from dualmech.validation.compare.tables import worst
from dualmech.validation.engines import get_engine
from tests import linkage_reactions
from tests.linkage_cases import random_rccc
from tests.linkage_oracles import analyze_rccc
from tests.linkage_oracles import rccc_to_table as to_table
from tests.tolerances import LINKAGE_JUDGE_KINEMATICS, LINKAGE_JUDGE_REACTIONS


def _bundled() -> RcccCase:
    return rccc_from_dict(read_linkage("rccc"))


def _judges():
    """The registry's rigid judges of an RCCC case (the generated judges of its joint table)."""
    pytest.importorskip("pinocchio")
    pytest.importorskip("mujoco")
    return {name: get_engine(name, "rccc") for name in ("pinocchio", "mujoco")}


def _ratios(case: RcccCase, judge: str) -> dict[str, float]:
    ours, theirs = to_table(analyze_rccc(case)), _judges()[judge](case)
    assert_array_equal(np.asarray(theirs.status, dtype=str), np.asarray(ours.status, dtype=str))
    assert (ours.status == Status.OK).any()
    kinematics = set(SPEC.kinematics)
    return {c: w / (LINKAGE_JUDGE_KINEMATICS.value if c in kinematics else LINKAGE_JUDGE_REACTIONS.value)
            for c, w in worst(ours, theirs, SPEC).items()}


@pytest.mark.parametrize("judge", ["pinocchio", "mujoco"])
@pytest.mark.parametrize("seed", [None, 1, 4, 7])
def test_judges_agree(judge: str, seed: int | None) -> None:
    """The bundled case and random ones (seeds 4 and 7 have no_assembly rows and rows near the edge)."""
    case = _bundled() if seed is None else rccc_from_dict(random_rccc(np.random.default_rng(seed)))
    bad = {c: r for c, r in _ratios(case, judge).items() if not r <= 1.0}
    assert not bad, f"columns over tolerance (ratio to it): {bad}"


def test_a_judge_with_the_wrong_twist_sign_fails() -> None:
    """Deliberate fault: the MuJoCo judge given the coupler's twist of the other sign."""
    case = _bundled()
    g = case.geometry
    flipped = replace(case, geometry=replace(g, alpha=(g.alpha[0], -g.alpha[1], g.alpha[2], g.alpha[3])))
    ours = to_table(analyze_rccc(case))
    theirs = _judges()["mujoco"](flipped)
    assert max(worst(ours, theirs, SPEC).values()) > 1e6 * LINKAGE_JUDGE_KINEMATICS.value


def test_a_dropped_gyroscopic_term_is_seen(monkeypatch: pytest.MonkeyPatch) -> None:
    """Deliberate fault: the in-house dynamics without omega x I omega; Pinocchio must see it."""
    def without_gyroscopic(body, motion):
        i_world = motion.rotation @ body.inertia @ np.swapaxes(motion.rotation, -1, -2)
        gyro = np.cross(motion.omega, np.einsum("nij,nj->ni", i_world, motion.omega))
        return momentum_rate(body, motion) - Dual(np.zeros_like(gyro), gyro)

    case = rccc_from_dict(random_rccc(np.random.default_rng(1)))
    monkeypatch.setattr(linkage_reactions, "momentum_rate", without_gyroscopic)
    ratios = _ratios(case, "pinocchio")
    assert max(ratios.values()) > 100.0 and all(ratios[c] <= 1.0 for c in SPEC.kinematics)


@pytest.mark.parametrize("seed", [14, 26])
def test_the_simulation_follows_a_fast_output(seed: int) -> None:
    """Random RCCCs whose joints turn 3.4 (seed 14) and 2.1 (seed 26) times as fast as their drives: MuJoCo's
    simulation steps one degree of the fastest joint and passes the gate (every column within the simulated
    judge's tolerances, statuses equal).  Seen failing before, at one degree of the drive: seed 14 by 19
    times its tolerance in joint 1's force, seed 26 at 1.00 in the output's acceleration."""
    from dualmech.validation.compare.tables import judge_checks

    pytest.importorskip("mujoco")
    case = rccc_from_dict(random_rccc(np.random.default_rng(seed)))
    checks, _ = judge_checks(str(seed), to_table(analyze_rccc(case)), get_engine("mujoco-sim", "rccc")(case),
                             SPEC)
    failed = {c.quantity: round(c.ratio, 3) for c in checks if not c.passed}
    assert not failed, failed
    assert max(c.ratio for c in checks if c.ratio == c.ratio) <= 0.5
