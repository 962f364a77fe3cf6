"""The Exudyn judge on the slider crank (``validation/judges/presets/slider_crank.py``) against the in-house
engine, as the slider crank's gate compares them: the same status words, every compared column's difference
over its unit group's peak (with the gate's condition factor ``1/|t|`` in drive-torque mode) within
``EXUDYN_KINEMATICS`` and ``EXUDYN_REACTIONS``.  The joint variants: the thesis's ideal case in drive-torque
mode through its dead centre at 90 degrees; the spatial case with a revolute crank and a universal joint at
the slider, in slider-load mode; the spatial case with a sinusoidal ``S1`` (a cylindrical crank driven along
its axis too), in drive-torque mode; a case that does not assemble between two ranges, restarted past the
gap.  Short angle ranges: the judge integrates through them after a 90 degree run-in.
"""

from __future__ import annotations

import copy

import numpy as np
import pytest

from dualmech.core.table import REACTION_COLUMNS, ResultTable
from dualmech.models.case import Case, case_from_dict, load_case
from dualmech.validation.compare.differences import relative_differences
from dualmech.validation.engines import run_engine
from dualmech.validation.matrix.data import COMPARABLE
from dualmech.validation.tolerances import EXUDYN_KINEMATICS, EXUDYN_REACTIONS

pytest.importorskip("exudyn")

from dualmech.validation.judges.exudyn_loop.closure import CLOSURE_TOL  # noqa: E402
from dualmech.validation.judges.presets import slider_crank  # noqa: E402


def _case(preset: str, angles: tuple[float, float, float], loads: dict | None = None,
          **values: object) -> Case:
    """``preset`` at the crank angles ``(start, stop, step)`` (deg), each ``table__key`` of ``values`` set,
    its loads (besides gravity) ``loads`` when given."""
    raw = copy.deepcopy(load_case(preset).raw)
    raw["motion"]["angles_deg"] = dict(zip(("start", "stop", "step"), angles))
    for key, value in values.items():
        table, name = key.split("__")
        raw.setdefault(table, {})[name] = value
    if loads is not None:
        raw["loads"] = {"gravity": raw["loads"].get("gravity", [0.0, 0.0, 0.0]), **loads}
    return case_from_dict(raw)


CASES = {
    "dead-centre": _case("thesis/ideal", (70.0, 110.0, 2.0)),
    "universal": _case("thesis/a4-30-s1-3.5", (0.0, 60.0, 3.0), joints__crank="revolute",
                       joints__rod_slider="universal", loads={"slider_force": -100.0}),
    "sinusoidal-s1": _case("thesis/a4-30-s1-3.5", (0.0, 60.0, 3.0), motion__axial_amplitude=1.5,
                           motion__axial_cycles=2.0),
}
#: Assembled from 264 to 292 and from 428 to 456 degrees, a gap between.
GAP = _case("thesis/ideal", (264.0, 456.0, 4.0), geometry__slider_offset=45.0)


def disagreement(case: Case, mine: ResultTable, reference: ResultTable) -> dict[str, float]:
    """The largest difference of every compared column over its tolerance (module docstring); the status
    words must be the same."""
    np.testing.assert_array_equal(np.asarray(mine.status, str), np.asarray(reference.status, str))
    rel = relative_differences(reference, mine, case.loads.mode, COMPARABLE)
    out = {}
    for column, r in rel.items():
        bar = EXUDYN_REACTIONS if column in REACTION_COLUMNS else EXUDYN_KINEMATICS
        out[column] = float(np.nanmax(r, initial=0.0)) / bar.value
    return out


@pytest.fixture(scope="module")
def judged() -> dict[str, tuple[Case, ResultTable, ResultTable]]:
    return {}


def _judged(judged: dict, name: str) -> tuple[Case, ResultTable, ResultTable]:
    if name not in judged:
        case = GAP if name == "gap" else CASES[name]
        judged[name] = case, slider_crank.solve_case(case), run_engine("dualmech", case)
    return judged[name]


@pytest.mark.parametrize("name", list(CASES))
def test_the_judge_agrees_with_the_in_house_engine(name: str, judged: dict) -> None:
    case, mine, reference = _judged(judged, name)
    assert (np.asarray(reference.status, str) == "ok").sum() >= 10
    worst = disagreement(case, mine, reference)
    assert max(worst.values()) <= 1.0, {c: w for c, w in worst.items() if w > 1.0}
    np.testing.assert_allclose(mine["S1"], reference["S1"], rtol=0.0, atol=0.0)


def test_the_rows_past_a_gap_are_a_run_of_their_own(judged: dict) -> None:
    """One run from each row that follows rows that do not reach (``meta["restarts"]``), the gap's rows
    ``no_assembly`` and the message naming them, as the in-house engine's; the kinematics within the bar.
    (Not the reactions: the rows next to the gap, ``c = 0.14``, carry the judge's discretization error
    amplified as the pose swings toward the edge, and the planar case's ``j4_mz``, zero, is there 1.9e-6 of
    the moments' peak: docs/validation.md.)"""
    case, mine, reference = _judged(judged, "gap")
    worst = disagreement(case, mine, reference)
    assert max(w for c, w in worst.items() if c not in REACTION_COLUMNS) <= 1.0
    words = np.asarray(mine.status, str)
    starts = np.flatnonzero((words != "no_assembly") & np.r_[True, words[:-1] == "no_assembly"])
    assert starts.size == 2
    assert mine.meta["restarts"].tolist() == starts.tolist()
    assert mine.meta["messages"] == reference.meta["messages"]


def test_transmission_and_condition_are_its_own_pose(judged: dict) -> None:
    """``transmission`` ``z·((P2 - hub) x u) / a1`` and ``closure_condition`` ``|u·k4|`` by hand from the
    table's own ``S1``, ``S4`` (``P3 = F - S4 k4``); ``residual``: its closure within its tolerance (over
    the table's length, the rod's here)."""
    case, mine, _ = _judged(judged, "universal")
    g = case.geometry
    theta, s1 = np.radians(mine["theta1_deg"]), mine["S1"]
    hub = np.stack([0.0 * s1, 0.0 * s1, s1], 1)
    p2 = hub + g.crank_length * np.stack([np.cos(theta), np.sin(theta), 0.0 * s1], 1)
    p3 = g.foot - mine["S4"][:, None] * g.k4
    u = (p3 - p2) / np.linalg.norm(p3 - p2, axis=1)[:, None]
    np.testing.assert_allclose(mine["transmission"], np.cross(p2 - hub, u)[:, 2] / g.crank_length,
                               rtol=0.0, atol=1e-14)
    np.testing.assert_allclose(mine["closure_condition"], np.abs(u @ g.k4), rtol=0.0, atol=1e-14)
    assert (mine["residual"] <= 10 * CLOSURE_TOL).all()


def test_the_dead_centre_is_the_slider_cranks_word(judged: dict) -> None:
    case, mine, _ = _judged(judged, "dead-centre")
    assert case.loads.mode == "torque"
    assert (np.asarray(mine.status, str) == "dead_centre").sum() == 1
    assert mine.meta["restarts"].tolist() == [0] and mine.meta["messages"] == []


def test_a_wrench_on_the_wrong_side_is_caught(monkeypatch: pytest.MonkeyPatch, judged: dict) -> None:
    """Deliberate fault: joint 4's wrench read as the ground's on the slider (not negated)."""
    case, _, reference = _judged(judged, "universal")
    real = slider_crank._table

    def unturned(case, got, *args):
        got = {k: (-v if k.startswith("joint4_") else v) for k, v in got.items()}
        return real(case, got, *args)

    monkeypatch.setattr(slider_crank, "_table", unturned)
    worst = disagreement(case, slider_crank.solve_case(case), reference)
    failed = {c for c, w in worst.items() if w > 1.0}
    assert "slider_load" in failed and failed <= {f"j4_{k}{a}" for k in "fm" for a in "xyz"} | {"slider_load"}


def test_a_crude_start_on_the_other_branch_is_caught(monkeypatch: pytest.MonkeyPatch, judged: dict) -> None:
    """Deliberate fault: the crude slider a rod's length on the other side of the foot."""
    case, _, reference = _judged(judged, "dead-centre")
    real = slider_crank.crude_s4

    def other_side(case: Case, at: int) -> float:
        return real(case, at) - 2.0 * case.geometry.rod_length

    monkeypatch.setattr(slider_crank, "crude_s4", other_side)
    mine = slider_crank.solve_case(case)
    try:
        worst = max(disagreement(case, mine, reference).values())
    except AssertionError:  # other status words
        return
    assert worst > 1.0
