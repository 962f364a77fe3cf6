"""The pair table (:mod:`dualmech.validation.compare.pairs`): every pair of engines measured as the gate
measures a judge, against an oracle of known differences.

The tables are the stand-in reference of ``matrix_fakes`` (closed-form kinematics, synthetic reactions)
and exact copies of it as the judges, each edited at one row by a known multiple ``d`` of its unit group's
scale ``s_g`` (the reference's largest ``|R|`` over the group's columns: the scale convention restated
here, in slider-load mode where the condition factor is 1).  So the relative difference of two engines at
that row is ``|d_one - d_other|`` (0 elsewhere), and a cell, the worst over the cases and the group's
columns, is known in advance.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from dualmech.core.status import Status
from dualmech.core.table import ResultTable
from dualmech.validation.compare import Comparison, compare_run
from dualmech.validation.matrix import Matrix, load_matrix
from tests import matrix_fakes

PAIRS_MATRIX = """
name = "pairs"
description = "three cases in slider-load mode on four engines"
base = "thesis/ideal"
engines = ["dualmech", "pinocchio", "mujoco", "mujoco-sim"]
reference = "dualmech"
set = { "motion.angles_deg" = { start = 0.0, stop = 360.0, step = 30.0 } }

[load_modes]
force = { "loads.slider_force" = -100.0 }

[[sweep]]
name = "a4"
grid = { "geometry.slider_offset" = [10.0, 30.0] }
"""
BASE, A10, A30 = "force_base", "force_a4=10", "force_a4=30"
P, M, S, R = "pinocchio", "mujoco", "mujoco-sim", "dualmech"
#: The unit groups of the edited columns, as docs/conventions.md states them (the scale's columns).
SCALE_COLUMNS = {"S4": ("S1", "S4"), "S4_dot": ("S4_dot",),
                 "j2_fy": ("j1_fx", "j1_fy", "j1_fz", "j2_fx", "j2_fy", "j2_fz", "j3_fx", "j3_fy", "j3_fz",
                           "j4_fx", "j4_fy", "j4_fz", "slider_load"),
                 "j1_mz": ("j1_mx", "j1_my", "j1_mz", "j3_mx", "j3_my", "j3_mz", "j4_mx", "j4_my", "j4_mz",
                           "drive_torque")}
SCALE_COLUMNS["drive_torque"] = SCALE_COLUMNS["j1_mz"]
#: (engine, case, column, row, d): each edit, at a row whose value is well inside its group's peak (so no
#: engine's scale moves).  S4 at 30 deg, S4_dot at 60 deg, j2_fy at 30 deg, j1_mz at 0 deg, drive_torque at
#: 120 deg; pinocchio and mujoco edited at the same row with opposite signs where their pair adds up.
EDITS = (
    (P, A10, "S4", 1, 2e-11), (M, A10, "S4", 1, -3e-11), (S, A30, "S4", 1, 4e-5),
    (P, BASE, "S4_dot", 2, 7e-11),
    (P, BASE, "j2_fy", 1, 6e-10), (M, BASE, "j2_fy", 1, -6e-10),
    (P, A30, "j1_mz", 0, 3e-10), (M, A10, "j1_mz", 0, 5e-10),
    (S, A10, "drive_torque", 4, 2e-4),
)
#: The oracle: pair -> group -> (worst |d_one - d_other| over the cases, its case); 0 where nothing differs.
EXPECTED = {
    (R, P): {"coordinates": (2e-11, A10), "rates": (7e-11, BASE), "forces": (6e-10, BASE),
             "moments": (3e-10, A30), "efforts": (0.0, None)},
    (R, M): {"coordinates": (3e-11, A10), "rates": (0.0, None), "forces": (6e-10, BASE),
             "moments": (5e-10, A10), "efforts": (0.0, None)},
    (R, S): {"coordinates": (4e-5, A30), "rates": (0.0, None), "forces": (0.0, None),
             "moments": (0.0, None), "efforts": (2e-4, A10)},
    (P, M): {"coordinates": (5e-11, A10), "rates": (7e-11, BASE), "forces": (1.2e-9, BASE),
             "moments": (5e-10, A10), "efforts": (0.0, None)},
    (P, S): {"coordinates": (4e-5, A30), "rates": (7e-11, BASE), "forces": (6e-10, BASE),
             "moments": (3e-10, A30), "efforts": (2e-4, A10)},
    (M, S): {"coordinates": (4e-5, A30), "rates": (0.0, None), "forces": (6e-10, BASE),
             "moments": (5e-10, A10), "efforts": (2e-4, A10)},
}
#: The gate's max_rel is r_i scaled to the tolerance by the row's allowances (``r_i tol / (tol + a_i)``,
#: validation/compare/conditioning.py): the edge-of-assembly law on S4 is 7.3e-3 of the rigid judges' 1e-10
#: here, the aspect-ratio law 1e-4; an edit of 2e-11 of the scale keeps eps / 2e-11 ~ 1e-5 of rounding.
#: 1e-2 holds them and still parts every two expected values (at least 20 % apart).
RTOL = 1e-2


@pytest.fixture()
def pairs_matrix(tmp_path: Path) -> Matrix:
    path = tmp_path / "pairs.toml"
    path.write_text(PAIRS_MATRIX)
    return load_matrix(path)


def _copies(matrix: Matrix) -> dict[str, dict[str, ResultTable]]:
    """Case id -> engine -> the stand-in reference's table, the judges exact copies of it."""
    out = {}
    for mc in matrix.cases:
        ref = matrix_fakes.solve_case(mc.case())
        out[mc.id] = {e: replace(ref, engine=e, columns={k: v.copy() for k, v in ref.columns.items()},
                                 status=np.asarray(ref.status, dtype=object).copy()) for e in matrix.engines}
    return out


def _scale(table: ResultTable, column: str) -> float:
    return max(float(np.max(np.abs(table[c]))) for c in SCALE_COLUMNS[column])


def _pairs(comparison: Comparison) -> dict[tuple[str, str], object]:
    return {(p.one, p.other): p for p in comparison.pairs}


def test_every_cell_of_the_pair_table_is_the_known_difference(pairs_matrix: Matrix) -> None:
    results = _copies(pairs_matrix)
    for engine, case, column, row, d in EDITS:
        ref = results[case][R]
        results[case][engine].columns[column][row] += d * _scale(ref, column)
        assert abs(ref[column][row]) < 0.9 * _scale(ref, column)  # the edited row is not the peak
    comparison = compare_run(pairs_matrix, results)
    assert comparison.passed, comparison.failures()  # every judge within its tolerance of the reference
    pairs = _pairs(comparison)
    assert list(pairs) == list(EXPECTED)  # every pair, in the matrix's order
    tolerances = pairs_matrix.tolerances
    for (one, other), groups in EXPECTED.items():
        pair = pairs[one, other]
        assert pair.verdict == (one == R) and pair.cases == 3 and pair.status_rows == 0
        assert set(pair.cells) == {*groups, "stroke"}
        assert_allclose(pair.cells["stroke"].max_rel, 0.0, rtol=0, atol=1e-15)  # S4's extremes untouched
        for group, (value, case) in groups.items():
            cell = pair.cells[group]
            assert_allclose(cell.max_rel, value, rtol=RTOL, atol=1e-16, err_msg=f"{one}-{other} {group}")
            if case is not None:
                assert cell.case == case, (one, other, group)
            looser = max(tolerances[e][cell.quantity].value for e in (one, other) if e != R)
            assert cell.tolerance.value == looser, (one, other, group)
            assert cell.passed == (value <= looser), (one, other, group)
    # the one cell beyond its tolerance: pinocchio and mujoco each 0.6 of 1e-9 from the reference, opposite
    assert [(p.one, p.other, g) for p in comparison.pairs for g, c in p.cells.items() if not c.passed] == \
        [(P, M, "forces")]


@pytest.mark.parametrize("faulty", [R, P, M, S])
def test_a_fault_in_one_engine_shows_in_exactly_its_pairs(pairs_matrix: Matrix, faulty: str) -> None:
    """Deliberate fault in one engine (the reference too): j1_mz 1 % too large at 0 deg of one case (5.4e-3
    of the moments' scale, beyond every tolerance), and ``not_converged`` at 150 deg of another."""
    results = _copies(pairs_matrix)
    table = results[BASE][faulty]
    table.columns["j1_mz"][0] *= 1.01
    results[A30][faulty].status[5] = Status.NOT_CONVERGED
    expected = 0.01 * abs(table["j1_mz"][0] / 1.01) / _scale(results[BASE][R], "j1_mz")
    pairs = compare_run(pairs_matrix, results).pairs
    assert len(pairs) == 6
    for pair in pairs:
        moments, has = pair.cells["moments"], faulty in (pair.one, pair.other)
        assert pair.status_rows == int(has), (pair.one, pair.other)
        assert moments.passed != has, (pair.one, pair.other)
        assert_allclose(moments.max_rel, expected if has else 0.0, rtol=RTOL, atol=1e-16)
        assert all(c.passed for g, c in pair.cells.items() if g != "moments"), (pair.one, pair.other)


def test_the_slider_cranks_report_renders_the_pair_table(small: Path, tmp_path: Path) -> None:
    """The slider crank's report (the stand-in engines of ``matrix_fakes``: the judges agree to ~1e-13 and
    ~1e-11): one row per pair with the comparison's cells, the stroke among its columns; ``summary.json``
    has the same pairs."""
    import json

    from dualmech.validation.report.render import write_report
    from dualmech.validation.run.runner import run_matrix
    from tests.validation.test_validate import FAKE_REGISTRY

    out = tmp_path / "run"
    run_matrix(load_matrix(small), out, jobs=1, registry=FAKE_REGISTRY)
    write_report(out, None, jobs=1)
    pairs = json.loads((out / "summary.json").read_text())["pairs"]
    assert [(p["one"], p["other"], p["verdict"]) for p in pairs] == [
        (R, P, True), (R, M, True), (P, M, False)]
    markdown = (out / "report.md").read_text()
    section = markdown.split("## Agreement of every pair of engines\n", 1)[1].split("\n## ", 1)[0]
    groups = ["coordinates", "rates", "forces", "moments", "efforts", "stroke"]
    assert f"| pair | kind | cases | statuses | {' | '.join(groups)} |" in section
    for p in pairs:
        cells = " | ".join(f"✓ {p['cells'][g]['max_rel']:.2g} ({p['cells'][g]['tolerance']['value']:g}) "
                           + p["cells"][g]["quantity"].replace("_", "\\_") for g in groups)
        kind = "gate" if p["verdict"] else "informative"
        assert f"| {p['one']} – {p['other']} | {kind} | 6 | agree | {cells} |" in section
    # the fakes' own deviations (matrix_fakes): pinocchio ~1e-13, mujoco ~1e-11 of each value
    worst = {(p["one"], p["other"]): max(c["max_rel"] for c in p["cells"].values()) for p in pairs}
    assert 1e-14 < worst[R, P] < 1e-12 < worst[R, M] < 1e-10 and 1e-12 < worst[P, M] < 1e-10
