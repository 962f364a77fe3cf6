"""The joint-frame table reproduces the thesis's own findings in its own notation."""

import numpy as np
import pytest
from numpy.testing import assert_allclose

from dualmech.models.case import load_case
from dualmech.models.joint_frames import joint_frame_columns
from dualmech.models.slider_crank.analysis import solve_case


def test_planar_case_in_thesis_notation():
    """Planar ideal case: 2F2j = -T/a1 (thesis 3.2), 2F2k = 0, joint-4 torques 0, 1T1i = 1T1j = 0."""
    case = load_case("ideal")
    table = solve_case(case)
    cols = joint_frame_columns(case, table)
    ok = table.status == "ok"
    assert_allclose(cols["2F2j"][ok], -100.0 / 12.0, rtol=1e-12)
    scale = np.abs(cols["2F2i"][ok]).max()
    for name in ("2F2k", "3F3k", "3T3i", "3T3j", "3T3k", "1T1i", "1T1j", "4T4i", "4T4j", "4T4k"):
        assert_allclose(cols[name][ok], 0.0, atol=1e-12 * scale * 12.0, err_msg=name)


@pytest.mark.parametrize("name", ["a4-20-alpha-232", "iftomm/spatial-slider-crank"])
def test_frame_change_preserves_magnitudes(name):
    case = load_case(name)
    table = solve_case(case)
    cols = joint_frame_columns(case, table)
    ok = table.status == "ok"
    assert name.startswith("a4") or np.abs(cols["3T3j"][ok]).max() > 0.0  # the universal joint's moment
    pairs = (("j2_f", "2F2"), ("j3_f", "3F3"), ("j3_m", "3T3"), ("j4_f", "4F4"), ("j4_m", "4T4"))
    for joint, thesis in pairs:
        world = np.linalg.norm(np.stack([table[f"{joint}{a}"] for a in "xyz"], 1), axis=1)
        local = np.linalg.norm(np.stack([cols[f"{thesis}{a}"] for a in "ijk"], 1), axis=1)
        assert_allclose(local[ok], world[ok], rtol=1e-12, atol=1e-9)
