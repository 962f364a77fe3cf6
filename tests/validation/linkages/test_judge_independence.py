"""The linkage judges are independent of the in-house solver: their starts are their own.

With every in-house start function (the RSSR's ``closed_form_phi`` and ``estimate``, the RCCC's
``spherical_estimate`` and ``estimate``, in their modules and wherever imported) returning an answer
1 rad off, the judges' tables are bit for bit the same while the in-house solver's change; a judge seeded
with the in-house start (the old design) is seen.  The crude start closes each branch at the first attempt
at every position, and a gap in assembly restarts it.
"""

from __future__ import annotations

import sys
from contextlib import contextmanager
from typing import Callable, Iterator

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from dualmech.core.status import Status
from dualmech.models.linkages import rccc, read_linkage, rssr
from dualmech.models.linkages.rccc_case import rccc_from_dict
from dualmech.models.linkages.rssr_case import rssr_from_dict
from dualmech.validation.linkages.gate import worst
from tests.models.linkages.cases import bundled, random_rccc, random_rssr
from tests.tolerances import LINKAGE_JUDGE_KINEMATICS, LINKAGE_JUDGE_REACTIONS

pytest.importorskip("pinocchio")
pytest.importorskip("mujoco")

from dualmech.validation.linkages import judges  # noqa: E402
from dualmech.validation.linkages.mujoco_rccc import solve_mujoco_rccc  # noqa: E402
from dualmech.validation.linkages.mujoco_rssr import solve_mujoco  # noqa: E402
from dualmech.validation.linkages.pinocchio_rccc import solve_pinocchio_rccc  # noqa: E402
from dualmech.validation.linkages.pinocchio_rssr import solve_pinocchio  # noqa: E402

#: How far (rad) the patched in-house start functions put their answer: a wrong start, not a nudge.
GARBAGE = 1.0
JUDGES = {"rssr": {"pinocchio": solve_pinocchio, "mujoco": solve_mujoco},
          "rccc": {"pinocchio": solve_pinocchio_rccc, "mujoco": solve_mujoco_rccc}}


def _rssr(branch: int | None = None, seed: int | None = None, step: float = 10.0):
    data = bundled() if seed is None else random_rssr(np.random.default_rng(seed), "output", step=step)
    if branch is not None:
        data["mechanism"]["branch"] = branch
    return rssr_from_dict(data)


def _rccc(branch: int | None = None, seed: int | None = None, step: float = 10.0):
    data = read_linkage("rccc") if seed is None else random_rccc(np.random.default_rng(seed), step=step)
    if branch is not None:
        data["mechanism"]["branch"] = branch
    return rccc_from_dict(data)


def _in_house(kind: str, case):
    if kind == "rssr":
        return rssr.to_table(rssr.analyze_rssr(case))
    return rccc.to_table(rccc.analyze_rccc(case))


def _spec(kind: str):
    return rssr.SPEC if kind == "rssr" else rccc.SPEC


def _garbage_versions() -> dict[tuple[object, str], Callable]:
    """The in-house start functions, each returning its answer :data:`GARBAGE` rad off (the reach kept)."""
    cfp, rssr_estimate = rssr.closed_form_phi, rssr.estimate
    sph, rccc_estimate = rccc.spherical_estimate, rccc.estimate

    def closed_form_phi(geom, theta1, branch):
        phi, rho = cfp(geom, theta1, branch)
        return phi + GARBAGE, rho

    def spherical_estimate(geom, theta1, branch):  # the other branch's axis
        return sph(geom, theta1, -branch)[0], sph(geom, theta1, branch)[1]

    def estimate_rccc(geom, theta1, z3):
        state = rccc_estimate(geom, theta1, z3)
        angles = GARBAGE * np.array([1.0, 0.0, 1.0, 0.0, 1.0, 0.0])
        return type(state)(state.scalars + angles, state.rotations)

    def estimate_rssr(geom, theta1, phi):
        return rssr_estimate(geom, theta1, phi + GARBAGE)

    return {(rssr, "closed_form_phi"): closed_form_phi, (rssr, "estimate"): estimate_rssr,
            (rccc, "spherical_estimate"): spherical_estimate, (rccc, "estimate"): estimate_rccc}


@contextmanager
def _garbage() -> Iterator[int]:
    """Patch every reference to the in-house start functions (their modules and every loaded module that
    imported them) with :func:`_garbage_versions`; yields how many references were patched."""
    patched = 0
    with pytest.MonkeyPatch.context() as mp:
        for (home, name), fake in _garbage_versions().items():
            real = getattr(home, name)
            for module in list(sys.modules.values()):
                if getattr(module, name, None) is real:
                    mp.setattr(module, name, fake)
                    patched += 1
        yield patched


def _same(a, b) -> bool:
    """Bit for bit: every column (NaN where NaN), the status words, the judge's iteration counts."""
    try:
        assert_array_equal(np.asarray(a.status, dtype=str), np.asarray(b.status, dtype=str))
        for column in a.columns:
            assert_array_equal(a[column], b[column])
        assert_array_equal(a.meta.get("iterations", 0), b.meta.get("iterations", 0))
    except AssertionError:
        return False
    return True


def _untouched_by_garbage(kind: str, judge: str, case) -> bool:
    before = JUDGES[kind][judge](case)
    with _garbage() as patched:
        assert patched >= 4
        after = JUDGES[kind][judge](case)
    return _same(before, after)


def _agrees(kind: str, case, table) -> None:
    ours = _in_house(kind, case)
    assert_array_equal(np.asarray(table.status, dtype=str), np.asarray(ours.status, dtype=str))
    spec = _spec(kind)
    for column, w in worst(ours, table, spec).items():
        tol = LINKAGE_JUDGE_KINEMATICS if column in spec.kinematics else LINKAGE_JUDGE_REACTIONS
        assert w <= tol.value, f"{column}: {w:.3g} over {tol.value:.3g}"


@pytest.mark.parametrize("kind, case", [("rssr", _rssr()), ("rssr", _rssr(seed=11)), ("rccc", _rccc()),
                                        ("rccc", _rccc(seed=7))], ids=["rssr", "rssr-11", "rccc", "rccc-7"])
@pytest.mark.parametrize("judge", ["pinocchio", "mujoco"])
def test_judges_ignore_the_in_house_starts(kind: str, case, judge: str) -> None:
    """The garbage changes the in-house answer (statuses or values), not the judge's table."""
    ours = _in_house(kind, case)
    with _garbage():
        spoiled = _in_house(kind, case)
    assert not _same(ours, spoiled)
    assert _untouched_by_garbage(kind, judge, case)


def _seeded(kind: str, case) -> Callable:
    """Deliberate fault: a :class:`~dualmech.validation.linkages.judges.JudgeLoop` whose crude start is the
    in-house start moved by 0.1 rad (the judges' old design), looked up when called."""
    real = judges.JudgeLoop

    def from_in_house(theta1: float):
        th = np.array([theta1])
        if kind == "rssr":
            return [float(rssr.closed_form_phi(case.geometry, th, case.branch)[0][0]) + 0.1]
        z3 = rccc.spherical_estimate(case.geometry, th, case.branch)[0]
        s = rccc.estimate(case.geometry, th, z3).scalars[0] + 0.1 * np.array([1, 0, 1, 0, 1, 0])
        return [-s[[4, 5, 2, 3, 0, 1]]]

    return lambda reach, crude, position: real(reach, from_in_house, position)


@pytest.mark.parametrize("kind, case", [("rssr", _rssr()), ("rccc", _rccc())], ids=["rssr", "rccc"])
def test_a_judge_seeded_with_the_in_house_start_is_seen(kind: str, case, monkeypatch: pytest.MonkeyPatch
                                                         ) -> None:
    monkeypatch.setattr(judges, "JudgeLoop", _seeded(kind, case))
    _agrees(kind, case, JUDGES[kind]["pinocchio"](case))  # it still agrees: only the start moved
    assert not _untouched_by_garbage(kind, "pinocchio", case)


def _counting(monkeypatch: pytest.MonkeyPatch, every_position_crude: bool) -> list[int]:
    """Count the judge's attempts (calls of its ``position``); optionally never continue (a crude start at
    every position)."""
    calls, real_loop, real_answer = [0], judges.JudgeLoop, judges.judge_answer

    def counted(reach, crude, position):
        def position_counted(*args):
            calls[0] += 1
            return position(*args)
        return real_loop(reach, crude, position_counted)

    monkeypatch.setattr(judges, "JudgeLoop", counted)
    if every_position_crude:
        monkeypatch.setattr(judges, "judge_answer", lambda loop, state, previous, *rest: real_answer(
            loop, state, None, *rest))
    return calls


@pytest.mark.parametrize("kind, make", [("rssr", _rssr), ("rccc", _rccc)])
@pytest.mark.parametrize("branch", [1, -1])
@pytest.mark.parametrize("judge", ["pinocchio", "mujoco"])
def test_the_crude_start_closes_each_branch_at_the_first_attempt(kind: str, make, branch: int, judge: str,
                                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    """Every position started crude (no continuation): one attempt each, on the case's branch, agreeing
    with the in-house engine; the bundled cases' own branch and the other one."""
    case = make(branch)
    calls = _counting(monkeypatch, every_position_crude=True)
    table = JUDGES[kind][judge](case)
    assembled = np.asarray(table.status, dtype=str) != Status.NO_ASSEMBLY.value
    assert table.meta["crude"][assembled].all()
    assert calls[0] == assembled.sum()
    ok = np.asarray(table.status, dtype=str) == Status.OK.value
    assert ok.any() and (np.sign(table["transmission_out"][ok]) == branch).all()
    _agrees(kind, case, table)


def test_a_crude_start_on_the_wrong_side_is_seen(monkeypatch: pytest.MonkeyPatch) -> None:
    """Deliberate fault: the scan's brackets ordered for the other branch; the first attempts land on it."""
    real = judges.scan_starts
    monkeypatch.setattr(judges, "scan_starts", lambda grid, mismatch, slope: real(grid, mismatch, -slope))
    calls = _counting(monkeypatch, every_position_crude=True)
    table = solve_pinocchio(_rssr())
    assert calls[0] > len(table)


def _restarts(table) -> tuple[np.ndarray, np.ndarray]:
    """Where the judge started crude, and where it should have: the first assembled row and every assembled
    row after a no_assembly one."""
    gap = np.asarray(table.status, dtype=str) == Status.NO_ASSEMBLY.value
    expected = ~gap & np.r_[True, gap[:-1]]
    return table.meta["crude"], expected


#: Cases with no_assembly ranges; RSSR 124 and RCCC 111 (5 deg steps) restart next to the assembly limit
#: (|t| 0.026 and 0.066), where the two roots of the scanned mismatch lie within one grid step (RCCC 111: no
#: sign change on the grid at all).
GAP_CASES = {"rssr-11": ("rssr", _rssr(seed=11)), "rssr-124": ("rssr", _rssr(seed=124, step=5.0)),
             "rccc-4": ("rccc", _rccc(seed=4)), "rccc-7": ("rccc", _rccc(seed=7)),
             "rccc-111": ("rccc", _rccc(seed=111, step=5.0))}


@pytest.mark.parametrize("name", GAP_CASES)
@pytest.mark.parametrize("judge", ["pinocchio", "mujoco"])
def test_a_gap_in_assembly_restarts_the_judge(name: str, judge: str) -> None:
    """Crude exactly at the first row and after each gap (continuation elsewhere), and the table agrees with
    the in-house engine on both sides of the gap."""
    kind, case = GAP_CASES[name]
    table = JUDGES[kind][judge](case)
    crude, expected = _restarts(table)
    assert expected[1:].any()  # the case has a gap inside its range
    assert_array_equal(crude, expected)
    _agrees(kind, case, table)


@pytest.mark.parametrize("name", ["rssr-124", "rccc-111"])
def test_a_start_between_close_roots_is_seen(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """Deliberate fault: crude starts at the grid point of the smallest |mismatch| (between the two roots
    near the assembly limit); the restart next to the limit closes on the other branch."""
    def nearest(grid, mismatch, slope):
        return [float(grid[np.argmin(np.abs(mismatch))])]

    monkeypatch.setattr(judges, "scan_starts", nearest)
    kind, case = GAP_CASES[name]
    with pytest.raises(AssertionError):
        _agrees(kind, case, JUDGES[kind]["pinocchio"](case))


def test_continuing_across_a_gap_is_seen(monkeypatch: pytest.MonkeyPatch) -> None:
    """Deliberate fault: a driver that keeps the last closed pose across a gap; the restart check fails."""
    real, last = judges.judge_answer, [None]

    def across(loop, state, previous, *rest):
        out = real(loop, state, last[0] if previous is None else previous, *rest)
        last[0] = out[0].state
        return out

    monkeypatch.setattr(judges, "judge_answer", across)
    crude, expected = _restarts(solve_pinocchio(_rssr(seed=11)))
    assert not np.array_equal(crude, expected)


@pytest.mark.parametrize("branch", [1, -1])
def test_assemble_is_the_judges_own_first_answer(branch: int) -> None:
    """:func:`~dualmech.validation.linkages.mujoco_rssr.assemble` (a simulation's initial state without the
    in-house start): the judge's first row, the same under the garbage, ``qpos`` closed."""
    from dualmech.validation.linkages.mujoco_rssr import assemble, build

    case = _rssr(branch)
    state = case.motion.state(case.geometry.s1)
    first = (float(state.theta[0]), float(state.theta_dot[0]), float(state.theta_ddot[0]))
    mr = build(case)
    answer = assemble(mr, case, *first)
    with _garbage():
        again = assemble(build(case), case, *first)
    assert answer.phi == again.phi and answer.values == again.values
    gap = np.linalg.norm(mr.data.site_xpos[mr.pin] - mr.data.site_xpos[mr.end])
    assert gap <= judges.JUDGE_CLOSURE_TOL * case.geometry.a2
    assert np.sign(answer.t4) == branch
    assert answer.values["phi4_deg"] == solve_mujoco(case)["phi4_deg"][0]
