"""Common-mode inputs: what every engine reads, held against values derived independently of the code.

Every engine (in-house, Pinocchio, MuJoCo rigid, MuJoCo simulation) builds its model from the
mass properties of :func:`dualmech.models.case.case_from_dict` (``Case.bodies``) and drives the
crank with :meth:`dualmech.core.motion.CrankMotion.state`.  A mistake there would be made by all
engines alike and no cross-validation could see it, so these tests hold both against numbers
derived by hand from the thesis (S. Rahman, *Dynamic analysis of the generalized slider crank*,
NJIT 1991, section 3.1 "Example", p. 54 of the printed thesis, and eq. (27)-(28b), section 2.6.1
and 2.9).  The expected side never imports the project's mass-property or motion code: each value
is written out as a number with its arithmetic, and recomputed from the printed formula with
:mod:`math` in the test.

Deliberate faults these tests were seen to catch (each made by hand in a scratch edit, then undone):
crank/rod transverse inertia ``L^2/3`` instead of ``L^2/12`` in ``core/inertia.solid_cylinder_x``;
``cos`` instead of ``sin`` in the S1 law of ``core/motion.py``; a phase error (``sin(alpha
theta + pi/2)``); ``alpha^2`` dropped from the centripetal term of S1_ddot.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from dualmech.models.case import case_from_dict
from dualmech.models.slider_crank.analysis import solve_case
from tests.tolerances import COMMON_MODE_INPUT, PRINTED_DIGITS

# ----------------------------------------------------------------------------- thesis section 3.1
# Printed data (section 3.1): a1 = 12 in, a2 = 50 in, crank radius r1 = 1.5 in, rod radius r2 = 1 in,
# slider cube side r3 = 3 in, "specific gravity" d = 0.28 (a weight density, lbf/in^3: errata E16),
# g = 386.4 in/s^2, crank RPM = 50.
A1, A2, R1, R2, R3, D, G, RPM = 12.0, 50.0, 1.5, 1.0, 3.0, 0.28, 386.4, 50.0

# Masses, printed m1 = pi r1^2 a1 d / g, m2 = pi r2^2 a2 d / g, m3 = r3^3 d / g (lbf s^2/in):
#   m1 = pi * 2.25 * 12 * 0.28 / 386.4 = pi * 7.56 / 386.4 = 23.750440 / 386.4 = 0.0614659
#   m2 = pi * 1 * 50 * 0.28 / 386.4    = pi * 14 / 386.4   = 43.982297 / 386.4 = 0.1138258
#   m3 = 27 * 0.28 / 386.4            = 7.56 / 386.4                         = 0.0195652
M1, M2, M3 = 0.0614659432, 0.1138258208, 0.0195652174
# Radii of gyration, printed K1x = r1/sqrt2, K1y = K1z = (r1^2/4 + a1^2/3)^(1/2) (and the same for the
# rod), K3x = K3y = K3z = r3/sqrt6.  K1y, K2y are about the link's END (a^2/3: errata E8); the code
# states inertia about the centre of mass at a/2, so the parallel-axis theorem removes m (a/2)^2:
#   crank axial      m1 r1^2/2                  = 0.0614659 * 1.125                    = 0.0691492
#   crank transverse m1 (r1^2/4 + a1^2/3 - 36)  = 0.0614659 * (0.5625 + 48 - 36 = 12.5625) = 0.7721659
#   rod axial        m2 r2^2/2                  = 0.1138258 * 0.5                      = 0.0569129
#   rod transverse   m2 (r2^2/4 + a2^2/3 - 625) = 0.1138258 * (0.25 + 833.3333 - 625 = 208.5833) = 23.742169
#   slider           m3 r3^2/6                  = 0.0195652 * 1.5                      = 0.0293478
CRANK_INERTIA = (0.0691491861, 0.7721659117, 0.7721659117)
ROD_INERTIA = (0.0569129104, 23.742169118, 23.742169118)
SLIDER_INERTIA = (0.0293478261,) * 3
#: Centres of mass, printed g1 = a1/2, g2 = a2/2 (from the crank axis / from P2; errata E8), g3 = 0.
CRANK_COM, ROD_COM, SLIDER_COM = (6.0, 0.0, 0.0), (25.0, 0.0, 0.0), (0.0, 0.0, 0.0)
#: 50 rpm = 2 pi 50 / 60 rad/s = 5.2359878 rad/s.
THETA1_DOT = 5.2359877560


def _thesis_dict(**motion) -> dict:
    """The thesis example written as a case table, independent of the bundled preset files."""
    return {
        "name": "thesis-3.1", "units": "inch-lbf-s",
        "geometry": {"crank_length": A1, "rod_length": A2, "slider_offset": 30.0, "slider_twist_deg": 270.0,
                     "crank_axial_shift": 3.5},
        "motion": {"crank_rpm": RPM, "angles_deg": {"start": 0.0, "stop": 360.0, "step": 15.0}, **motion},
        "bodies": {"crank_radius": R1, "rod_radius": R2, "slider_side": R3, "weight_density": D,
                   "gravity_constant": G},
        "loads": {"drive_torque": 100.0},
    }


def _by_hand(mass_per_volume: float) -> dict[str, tuple[float, tuple, tuple]]:
    """(mass, com, principal central inertia) of each body from the printed formulas of section 3.1."""
    m1 = math.pi * R1**2 * A1 * mass_per_volume
    m2 = math.pi * R2**2 * A2 * mass_per_volume
    m3 = R3**3 * mass_per_volume

    def link(m: float, r: float, a: float) -> tuple:
        k_end2 = r**2 / 4 + a**2 / 3  # printed K_y^2, about the end
        return (m * r**2 / 2, m * (k_end2 - (a / 2) ** 2), m * (k_end2 - (a / 2) ** 2))

    return {"crank": (m1, (A1 / 2, 0, 0), link(m1, R1, A1)), "rod": (m2, (A2 / 2, 0, 0), link(m2, R2, A2)),
            "slider": (m3, (0, 0, 0), (m3 * R3**2 / 6,) * 3)}


def test_printed_arithmetic_matches_the_printed_formulas():
    """The literals above are the printed formulas evaluated (guards the hand arithmetic itself)."""
    hand = _by_hand(D / G)
    for name, (mass, com, inertia) in zip(("crank", "rod", "slider"), (
            (M1, CRANK_COM, CRANK_INERTIA), (M2, ROD_COM, ROD_INERTIA), (M3, SLIDER_COM, SLIDER_INERTIA))):
        assert_allclose(hand[name][0], mass, rtol=PRINTED_DIGITS, atol=0, err_msg=name)
        assert_allclose(hand[name][1], com, rtol=0, atol=0, err_msg=name)
        assert_allclose(hand[name][2], inertia, rtol=PRINTED_DIGITS, atol=0, err_msg=name)
    assert_allclose(2 * math.pi * RPM / 60, THETA1_DOT, rtol=PRINTED_DIGITS, atol=0)


def test_mass_properties_from_geometry_match_section_3_1():
    """``case_from_dict`` (the one function every engine's model is built from) against section 3.1."""
    bodies = case_from_dict(_thesis_dict()).bodies
    for name, mass, com, inertia in (
        ("crank", M1, CRANK_COM, CRANK_INERTIA),
        ("rod", M2, ROD_COM, ROD_INERTIA),
        ("slider", M3, SLIDER_COM, SLIDER_INERTIA),
    ):
        body = getattr(bodies, name)
        assert_allclose(body.mass, mass, rtol=PRINTED_DIGITS, atol=0, err_msg=name)
        assert_allclose(body.com, com, rtol=0, atol=COMMON_MODE_INPUT * A2, err_msg=name)
        assert_allclose(body.inertia, np.diag(inertia), rtol=PRINTED_DIGITS,
                        atol=COMMON_MODE_INPUT * max(inertia), err_msg=name)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_mass_properties_from_geometry_match_the_printed_formulas_for_any_sizes(seed):
    """The same formulas at random sizes and a plain density: no coincidence of the thesis numbers."""
    rng = np.random.default_rng(seed)
    a1, a2 = rng.uniform(0.5, 5.0), rng.uniform(6.0, 20.0)
    r1, r2, r3, rho = rng.uniform(0.05, 0.4, size=3).tolist() + [float(rng.uniform(500.0, 9000.0))]
    data = _thesis_dict()
    data["geometry"].update(crank_length=a1, rod_length=a2)
    data["bodies"] = {"crank_radius": r1, "rod_radius": r2, "slider_side": r3, "density": rho}
    bodies = case_from_dict(data).bodies
    expected = {
        "crank": (math.pi * r1**2 * a1 * rho, (a1 / 2, 0, 0)),
        "rod": (math.pi * r2**2 * a2 * rho, (a2 / 2, 0, 0)),
        "slider": (r3**3 * rho, (0, 0, 0)),
    }
    for name, r, a in (("crank", r1, a1), ("rod", r2, a2), ("slider", r3, None)):
        mass, com = expected[name]
        inertia = (mass * r**2 / 6,) * 3 if a is None else (
            mass * r**2 / 2, mass * (r**2 / 4 + a**2 / 3 - a**2 / 4), mass * (r**2 / 4 + a**2 / 3 - a**2 / 4))
        body = getattr(bodies, name)
        assert_allclose(body.mass, mass, rtol=COMMON_MODE_INPUT, atol=0, err_msg=name)
        assert_allclose(body.com, com, rtol=0, atol=COMMON_MODE_INPUT * a2, err_msg=name)
        assert_allclose(body.inertia, np.diag(inertia), rtol=COMMON_MODE_INPUT,
                        atol=COMMON_MODE_INPUT * max(inertia), err_msg=name)


# ----------------------------------------------------------------------------- crank motion, eq. (27)-(28b)
# Printed (section 2.6.1): S1 = S_S1 sin(alpha theta1)                                   (28)
# and its rates (28a, corrected per errata E7; 28b as printed):
#   S1_dot  = alpha S_S1 cos(alpha theta1) theta1_dot
#   S1_ddot = alpha S_S1 [cos(alpha theta1) theta1_ddot - alpha sin(alpha theta1) theta1_dot^2]
# dualmech adds the constant part: S1 = crank_axial_shift + S_S1 sin(alpha theta1).
# By hand at theta1 = 30 deg, S_S1 = 2 in, alpha = 2, 50 rpm (theta1_dot = 5.2359878 rad/s),
# theta1_ddot = 0.7 rad/s^2 and shift 3.5 in:  alpha theta1 = 60 deg, sin = 0.8660254, cos = 0.5,
#   S1      = 3.5 + 2 * 0.8660254                                        = 5.2320508 in
#   S1_dot  = 2 * 2 * 0.5 * 5.2359878                                    = 10.4719755 in/s
#   S1_ddot = 2 * 2 * (0.5 * 0.7 - 2 * 0.8660254 * 27.4155678)           = -188.5406253 in/s^2
S1_AT_30, S1_DOT_AT_30, S1_DDOT_AT_30 = 5.2320508076, 10.4719755120, -188.5406252588


def _sinusoidal_case(theta1_ddot: float = 0.7):
    return case_from_dict(_thesis_dict(crank_accel=theta1_ddot, axial_amplitude=2.0, axial_cycles=2.0))


def test_crank_motion_matches_eq_28_by_hand_at_30_degrees():
    case = _sinusoidal_case()
    st = case.own_crank_states(np.array([30.0]))
    assert_allclose(st.theta, [math.pi / 6], rtol=COMMON_MODE_INPUT, atol=0)
    assert_allclose(st.theta_dot, [THETA1_DOT], rtol=PRINTED_DIGITS, atol=0)
    assert_allclose(st.theta_ddot, [0.7], rtol=0, atol=0)
    assert_allclose(st.s, [S1_AT_30], rtol=PRINTED_DIGITS, atol=0)
    assert_allclose(st.s_dot, [S1_DOT_AT_30], rtol=PRINTED_DIGITS, atol=0)
    assert_allclose(st.s_ddot, [S1_DDOT_AT_30], rtol=PRINTED_DIGITS, atol=0)


@pytest.mark.parametrize("seed", [3, 4])
def test_crank_motion_matches_eq_27_28_at_random_states(seed):
    """S1 and its rates from (28)-(28b) by hand at random angles, amplitudes, cycles and accelerations."""
    rng = np.random.default_rng(seed)
    amp, cycles, shift = rng.uniform(0.5, 4.0), float(rng.integers(1, 4)), rng.uniform(-3.0, 3.0)
    rpm, accel = rng.uniform(10.0, 300.0), rng.uniform(-50.0, 50.0)
    data = _thesis_dict(crank_rpm=rpm, crank_accel=accel, axial_amplitude=amp, axial_cycles=cycles)
    data["geometry"]["crank_axial_shift"] = shift
    case = case_from_dict(data)
    deg = rng.uniform(0.0, 360.0, size=50)
    st = case.motion.state(shift, deg)
    th = np.array([math.radians(x) for x in deg])
    w = 2 * math.pi * rpm / 60
    s = np.array([shift + amp * math.sin(cycles * t) for t in th])
    s_dot = np.array([cycles * amp * math.cos(cycles * t) * w for t in th])
    s_ddot = np.array([cycles * amp * (math.cos(cycles * t) * accel - cycles * math.sin(cycles * t) * w**2)
                       for t in th])
    scale = amp * cycles * (w**2 * cycles + abs(accel) + w)
    assert_allclose(st.theta, th, rtol=COMMON_MODE_INPUT, atol=0)
    assert_allclose(st.theta_dot, w, rtol=COMMON_MODE_INPUT, atol=0)
    assert_allclose(st.theta_ddot, accel, rtol=COMMON_MODE_INPUT, atol=0)
    assert_allclose(st.s, s, rtol=0, atol=COMMON_MODE_INPUT * (abs(shift) + amp))
    assert_allclose(st.s_dot, s_dot, rtol=0, atol=COMMON_MODE_INPUT * scale)
    assert_allclose(st.s_ddot, s_ddot, rtol=0, atol=COMMON_MODE_INPUT * scale)


def test_in_house_table_carries_the_hand_s1_law():
    """The engine's S1 column is eq. (28) (the engine reads the shared motion, not a copy of it)."""
    table = solve_case(_sinusoidal_case())
    th = np.radians(np.arange(0.0, 360.0, 15.0))
    assert_allclose(table["theta1_deg"], np.degrees(th), rtol=0, atol=COMMON_MODE_INPUT * 360)
    assert_allclose(table["S1"], 3.5 + 2.0 * np.sin(2.0 * th), rtol=0, atol=COMMON_MODE_INPUT * 5.5)
