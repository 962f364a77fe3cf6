"""Shared test fixtures: the bundled thesis cases and closed-form oracles."""

from __future__ import annotations

import numpy as np
import pytest

from dualmech.core.dual import Dual, dcos, dsin, dsqrt
from dualmech.models.case import Case, load_case, preset_names


@pytest.fixture(scope="session")
def thesis_cases() -> list[Case]:
    return [load_case(n) for n in preset_names() if n.startswith("thesis/")]


def closed_form_s4(case: Case, theta: Dual) -> Dual:
    """Sphere-line intersection S4(theta1) on the branch (P3-P2).k4 < 0 -- a test oracle only.

    ``theta`` is a dual number (value, derivative seed); the result carries dS4/dtheta1.
    Works with complex values for complex-step second derivatives.
    """
    g, m = case.geometry, case.motion
    s1 = Dual.of(g.crank_axial_shift) + dsin(theta * m.axial_cycles) * m.axial_amplitude
    a = g.slider_twist
    kx, ky, kz = 0.0, np.sin(a), np.cos(a)
    dx = dcos(theta) * g.crank_length + Dual.of(g.slider_offset)
    dy = dsin(theta) * g.crank_length
    dz = s1
    kd = dy * ky + dz * kz + dx * kx
    disc = kd * kd - (dx * dx + dy * dy + dz * dz) + Dual.of(g.rod_length**2)
    return -kd + dsqrt(disc)


def exact_slider_motion(case: Case, theta: np.ndarray):
    """S4, S4_dot, S4_ddot from the closed form: first derivative by dual numbers, second by complex step."""
    h = 1e-30
    th = Dual(theta.astype(complex) + 1j * h, np.ones(theta.shape, dtype=complex))
    r = closed_form_s4(case, th)
    d1, d2 = r.du.real, r.du.imag / h
    w, wd = case.motion.speed, case.motion.accel
    return r.re.real, d1 * w, d2 * w * w + d1 * wd


def assembly_margin(case: Case, theta: np.ndarray) -> np.ndarray:
    """a2^2 minus the squared distance from P2 to the slider line (< 0: the rod cannot reach)."""
    g, m = case.geometry, case.motion
    s1 = g.crank_axial_shift + m.axial_amplitude * np.sin(m.axial_cycles * theta)
    a = g.slider_twist
    d = np.stack([g.crank_length * np.cos(theta) + g.slider_offset, g.crank_length * np.sin(theta), s1], 1)
    k = np.array([0.0, np.sin(a), np.cos(a)])
    return g.rod_length**2 - ((d * d).sum(1) - (d @ k) ** 2)
