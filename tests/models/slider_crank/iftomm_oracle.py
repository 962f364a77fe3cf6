"""An independent model of the IFToMM spatial slider crank, in the benchmark's own frame (tests only).

It shares nothing with dualmech: no dual numbers, no loop table, no case file, no frame mapping. The
benchmark (Haug 1989; IFToMM multibody benchmark library; the parameters of EXUDYN's
``TestModels/sliderCrank3Dbenchmark.py``) is written out again in the IFToMM frame ``(X, Y, Z)``: the
crank turns by :math:`\\varphi` about +X through ``A = (0, 0.1, 0.12)``, its pin is

.. math:: B = A + L_1 (0, -\\sin\\varphi, \\cos\\varphi),\\qquad C = (x_C, 0, 0),\\quad
          x_C = \\sqrt{L_2^2 - B_Y^2 - B_Z^2}

(the slider on +X). Per unit crank rate the rod turns with
:math:`\\omega = u\\times(C' - B')/L_2 + s\\,u` (``u = (C - B)/L_2``); the universal joint at ``C``
(slider-side axis X, rod-side axis ``u x X``) allows no rotation about ``n = (u x X) x X``, which fixes
the spin ``s`` by :math:`\\omega\\cdot n = 0`; a ball joint there (``universal=False``) leaves the zero
spin ``s = 0``. With the generalized inertia :math:`I(\\varphi)` and the potential
:math:`V(\\varphi)` (zero at ``Z = 0``) the motion is Lagrange's

.. math:: I\\ddot\\varphi + \\tfrac12 I'\\dot\\varphi^2 + V' = 0,

with :math:`I'` and :math:`V'` by the complex step (every function here is analytic). SI units.
"""

from __future__ import annotations

import numpy as np

#: The benchmark's data (SI): crank pivot, lengths, masses, central inertias, gravity, initial rate.
PIVOT = np.array([0.0, 0.1, 0.12])
CRANK, ROD = 0.08, 0.3
MASSES = (0.12, 0.5, 2.0)
CRANK_AXIAL_INERTIA = 1e-4
ROD_AXIAL_INERTIA, ROD_TRANSVERSE_INERTIA = 4e-4, 4e-3
GRAVITY = 9.81
RATE0 = 6.0
#: Complex step, rad: h**2 vanishes against 1 in double precision.
_STEP = 1e-60


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product of ``(..., 3)`` arrays, complex-safe."""
    return np.stack([a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1],
                     a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
                     a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]], -1)


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return (a * b).sum(-1)


def pose(phi: np.ndarray) -> dict[str, np.ndarray]:
    """Points ``B``, ``C`` ``(n, 3)`` and, per unit crank rate, their velocities ``dB``, ``dC`` and the
    rod's zero-spin angular velocity ``w_perp`` ``(n, 3)`` and unit vector ``u`` (IFToMM frame)."""
    phi = np.atleast_1d(phi)
    zero = 0.0 * phi
    b = PIVOT + CRANK * np.stack([zero, -np.sin(phi), np.cos(phi)], -1)
    db = CRANK * np.stack([zero, -np.cos(phi), -np.sin(phi)], -1)
    xc = np.sqrt(ROD**2 - b[:, 1] ** 2 - b[:, 2] ** 2)
    c = np.stack([xc, zero, zero], -1)
    dc = np.stack([-(b[:, 1] * db[:, 1] + b[:, 2] * db[:, 2]) / xc, zero, zero], -1)
    u = (c - b) / ROD
    return {"B": b, "C": c, "dB": db, "dC": dc, "u": u, "w_perp": _cross(u, dc - db) / ROD}


def rod_spin(p: dict[str, np.ndarray]) -> np.ndarray:
    """Spin ``s`` ``(n,)`` of the rod about ``u`` per unit crank rate with the universal joint."""
    x = np.array([1.0, 0.0, 0.0])
    n = _cross(_cross(p["u"], x), x)
    return -_dot(p["w_perp"], n) / _dot(p["u"], n)


def inertia(phi: np.ndarray, universal: bool = True) -> np.ndarray:
    """Generalized inertia :math:`I(\\varphi)` ``(n,)``, kg m^2."""
    return _inertia_of(pose(phi), universal)


def _inertia_of(p: dict[str, np.ndarray], universal: bool) -> np.ndarray:
    """:func:`inertia` at the :func:`pose` ``p``."""
    u = p["u"]
    w = p["w_perp"] + (rod_spin(p)[:, None] * u if universal else 0.0)
    w_axial = _dot(w, u)
    rod_rotation = ROD_AXIAL_INERTIA * w_axial**2 + ROD_TRANSVERSE_INERTIA * (_dot(w, w) - w_axial**2)
    v_rod = (p["dB"] + p["dC"]) / 2
    m1, m2, m3 = MASSES
    return (CRANK_AXIAL_INERTIA + m1 * (CRANK / 2) ** 2 + m2 * _dot(v_rod, v_rod) + rod_rotation
            + m3 * p["dC"][:, 0] ** 2)


def potential(phi: np.ndarray) -> np.ndarray:
    """Gravity's potential ``(n,)``, J, zero at ``Z = 0`` (the slider's height)."""
    return _potential_of(pose(phi))


def _potential_of(p: dict[str, np.ndarray]) -> np.ndarray:
    """:func:`potential` at the :func:`pose` ``p``."""
    m1, m2, _ = MASSES
    return GRAVITY * (m1 * (PIVOT[2] + p["B"][:, 2]) / 2 + m2 * p["B"][:, 2] / 2)


def acceleration(phi: np.ndarray, rate: np.ndarray, universal: bool = True) -> np.ndarray:
    """Crank acceleration ``(n,)``, rad/s^2, of the free motion.

    One pose at the complex angle :math:`\\varphi + ih` gives :math:`I` and :math:`V` with their slopes: the
    real part of an analytic function there is its value (off by :math:`h^2 f''/2`, nothing in double
    precision), the imaginary part over ``h`` its derivative."""
    p = pose(np.atleast_1d(phi) + 1j * _STEP)
    i, v = _inertia_of(p, universal), _potential_of(p)
    return -(0.5 * np.imag(i) / _STEP * rate**2 + np.imag(v) / _STEP) / np.real(i)


def energy(phi: np.ndarray, rate: np.ndarray, universal: bool = True) -> np.ndarray:
    """Total energy ``(n,)``, J (potential zero at ``Z = 0``)."""
    return 0.5 * inertia(np.atleast_1d(phi), universal) * rate**2 + potential(phi)


def slider_x(phi: np.ndarray) -> np.ndarray:
    """The slider's X ``(n,)``, m."""
    return pose(phi)["C"][:, 0]


def simulate(t: np.ndarray, universal: bool = True, rtol: float = 1e-13) -> tuple[np.ndarray, np.ndarray]:
    """Crank angle and rate ``(n,)`` at times ``t`` (s, from 0), from ``phi = 0``, rate 6 rad/s."""
    from scipy.integrate import solve_ivp

    def rhs(_t: float, y: np.ndarray) -> np.ndarray:
        return np.array([y[1], acceleration(y[0], y[1], universal)[0]])

    sol = solve_ivp(rhs, (0.0, t[-1]), [0.0, RATE0], method="DOP853", t_eval=t, rtol=rtol,
                    atol=[1e-14, 1e-13])
    return sol.y[0], sol.y[1]
