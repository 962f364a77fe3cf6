"""A table without ``start`` values: every engine searches its own first assembly, and all of them take the
one nearest the zero pose (``models/loop/start.py``), so they follow the same assembly.  Before that rule
each took the first pose its search closed: of 16 random tables of ``test_random_tables.py`` (seeds 0-2)
the Pinocchio and the MuJoCo judge each started on another assembly than the in-house engine in 5; the
first two tables here were among them (both judges).  In the third the MuJoCo judge's search closes another
assembly first (its distance 20.0 rad², the nearest's 7.9), so a judge that took the first would fail
here."""

from __future__ import annotations

import numpy as np
import pytest

from dualmech.models.loop.engine import analyze_loop
from dualmech.validation.judges.mujoco_loop.engine import solve_loop as mujoco_loop
from dualmech.validation.judges.pinocchio_loop.engine import solve_loop as pinocchio_loop
from tests.models.loop.test_random_tables import random_table

#: Angles of one assembly by two engines: both close to ~1e-14 of the table's size; a different assembly is
#: off by 1e-2 to pi.
SAME_ASSEMBLY = 1e-8


def _angles(table, mech) -> dict[str, np.ndarray]:
    out = {}
    for k, joint in enumerate(mech.joints):
        for c in ("theta", "eta"):
            name = f"{c}{k + 1}"
            if hasattr(table, "coordinate"):
                try:
                    out[name] = table.coordinate(k, c)[0]
                except (KeyError, ValueError):
                    continue
            elif name in table.columns:
                out[name] = table.columns[name]
    return out


@pytest.mark.parametrize("seed, topology", [(0, "RSUR"), (0, "RSCR"), (1, "RSUR")])
@pytest.mark.parametrize("judge", [pinocchio_loop, mujoco_loop], ids=["pinocchio", "mujoco"])
def test_every_engine_starts_on_the_assembly_nearest_zero(seed: int, topology: str, judge) -> None:
    mech = random_table(seed, topology)
    assert not any(j.start for j in mech.joints)
    ours, theirs = _angles(analyze_loop(mech), mech), _angles(judge(mech), mech)
    assert ours.keys() == theirs.keys() and ours
    for name, values in ours.items():
        diff = np.remainder(theirs[name] - values + np.pi, 2 * np.pi) - np.pi
        both = np.isfinite(diff)
        assert both.sum() >= len(values) // 2, name
        np.testing.assert_allclose(diff[both], 0.0, rtol=0, atol=SAME_ASSEMBLY, err_msg=name)
