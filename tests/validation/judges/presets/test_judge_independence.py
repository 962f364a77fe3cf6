"""The linkage judges are independent of the in-house solver: their starts are their own.

The registry's ``pinocchio`` and ``mujoco`` engines of an RSSR or RCCC case are the generated judges of its
joint table, started by :mod:`dualmech.validation.judges.presets` from a crude pose of its own.  With every
in-house start function (the RSSR's ``closed_form_phi`` and ``estimate``, the RCCC's
``spherical_estimate`` and ``estimate``, in their modules and wherever imported) returning an answer
1 rad off, the judges' tables are bit for bit the same while the in-house solver's change; a judge seeded
with the in-house start is seen.  Each run starts on the case's branch at its first crude start, and a gap
in assembly restarts the judge.  The simulated judge starts from the same crude start.
"""

from __future__ import annotations

import sys
from contextlib import contextmanager
from dataclasses import replace
from typing import Callable, Iterator

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from dualmech.core.status import Status
from dualmech.models.linkages import rccc, read_linkage, readback, rssr
from dualmech.models.linkages.rccc_case import rccc_from_dict
from dualmech.models.linkages.rssr_case import rssr_from_dict
from dualmech.models.loop import preset_engine
from dualmech.validation.compare.tables import worst
from dualmech.validation.engines import get_engine
from tests.linkage_cases import bundled, random_rccc, random_rssr
from tests.tolerances import LINKAGE_JUDGE_KINEMATICS, LINKAGE_JUDGE_REACTIONS

pytest.importorskip("pinocchio")
pytest.importorskip("mujoco")

from dualmech.models.loop.presets import rssr_table  # noqa: E402
from dualmech.validation.judges.mujoco_loop.table import solve_table as mujoco_loop  # noqa: E402
from dualmech.validation.judges.pinocchio_loop.table import solve_table as pinocchio_loop  # noqa: E402
from dualmech.validation.judges.presets import run, starts  # noqa: E402

#: How far (rad) the patched in-house start functions put their answer: a wrong start, not a nudge.
GARBAGE = 1.0
LOOP_JUDGES = {"pinocchio": pinocchio_loop, "mujoco": mujoco_loop}


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
    return preset_engine.solve_rssr(case) if kind == "rssr" else preset_engine.solve_rccc(case)


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
    """Patch every reference to the in-house start functions (their modules and every loaded module of
    dualmech or of the tests that imported them) with :func:`_garbage_versions`; yields how many references
    were patched.  (Other libraries cannot import them; reading their modules' attributes woke mpmath's
    deprecated ones, 176 warnings a run.)"""
    patched = 0
    ours = [m for m in list(sys.modules.values())
            if getattr(m, "__name__", "").partition(".")[0] in ("dualmech", "tests")]
    with pytest.MonkeyPatch.context() as mp:
        for (home, name), fake in _garbage_versions().items():
            real = getattr(home, name)
            for module in ours:
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
    before = get_engine(judge, kind)(case)
    with _garbage() as patched:
        assert patched >= 4
        after = get_engine(judge, kind)(case)
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


@pytest.mark.parametrize("kind, case", [("rssr", _rssr()), ("rccc", _rccc())], ids=["rssr", "rccc"])
def test_the_simulation_ignores_the_in_house_starts(kind: str, case) -> None:
    """The simulated judge (the generated one, from the rigid judges' crude start) is untouched by the
    garbage too; :func:`test_a_judge_seeded_with_the_in_house_start_is_seen` sees it when its start is the
    in-house one."""
    assert _untouched_by_garbage(kind, "mujoco-sim", case)


def _from_in_house(kind: str) -> Callable:
    """Deliberate fault: start angles from the in-house start moved by 0.1 rad, looked up when called."""
    def angles(case, theta1: float) -> list[float]:
        th = np.array([theta1])
        if kind == "rssr":
            return [np.pi - float(rssr.closed_form_phi(case.geometry, th, case.branch)[0][0]) + 0.1]
        z3 = rccc.spherical_estimate(case.geometry, th, case.branch)[0]
        return [float(rccc.estimate(case.geometry, th, z3).scalars[0][4]) + 0.1]

    return angles


@pytest.mark.parametrize("kind, case", [("rssr", _rssr()), ("rccc", _rccc())], ids=["rssr", "rccc"])
@pytest.mark.parametrize("judge", ["pinocchio", "mujoco-sim"])
def test_a_judge_seeded_with_the_in_house_start_is_seen(kind: str, case, judge: str,
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(starts, f"{kind}_start_angles", _from_in_house(kind))
    if judge == "pinocchio":
        _agrees(kind, case, get_engine(judge, kind)(case))  # it still agrees: only the start moved
    assert not _untouched_by_garbage(kind, judge, case)


def _run(kind: str, judge: str, case):
    """The judge's table of ``case`` (:func:`~dualmech.validation.judges.presets.run.judge_case`) and the
    number of runs of the generated judge it took."""
    calls = [0]

    def counted(mechanism):
        calls[0] += 1
        return LOOP_JUDGES[judge](mechanism)

    return run.judge_case(case, judge, counted), calls[0]


@pytest.mark.parametrize("kind, make", [("rssr", _rssr), ("rccc", _rccc)])
@pytest.mark.parametrize("branch", [1, -1])
@pytest.mark.parametrize("judge", ["pinocchio", "mujoco"])
def test_the_crude_start_closes_each_branch_at_the_first_attempt(kind: str, make, branch: int,
                                                                 judge: str) -> None:
    """The first row's first crude start on the case's branch (one probe of that row, then one run from
    it), agreeing with the in-house engine; the bundled cases' own branch and the other one."""
    case = make(branch)
    table, runs = _run(kind, judge, case)
    assert runs == 2 and table.meta["restarts"].tolist() == [0]
    ok = np.asarray(table.status, dtype=str) == Status.OK.value
    assert ok.any() and (np.sign(table["transmission_out"][ok]) == branch).all()
    _agrees(kind, case, table)


def test_a_crude_start_on_the_wrong_side_is_seen(monkeypatch: pytest.MonkeyPatch) -> None:
    """Deliberate fault: the scan's brackets ordered for the other branch; the first probe lands on it."""
    real = starts.scan_starts
    monkeypatch.setattr(starts, "scan_starts", lambda mismatch, slope: real(mismatch, -slope))
    table, runs = _run("rssr", "pinocchio", _rssr())
    assert runs > 2 * len(table.meta["restarts"])


#: Cases with no_assembly ranges; RSSR 124 and RCCC 111 (5 deg steps) restart next to the assembly limit
#: (|t| 0.026 and 0.066), where the two roots of the scanned mismatch lie within one grid step (RCCC 111: no
#: sign change on the grid at all).
GAP_CASES = {"rssr-11": ("rssr", _rssr(seed=11)), "rssr-124": ("rssr", _rssr(seed=124, step=5.0)),
             "rccc-4": ("rccc", _rccc(seed=4)), "rccc-7": ("rccc", _rccc(seed=7)),
             "rccc-111": ("rccc", _rccc(seed=111, step=5.0))}


@pytest.mark.parametrize("name", GAP_CASES)
@pytest.mark.parametrize("judge", ["pinocchio", "mujoco"])
def test_a_gap_in_assembly_is_crossed_on_the_branch(name: str, judge: str) -> None:
    """Past a gap (where the judge's own continuation may land on the other branch, or not close) a run
    restarts from a crude start wherever no run answered on the branch: the table agrees with the in-house
    engine on both sides of the gap."""
    kind, case = GAP_CASES[name]
    table = get_engine(judge, kind)(case)
    gap = np.asarray(table.status, dtype=str) == Status.NO_ASSEMBLY.value
    assert (~gap & np.r_[False, gap[:-1]]).any()  # the case has a gap inside its range
    _agrees(kind, case, table)


def test_a_driver_without_restarts_is_seen() -> None:
    """Deliberate fault: one run from the first row's crude start, its answer taken as it is (no restart
    where it did not answer on the branch); past the gap the Pinocchio judge's continuation is on the other
    branch, and the check sees it."""
    kind, case = GAP_CASES["rssr-11"]
    theta1 = float(np.radians(case.motion.angles_deg[0]))
    start = starts.rssr_start(case, theta1, starts.rssr_start_angles(case, theta1)[0])
    mechanism = rssr_table(case)
    table = readback.rssr_columns(case, pinocchio_loop(starts.with_start(mechanism, start)))
    with pytest.raises(AssertionError):
        _agrees(kind, case, table)


@pytest.mark.parametrize("name", ["rssr-124", "rccc-111"])
def test_a_start_between_close_roots_is_seen(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """Deliberate fault: crude starts at the grid point of the smallest |mismatch| (between the two roots
    near the assembly limit) and no other; the restart next to the limit closes on the other branch."""
    def nearest(mismatch, slope):
        m = mismatch.shape[0]
        return [float(2.0 * np.pi * np.argmin(np.abs(mismatch)) / m)]

    monkeypatch.setattr(starts, "scan_starts", nearest)
    kind, case = GAP_CASES[name]
    with pytest.raises(AssertionError):
        _agrees(kind, case, get_engine("pinocchio", kind)(case))


def test_a_judge_that_fails_everywhere_costs_a_few_solves_a_row() -> None:
    """A judge that never closes (every word ``not_converged``) is probed row by row, at most
    MAX_CRUDE_STARTS positions solved a row, never re-run over the rest of the table from every row.  The
    bundled RSSR every 10 deg: runs to the end from each of its 36 rows would solve 4 * (36 + 35 + ... + 1)
    = 2664 positions, against the 4 * 36 = 144 allowed."""
    solved = [0]

    def failing(mechanism):
        table = pinocchio_loop(mechanism)
        solved[0] += len(table)
        return replace(table, status=np.full(len(table), Status.NOT_CONVERGED.value, dtype=object))

    data = bundled()
    data["motion"]["angles_deg"] = {"start": 0.0, "stop": 360.0, "step": 10.0}
    case = rssr_from_dict(data)
    table = run.judge_case(case, "pinocchio", failing)
    assert (np.asarray(table.status, dtype=str) == Status.NOT_CONVERGED.value).all()
    assert solved[0] <= run.MAX_CRUDE_STARTS * len(table)
