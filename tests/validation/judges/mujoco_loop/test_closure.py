"""The MuJoCo loop judge's closure: a descent that creeps to a non-zero gap is no assembly, at once.

Past an assembly limit, Levenberg-Marquardt creeps to the least-squares minimum of the gap, which is not
zero; without :data:`~dualmech.validation.judges.mujoco_loop.closure.CREEP` each random try of a branch
search ran its :data:`~dualmech.validation.judges.mujoco_loop.closure.DESCENT_ITER` steps to say
``not_converged``.  A random RCCC whose drive crosses a gap in assembly is the case.
"""

from __future__ import annotations

import numpy as np
import pytest

from dualmech.core.status import Status
from dualmech.models.linkages.rccc_case import rccc_from_dict
from dualmech.models.linkages.rssr import assembles
from tests.linkage_cases import random_rccc

pytest.importorskip("mujoco")

from dualmech.models.loop.presets import rccc_table  # noqa: E402
from dualmech.validation.judges.mujoco_loop import closure  # noqa: E402
from dualmech.validation.judges.mujoco_loop.engine import drive_values  # noqa: E402
from dualmech.validation.judges.presets.starts import rccc_reach  # noqa: E402

TRIES = 8
#: The random RCCC whose drive crosses a gap in assembly (seeded).
CASE = rccc_from_dict(random_rccc(np.random.default_rng(7), step=10.0))


def _random_tries(k: int) -> list[tuple[str, int, float]]:
    """:func:`~.closure.close` from :data:`TRIES` random poses (seeded) at drive position ``k`` of
    :data:`CASE`."""
    mechanism = rccc_table(CASE)
    lp, rng = closure.build(mechanism), np.random.default_rng(0)
    out = []
    for _ in range(TRIES):
        closure.scatter(lp, rng)
        closure.prescribe(lp, drive_values(mechanism, k)[0])
        out.append(closure.close(lp))
    return out


def _positions() -> tuple[int, int]:
    """A drive position of :data:`CASE` where it assembles and one where it does not (the cones miss)."""
    ok = assembles(rccc_reach(CASE, np.radians(CASE.motion.angles_deg)))
    assert ok.any() and not ok.all()
    return int(np.flatnonzero(ok)[0]), int(np.flatnonzero(~ok)[0])


def test_a_descent_past_the_assembly_limit_is_no_assembly_once_it_creeps() -> None:
    _, gap = _positions()
    tries = _random_tries(gap)
    assert {outcome for outcome, _, _ in tries} == {Status.NO_ASSEMBLY.value}
    bound = closure.MAX_ITER + 3 * closure.CREEP_ITER
    assert max(iterations for _, iterations, _ in tries) <= bound  # not DESCENT_ITER (300) of creeping


def test_the_creep_rule_cuts_no_descent_that_closes(monkeypatch: pytest.MonkeyPatch) -> None:
    """At a position that assembles, the random tries end the same with the rule as without it."""
    assembled, _ = _positions()
    with_rule = _random_tries(assembled)
    monkeypatch.setattr(closure, "CREEP_ITER", closure.DESCENT_ITER + 1)
    without = _random_tries(assembled)
    assert with_rule == without
    assert Status.OK.value in {outcome for outcome, _, _ in with_rule}
