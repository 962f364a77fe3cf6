"""Shaking-force balancing: the derived conditions balance the planar and the spatial mechanism."""

import numpy as np
import pytest
from numpy.testing import assert_allclose

from dualmech.core.reactions import momentum_rate
from dualmech.models.case import load_case, with_loads
from dualmech.models.slider_crank import balancing as bl
from dualmech.models.slider_crank.analysis import analyze
from dualmech.validation.tolerances import BALANCE_SHAKING_FORCE
from tests.tolerances import BALANCE


def _peak(force):
    return np.linalg.norm(force, axis=1).max()


def test_balancing_point_formula():
    p = bl.balancing_point(2.0, 4.0)
    assert (p.xi1, p.eta1, p.xi2, p.eta2) == (-2.5, 0.0, -0.25, 0.0)
    for bad in (0.0, -1.0, float("nan")):
        with pytest.raises(ValueError, match="mu1"):
            bl.balancing_point(bad, 1.0)


def test_balanced_planar_design_has_no_shaking_force_at_any_speed_and_acceleration():
    """Done-when: |f_shake| <= 1e-9 of the unbalanced design's peak at every position."""
    rng = np.random.default_rng(40)
    base = load_case("ideal")
    for _ in range(3):
        motion = {"motion.crank_rpm": float(rng.uniform(-500, 500)),
                  "motion.crank_accel": float(rng.uniform(-300, 300))}
        case = base.with_values(motion)
        before, after = bl.shaking(case), bl.shaking(bl.balanced_case(case))
        assert np.all(after.status == "ok")
        peak = _peak(before.force)
        assert peak > 0
        assert_allclose(after.force, 0.0, rtol=0, atol=BALANCE_SHAKING_FORCE.value * peak)


def test_printed_xi2_does_not_balance():
    """Eq. (75) prints xi2 = +1/mu2: that design keeps a shaking force of the order of the original."""
    case = load_case("ideal")
    mu1, mu2 = bl.mass_ratios(case)
    good = bl.balanced_case(case)
    printed = good.with_values({"bodies.rod.com": [case.geometry.rod_length / mu2, 0.0, 0.0]})
    assert _peak(bl.shaking(printed).force) > 0.1 * _peak(bl.shaking(case).force)
    assert bl.design_point(good) == bl.balancing_point(mu1, mu2)


def test_spatial_offsets_do_not_spoil_the_force_balance():
    rng = np.random.default_rng(41)
    for name in ("a4-20-alpha-232", "a4-30-s1-9"):
        case = load_case(name).with_values({"motion.crank_rpm": float(rng.uniform(20, 400)),
                                            "motion.crank_accel": float(rng.uniform(-100, 100))})
        peak = _peak(bl.shaking(case).force)
        after = bl.shaking(bl.balanced_case(case))
        assert_allclose(after.force, 0.0, rtol=0, atol=BALANCE_SHAKING_FORCE.value * peak)


def test_axial_motion_leaves_an_axial_shaking_force():
    """With S1(theta) driven the balanced design still shakes along z by -m S1''(t)."""
    case = load_case("a4-30-s1-3.5").with_values({"motion.axial_amplitude": 1.0, "motion.axial_cycles": 2.0,
                                                  "motion.crank_accel": 5.0})
    balanced = bl.balanced_case(case)
    s = bl.shaking(balanced)
    total = sum(b.mass for b in (balanced.bodies.crank, balanced.bodies.rod, balanced.bodies.slider))
    s1_ddot = balanced.own_crank_states().s_ddot
    peak = _peak(bl.shaking(case).force)
    assert_allclose(s.force[:, :2], 0.0, rtol=0, atol=BALANCE_SHAKING_FORCE.value * peak)
    assert_allclose(s.force[:, 2], -total * s1_ddot, rtol=0, atol=BALANCE_SHAKING_FORCE.value * peak)


def test_shaking_is_the_momentum_rate_and_does_not_depend_on_the_load_mode():
    rng = np.random.default_rng(42)
    case = load_case("a4-20-alpha-310").with_values(
        {"loads.gravity": [float(x) for x in rng.normal(0, 200, 3)], "motion.crank_accel": 12.0}
    )
    s = bl.shaking(case)
    an = analyze(case)
    bodies = (case.bodies.crank, case.bodies.rod, case.bodies.slider)
    rates = [momentum_rate(b, m) for b, m in zip(bodies, an.motions)]
    g = case.loads.gravity
    weight_force = sum(b.mass for b in bodies) * g
    weight_moment = sum(np.cross(m.com, b.mass * g) for b, m in zip(bodies, an.motions))
    force = weight_force - sum(r.re for r in rates)
    moment = weight_moment - sum(r.du for r in rates)
    assert_allclose(s.force, force, rtol=0, atol=BALANCE * np.abs(force).max())
    assert_allclose(s.moment, moment, rtol=0, atol=BALANCE * np.abs(moment).max())
    torque_mode = with_loads(case, drive_torque=55.0, slider_force=None)
    an_t = analyze(torque_mode)
    ok = an_t.status == "ok"
    f_t = -(an_t.reactions.j1_force + an_t.reactions.j4_force)
    condition = 1.0 / np.abs(an_t.transmission[ok]).min()  # torque mode: reactions carry 1/|t|
    assert_allclose(f_t[ok], s.force[ok], rtol=0, atol=BALANCE * np.abs(force).max() * condition)


def test_balanced_case_with_given_mass_ratios():
    case = load_case("ideal")
    m3 = case.bodies.slider.mass
    b = bl.balanced_case(case, mu1=5.0, mu2=2.0)
    assert_allclose([b.bodies.crank.mass / m3, b.bodies.rod.mass / m3], [5.0, 2.0], rtol=1e-14)
    assert_allclose(
        b.bodies.rod.inertia, case.bodies.rod.inertia * (2.0 * m3 / case.bodies.rod.mass), rtol=1e-14
    )
    p = bl.design_point(b)
    assert_allclose([p.xi1, p.eta1, p.xi2, p.eta2], [-3.0 / 5.0, 0.0, -0.5, 0.0], rtol=1e-14, atol=0)
    assert_allclose(
        _peak(bl.shaking(b).force), 0.0, atol=BALANCE_SHAKING_FORCE.value * _peak(bl.shaking(case).force)
    )


def test_polar_plot_is_written(tmp_path):
    pytest.importorskip("matplotlib")
    case = load_case("ideal").with_values({"motion.angles_deg": {"start": 0.0, "stop": 360.0, "step": 5.0}})
    path = bl.shaking_force_polar(case, bl.balanced_case(case), tmp_path / "polar.png")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert path.stat().st_size > 10_000
