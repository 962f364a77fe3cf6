"""Fixtures shared by the validation-matrix tests: a small matrix file and the stand-in engines' tables.

The stand-in engines are ``matrix_fakes``; ``small`` is a two-sweep matrix of the
thesis example coarse enough to run in a second.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from dualmech.core.table import ResultTable
from dualmech.validation.matrix import Matrix, load_matrix

from .. import matrix_fakes

SMALL = """
name = "small"
description = "two sweeps of the thesis example, <b>coarse</b> & quick"
base = "thesis/ideal"
engines = ["dualmech", "pinocchio", "mujoco"]
reference = "dualmech"
set = { "motion.angles_deg" = { start = 0.0, stop = 360.0, step = 30.0 } }

[load_modes]
torque = { "loads.drive_torque" = 100.0 }
force = { "loads.slider_force" = -100.0 }

[[sweep]]
name = "a4"
fixed = { "geometry.crank_axial_shift" = 3.5 }
grid = { "geometry.slider_offset" = [10.0, 30.0] }
"""


@pytest.fixture()
def small(tmp_path: Path) -> Path:
    """The ``SMALL`` matrix written to a file."""
    path = tmp_path / "small.toml"
    path.write_text(SMALL)
    return path


@pytest.fixture()
def matrix(small: Path) -> Matrix:
    return load_matrix(small)


def fake_results(matrix: Matrix) -> dict[str, dict[str, ResultTable]]:
    """Case id -> engine -> table of the stand-in engines (all agreeing) for every case of ``matrix``."""
    return {mc.id: {"dualmech": matrix_fakes.solve_case(mc.case()),
                    "pinocchio": matrix_fakes.solve_case_judge(mc.case()),
                    "mujoco": matrix_fakes.solve_case_judge_b(mc.case())} for mc in matrix.cases}


@pytest.fixture()
def results(matrix: Matrix) -> dict[str, dict[str, ResultTable]]:
    """:func:`fake_results` of the ``SMALL`` matrix."""
    return fake_results(matrix)
