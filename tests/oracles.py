"""The tests' one closed-form oracle of the slider crank's kinematics, pure numpy.

It shares nothing with the engines under test: no dual numbers, no loop table, no solver, and
not even the package's derived geometry or axial law (``F``, ``k4``, ``P2`` and ``S1`` are
written out again here from ``docs/conventions.md``, so a fault in
:mod:`dualmech.models.mechanism` or :class:`dualmech.core.motion.CrankMotion` cannot hide in the
oracle).  The slider pin is the intersection of the sphere of radius ``a2`` about the crank pin
with the slider line, on the assembly branch ``(P3 - P2)·k4 < 0``:

.. math:: S_4 = -d\\cdot k_4 + \\sqrt{(d\\cdot k_4)^2 - d\\cdot d + a_2^2},\\qquad d = P_2 - F

and its rates follow from differentiating :math:`|P_3 - P_2|^2 = a_2^2` with :math:`e = P_3 - P_2`:

.. math:: \\dot S_4 = -\\frac{e\\cdot\\dot P_2}{e\\cdot k_4},\\qquad
          \\ddot S_4 = \\frac{\\dot e\\cdot\\dot e - e\\cdot\\ddot P_2}{e\\cdot k_4}.

Arrays are ``(n,)`` or ``(n, 3)`` (world axes) over the crank positions; NaN where the rod
cannot reach the slider line.
"""

from __future__ import annotations

import numpy as np
from numpy.testing import assert_allclose

from dualmech.models.case import Case


def slider_line(a4: float, alpha4: float) -> tuple[np.ndarray, np.ndarray]:
    """``F = (-a4, 0, 0)`` and ``k4 = (0, sin alpha4, cos alpha4)`` (alpha4 in radians), ``(3,)`` each."""
    return np.array([-a4, 0.0, 0.0]), np.array([0.0, np.sin(alpha4), np.cos(alpha4)])


def axial(case: Case, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``S1 = S1,0 + S_S1 sin(alpha theta1)`` and its first two derivatives in theta1 (thesis eq. 27),
    ``(n,)`` each."""
    g, m = case.geometry, case.motion
    phase = m.axial_cycles * theta
    return (g.crank_axial_shift + m.axial_amplitude * np.sin(phase),
            m.axial_amplitude * m.axial_cycles * np.cos(phase),
            -m.axial_amplitude * m.axial_cycles**2 * np.sin(phase))


def sphere_line_s4(p2: np.ndarray, foot: np.ndarray, k4: np.ndarray, a2: float) -> np.ndarray:
    """``S4`` of the intersection on the assembly branch, ``(n,)`` for ``p2`` ``(n, 3)`` (NaN if none)."""
    d = np.atleast_2d(p2) - foot
    kd = d @ k4
    with np.errstate(invalid="ignore"):
        return -kd + np.sqrt(kd**2 - (d * d).sum(-1) + a2**2)


def assembly_margin(case: Case, theta: np.ndarray) -> np.ndarray:
    """``a2^2`` minus the squared distance from ``P2`` to the slider line, ``(n,)`` (< 0: the rod cannot
    reach)."""
    g = case.geometry
    foot, k4 = slider_line(g.slider_offset, np.radians(g.slider_twist_deg))
    s1 = axial(case, theta)[0]
    d = np.stack([g.crank_length * np.cos(theta), g.crank_length * np.sin(theta), s1], -1) - foot
    return g.rod_length**2 - ((d * d).sum(-1) - (d @ k4) ** 2)


def slider_motion(case: Case, theta: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Closed-form kinematics at crank angles ``theta`` (rad; default the case's), the case's constant crank
    speed and acceleration.

    Returns ``theta``, ``S1``, ``S1_dot``, ``S1_ddot``, ``F``, ``k4``, ``p2``, ``v2``, ``a2`` (the crank pin's
    position, velocity, acceleration), ``p3``, ``v3``, ``a3`` (the slider pin's) and ``S4``, ``S4_dot``,
    ``S4_ddot``.
    """
    g, m = case.geometry, case.motion
    theta = np.radians(m.angles_deg) if theta is None else np.asarray(theta, dtype=float)
    w, wd = m.speed, m.accel
    foot, k4 = slider_line(g.slider_offset, np.radians(g.slider_twist_deg))
    s, sp, spp = axial(case, theta)
    s_dot, s_ddot = sp * w, spp * w**2 + sp * wd
    a1, c, sn = g.crank_length, np.cos(theta), np.sin(theta)
    p2 = np.stack([a1 * c, a1 * sn, s], -1)
    v2 = np.stack([-a1 * sn * w, a1 * c * w, s_dot], -1)
    acc2 = np.stack([-a1 * c * w**2 - a1 * sn * wd, -a1 * sn * w**2 + a1 * c * wd, s_ddot], -1)
    s4 = sphere_line_s4(p2, foot, k4, g.rod_length)
    p3 = foot - s4[:, None] * k4
    e = p3 - p2
    with np.errstate(invalid="ignore", divide="ignore"):  # e.k4 = 0 at the exact edge of assembly
        s4_dot = -(e * v2).sum(-1) / (e @ k4)
        v3 = -s4_dot[:, None] * k4
        e_dot = v3 - v2
        s4_ddot = ((e_dot * e_dot).sum(-1) - (e * acc2).sum(-1)) / (e @ k4)
    return {"theta": theta, "S1": s, "S1_dot": s_dot, "S1_ddot": s_ddot, "F": foot, "k4": k4,
            "p2": p2, "v2": v2, "a2": acc2, "p3": p3, "v3": v3, "a3": -s4_ddot[:, None] * k4,
            "S4": s4, "S4_dot": s4_dot, "S4_ddot": s4_ddot}


def exact_slider_motion(case: Case, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``S4``, ``S4_dot``, ``S4_ddot`` of :func:`slider_motion`, ``(n,)`` each."""
    mo = slider_motion(case, theta)
    return mo["S4"], mo["S4_dot"], mo["S4_ddot"]


def assert_slider_motion(case: Case, table, tol: float, rows=slice(None), peak_rows=None,
                         label: str = "") -> None:
    """``S4``, ``S4_dot``, ``S4_ddot`` of ``table`` on ``rows`` against :func:`exact_slider_motion`, each
    within ``tol`` times its closed-form peak over ``peak_rows`` (default ``rows``)."""
    exact = exact_slider_motion(case, np.radians(table["theta1_deg"]))
    for q, want in zip(("S4", "S4_dot", "S4_ddot"), exact):
        scale = np.abs(want[rows if peak_rows is None else peak_rows]).max()
        assert_allclose(table[q][rows], want[rows], rtol=0, atol=tol * scale, err_msg=f"{label}{q}")
