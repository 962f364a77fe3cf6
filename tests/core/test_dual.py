"""Dual algebra: arithmetic rules, rotation builders against the thesis's printed matrices."""

import numpy as np
from numpy.testing import assert_allclose

from dualmech.core.dual import (
    Dual,
    dcos,
    dcross,
    ddot,
    dsin,
    dsqrt,
    from_pose,
    identity,
    origin,
    rot_x,
    rot_y,
    rot_z,
    skew,
    vee,
)

EXACT = dict(rtol=0, atol=1e-14)  # a few ulp of O(1) quantities


def _random_dual(rng, shape):
    return Dual(rng.normal(size=shape), rng.normal(size=shape))


def test_epsilon_squares_to_zero():
    eps = Dual.of(0.0, 1.0)
    sq = eps * eps
    assert_allclose([sq.re, sq.du], [0.0, 0.0], **EXACT)


def test_functions_follow_taylor_expansion():
    rng = np.random.default_rng(1)
    x = _random_dual(rng, (50,))
    one = dsin(x) * dsin(x) + dcos(x) * dcos(x)
    assert_allclose(one.re, 1.0, **EXACT)
    assert_allclose(one.du, 0.0, **EXACT)
    pos = Dual(np.abs(x.re) + 0.5, x.du)
    root = dsqrt(pos)
    back = root * root
    assert_allclose(back.re, pos.re, rtol=1e-14, atol=0)
    assert_allclose(back.du, pos.du, rtol=1e-13, atol=1e-14)


def test_rotation_builders_are_dual_orthogonal():
    rng = np.random.default_rng(2)
    for build in (rot_x, rot_y, rot_z):
        m = build(_random_dual(rng, (20,)))
        prod = m @ m.T
        assert_allclose(prod.re, np.broadcast_to(np.eye(3), prod.re.shape), **EXACT)
        assert_allclose(prod.du, 0.0, **EXACT)


def test_thesis_matrix_1_and_4():
    """M1 = Z(theta1 + eps S1) X(0 + eps a1) (eq. 1) and M4 = Z(eps S4) X(alpha4 + eps a4) (eq. 4), as
    printed."""
    rng = np.random.default_rng(3)
    th, s1, a1, s4, al, a4 = rng.normal(size=6)
    m1 = rot_z(Dual.of(th, s1)) @ rot_x(Dual.of(0.0, a1))
    c, s = np.cos(th), np.sin(th)
    assert_allclose(m1.re, [[c, -s, 0], [s, c, 0], [0, 0, 1]], **EXACT)
    assert_allclose(m1.du, [[-s1 * s, -s1 * c, a1 * s], [s1 * c, -s1 * s, -a1 * c], [0, a1, 0]], **EXACT)
    m4 = rot_z(Dual.of(0.0, s4)) @ rot_x(Dual.of(al, a4))
    ca, sa = np.cos(al), np.sin(al)
    assert_allclose(m4.re, [[1, 0, 0], [0, ca, -sa], [0, sa, ca]], **EXACT)
    assert_allclose(
        m4.du, [[0, -s4 * ca, s4 * sa], [s4, -a4 * sa, -a4 * ca], [0, a4 * ca, -a4 * sa]], **EXACT
    )


def test_pose_round_trip_and_plucker_columns():
    rng = np.random.default_rng(4)
    r = rot_z(Dual.of(rng.normal())).re @ rot_y(Dual.of(rng.normal())).re
    p = rng.normal(size=3)
    m = from_pose(r, p)
    assert_allclose(origin(m), p, **EXACT)
    line = m.column(2)  # the frame's z axis: direction and moment p x direction
    assert_allclose(line.du, np.cross(p, r[:, 2]), **EXACT)


def test_cross_and_dot_products():
    rng = np.random.default_rng(5)
    a, b = _random_dual(rng, (10, 3)), _random_dual(rng, (10, 3))
    c = dcross(a, b)
    # a x b is orthogonal to a in the dual sense: a . (a x b) = 0 (primary and dual parts)
    d = ddot(a, c)
    assert_allclose(d.re, 0.0, rtol=0, atol=1e-13)
    assert_allclose(d.du, 0.0, rtol=0, atol=1e-13)
    assert_allclose(vee(skew(a.re)), a.re, **EXACT)


def test_batched_matches_scalar_loop():
    rng = np.random.default_rng(6)
    a, b = _random_dual(rng, (7, 3, 3)), _random_dual(rng, (7, 3, 3))
    batched = a @ b
    for i in range(7):
        single = a.take(i) @ b.take(i)
        assert_allclose(batched.re[i], single.re, **EXACT)
        assert_allclose(batched.du[i], single.du, **EXACT)
    assert_allclose(identity((2,)).re, np.broadcast_to(np.eye(3), (2, 3, 3)))
