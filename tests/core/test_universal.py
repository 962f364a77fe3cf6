"""The universal joint at the slider: the rod's spin it determines, and the moment it carries.

The rod's frame ``(u, a, u x a)`` with ``a = (u x k4)/|u x k4|`` is the joint's own definition; its
angular velocity and acceleration by central differences along a constant-speed motion are an
oracle that shares nothing with :mod:`dualmech.core.universal` but the positions.
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from dualmech.core.universal import joint_axes, link_frame
from dualmech.models.case import load_case
from dualmech.models.slider_crank.analysis import analyze
from tests.tolerances import FINITE_DIFFERENCE

STEP = 1e-4  # rad of crank angle: central differences, truncation ~ STEP^2, round-off ~ 1e-16/STEP


def _universal(name: str):
    return load_case(name).with_values({"joints.rod_slider": "universal", "motion.crank_accel": 0.0})


def _rod(case, shift: float):
    """The rod's frame, angular velocity and unit vector at every position moved by ``shift`` rad."""
    moved = case.own_crank_states(case.motion.angles_deg + np.degrees(shift))
    an = analyze(case, moved)
    u = (an.p3 - an.p2) / case.geometry.rod_length
    k4 = np.broadcast_to(case.geometry.k4, u.shape)
    return link_frame(u, k4), an.motions[1].omega, an


@pytest.mark.parametrize("name", ["thesis/a4-30-s1-3.5", "thesis/a4-20-alpha-310", "thesis/a4-10-s1-3.5"])
def test_spin_matches_the_rod_frame_by_differences(name: str) -> None:
    case = _universal(name)
    speed = case.motion.speed
    (r_minus, w_minus, _), (rot, omega, an), (r_plus, w_plus, _) = (
        _rod(case, -STEP), _rod(case, 0.0), _rod(case, STEP))
    ok = an.status == "ok"
    skew = (r_plus - r_minus) / (2 * STEP / speed) @ np.swapaxes(rot, 1, 2)
    by_frame = np.stack([skew[:, 2, 1], skew[:, 0, 2], skew[:, 1, 0]], axis=1)
    scale = np.abs(omega[ok]).max()
    assert_allclose(omega[ok], by_frame[ok], rtol=0, atol=FINITE_DIFFERENCE * scale)
    assert_allclose(an.motions[1].rotation[ok], rot[ok], rtol=0, atol=1e-15)
    alpha = an.motions[1].omega_dot
    by_rate = (w_plus - w_minus) / (2 * STEP / speed)
    assert_allclose(alpha[ok], by_rate[ok], rtol=0, atol=FINITE_DIFFERENCE * np.abs(alpha[ok]).max())
    spin = np.einsum("ni,ni->n", omega, (an.p3 - an.p2) / case.geometry.rod_length)
    assert np.abs(spin[ok]).max() > 1e-3 * scale  # the zero-spin gauge would fail the differences above


def test_moment_is_carried_about_the_normal_of_both_axes_only() -> None:
    case = _universal("thesis/a4-30-s1-3.5")
    an = analyze(case)
    ok = an.status == "ok"
    u = (an.p3 - an.p2) / case.geometry.rod_length
    a, n = joint_axes(u, np.broadcast_to(case.geometry.k4, u.shape))
    m = an.reactions.j3_moment[ok]
    size = np.linalg.norm(m, axis=1)
    assert size.max() > 0.0
    for axis in (a[ok], np.broadcast_to(case.geometry.k4, m.shape)):  # the joint turns freely about both
        assert_allclose(np.einsum("ni,ni->n", m, axis), 0.0, rtol=0, atol=1e-12 * size.max())
    assert_allclose(np.abs(np.einsum("ni,ni->n", m, n[ok])), size, rtol=1e-12, atol=0)


def test_a_ball_joint_carries_no_moment() -> None:
    an = analyze(load_case("thesis/a4-30-s1-3.5"))
    assert np.all(an.reactions.j3_moment == 0.0)
