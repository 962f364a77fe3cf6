"""The searched start of a table without ``start`` values: the assembly nearest the zero pose
(``models/loop/start.py``), its distance, and the in-house engine taking it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from dualmech.core.continuation import search_assembly
from dualmech.models.loop.engine import analyze_loop, find_start
from dualmech.models.loop.start import nearest_to_zero, wrapped, zero_distance
from dualmech.models.loop.translate import drive_state, to_loop
from tests.models.loop.test_random_tables import random_table

#: Angles compared after a wrap: ~100 ulps of pi.
ANGLE_ATOL = 1e-13


def test_the_distance_sums_the_wrapped_angles_squared_and_nothing_else():
    pose = {"theta2": 0.5, "eta2": -3.0 + 4 * math.pi, "s3": 7.0, "theta4": 2 * math.pi + 0.1}
    assert zero_distance(pose) == pytest.approx(0.5**2 + 3.0**2 + 0.1**2, rel=1e-12)
    assert zero_distance({"s1": 3.0, "s2": -1.0}) == 0.0


def test_wrapping_keeps_the_pose_and_the_slides():
    pose = {"theta1": 7.0, "eta2": -9.0, "s3": 12.5}
    out = wrapped(pose)
    assert out["s3"] == 12.5
    for name in ("theta1", "eta2"):
        assert -math.pi <= out[name] <= math.pi
        np.testing.assert_allclose(math.cos(out[name]), math.cos(pose[name]), rtol=0, atol=ANGLE_ATOL)
        np.testing.assert_allclose(math.sin(out[name]), math.sin(pose[name]), rtol=0, atol=ANGLE_ATOL)


def test_the_nearest_pose_wins():
    poses = [{"theta2": 2.0}, {"theta2": -0.5 + 2 * math.pi}, {"theta2": 0.6}]
    assert nearest_to_zero(poses) == 1
    with pytest.raises(ValueError, match="at least one closed pose"):
        nearest_to_zero([])


def test_equal_angles_are_told_apart_by_the_slides_then_by_the_greater_coordinate():
    """An RSSP's two assemblies: the same angles (``theta1``, the drive), the slide at ``+s`` or ``-s``."""
    a = {"theta1": 0.4, "s4": -0.17376128341343788}
    b = {"theta1": 0.4 + 2 * math.pi * (1 + 1e-16), "s4": 0.17376128341343735}  # rounding apart
    assert nearest_to_zero([a, b]) == 1 and nearest_to_zero([b, a]) == 0
    assert nearest_to_zero([a, {"theta1": 0.4, "s4": 0.5}]) == 0  # the lesser slides first
    first = {"theta2": -1.0, "theta3": 2.0}  # equal distances; theta2 decides, the greater
    assert nearest_to_zero([first, {"theta2": 1.0, "theta3": -2.0}]) == 1
    assert nearest_to_zero([{"theta1": 0.1}, {"theta1": 0.1}]) == 0  # all equal: the first


@pytest.mark.parametrize("seed, topology", [(0, "RSUR"), (0, "RSCR")])
def test_the_engine_starts_on_the_searched_assembly_nearest_zero(seed: int, topology: str):
    """Of the assemblies the search closes at the start's position, the engine starts on the one whose
    wrapped angles have the least sum of squares (computed here from the search's own poses), with its
    angles wrapped to [-pi, pi]."""
    mech = random_table(seed, topology)
    loop, drive = to_loop(mech), drive_state(mech)
    start, at = find_start(mech, loop, drive)
    found = search_assembly(loop, drive.take(slice(at, at + 1)).values, size=mech.length)
    angles = np.array([name.rstrip("0123456789") in ("theta", "eta") for name in loop.unknowns])
    sums = (np.remainder(found.scalars[:, angles] + np.pi, 2 * np.pi) - np.pi) ** 2
    best = found.scalars[np.argmin(sums.sum(axis=1))]
    assert found.scalars.shape[0] >= 2  # a choice was made
    diff = np.remainder(start.scalars[0] - best + np.pi, 2 * np.pi) - np.pi
    np.testing.assert_allclose(np.where(angles, diff, start.scalars[0] - best), 0.0, rtol=0, atol=1e-9)
    assert np.all(np.abs(start.scalars[0][angles]) <= math.pi)
    table = analyze_loop(mech)
    np.testing.assert_allclose(table.state.scalars[at], start.scalars[0], rtol=0, atol=1e-9)
