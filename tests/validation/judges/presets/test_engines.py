"""The Exudyn judge on the RSSR and RCCC (``validation/judges/presets/engines.py``): each case through its
joint table from the crude starts of ``starts.py``, each probed by the judge's own closure alone
(``exudyn_loop.table.close_table``), read back as the mechanism's table; against the in-house engine as the
linkages' gate compares them (``worst``: every column over its unit group's peak), within
``EXUDYN_KINEMATICS`` and ``EXUDYN_REACTIONS``."""

from __future__ import annotations

import numpy as np
import pytest

from dualmech.models.linkages import linkage_case, rccc, read_linkage, rssr
from dualmech.models.tables import LinkageTable
from dualmech.validation.compare.tables import worst
from dualmech.validation.engines import get_engine, run_engine
from dualmech.validation.judges.exudyn_loop.closure import CLOSURE_TOL
from dualmech.validation.tolerances import EXUDYN_KINEMATICS, EXUDYN_REACTIONS
from tests.linkage_cases import random_rssr

pytest.importorskip("exudyn")

from dualmech.validation.judges.presets import run  # noqa: E402


def _every(name: str, step: float):
    """The bundled case ``name`` every ``step`` degrees of a turn."""
    data = read_linkage(name)
    data["motion"]["angles_deg"] = {"start": 0.0, "stop": 360.0, "step": step}
    return linkage_case(data)


def _agrees(kind: str, case, table: LinkageTable) -> None:
    ours = run_engine("dualmech", case)
    np.testing.assert_array_equal(np.asarray(table.status, str), np.asarray(ours.status, str))
    spec = rssr.SPEC if kind == "rssr" else rccc.SPEC
    for column, w in worst(ours, table, spec).items():
        bar = EXUDYN_KINEMATICS if column in spec.kinematics else EXUDYN_REACTIONS
        assert w <= bar.value, f"{column}: {w:.3g} over {bar.value:.3g}"


@pytest.mark.parametrize("kind", ["rssr", "rccc"])
def test_the_exudyn_judge_agrees_with_the_in_house_engine(kind: str) -> None:
    """One run from the first row's first crude start answers every row; ``dynamics_residual`` is not
    given (NaN: no least squares), the judge counts no iterations, its closure closes (``residual`` within
    its tolerance) at the case's angles."""
    case = _every(kind, 20.0)
    table = get_engine("exudyn", kind)(case)
    _agrees(kind, case, table)
    np.testing.assert_allclose(table["theta1_deg"], case.motion.angles_deg, rtol=0.0, atol=1e-12)
    assert (table["residual"] <= CLOSURE_TOL).all()
    assert table.engine == "exudyn" and table.meta["restarts"].tolist() == [0]
    assert "iterations" not in table.meta and np.isnan(table["dynamics_residual"]).all()


def test_a_gap_in_assembly_is_crossed_on_the_branch() -> None:
    """A random RSSR that does not assemble over a range inside its turn: a run restarts past the gap."""
    case = linkage_case(random_rssr(np.random.default_rng(11), "output", step=10.0))
    table = get_engine("exudyn", "rssr")(case)
    gap = np.asarray(table.status, str) == "no_assembly"
    assert (~gap & np.r_[False, gap[:-1]]).any() and len(table.meta["restarts"]) >= 2
    _agrees("rssr", case, table)


def test_a_probe_read_as_a_full_table_is_seen(monkeypatch: pytest.MonkeyPatch) -> None:
    """Deliberate fault: the closure's one-row table read back as if it gave rates and reactions: its rows
    are ``not_finite``, no crude start is taken, and no row is answered."""
    real = run.crude_start
    monkeypatch.setattr(run, "crude_start", lambda case, mechanism, k, judge, pose_only=False:
                        real(case, mechanism, k, judge))
    table = get_engine("exudyn", "rssr")(_every("rssr", 60.0))
    assert table.meta["restarts"].tolist() == []
    assert set(np.asarray(table.status, str)) == {"not_finite"}
