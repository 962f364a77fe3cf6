"""The planar slider crank of Sinatra and Angeles: twist-shaping vector, I(psi), C, tau.

::

          j
          |            O2 (crank pin)
          |          /    \\
          |  r12   /        \\  r23 (rod, angle theta)
          |      /  psi       \\
          O1 ---------------------- O3 (slider pin) ---> i     slider line {y = h}
        crank pivot                 s = i . O3

Everything is in the paper's frame: ``i`` along the slider line (the slider's
positive direction), ``j = E i``, origin at the crank pivot ``O1``; the slider
line is ``{y = h}``.  ``psi`` is the crank angle from ``i``, ``theta`` the rod
angle; the assembly branch has the slider ahead of the crank pin
(``i . r23 > 0``).  ``E`` is the 90-degree rotation of eq. (4).

Link data: crank (1), rod (2), slider (3); masses ``m_i``; polar moments
``I_i`` about the mass centres; mass-centre vectors ``r1`` (from ``O1``),
``r2`` (from ``O2``), ``r3`` (from ``O3``), given in link axes (x toward the
next joint) and rotated here.

The paper's printed equations carry errors; this module implements the
derived forms (``docs/errata.md``, S1-S12):

* eq. (30), (35): ``r_0`` is :math:`r_\\theta` (S3);
* eq. (35): the rod block of ``u`` is :math:`-(r_{12} + r_\\theta r_2)^T E`
  (the printed :math:`r_{23}` gives the velocity of the slider pin, not of
  the rod's mass centre; eq. 26 and 56 use :math:`r_2`) (S4);
* eq. (41): the first rod term is :math:`r_\\theta'(r_{12} + r_\\theta r_2)^T r_2`
  (printed :math:`(E r_{12} + r_\\theta r_2)^T r_2`) (S5).

The viscous part of :math:`\\tau` (eq. 43) is not given in the paper; here it is
the Rayleigh dissipation of a crank-bearing damper :math:`c_1` and a slider
damper :math:`c_4` (:func:`generalized_force`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

#: Eq. (4): rotation through +90 degrees in the plane.
E = np.array([[0.0, -1.0], [1.0, 0.0]])
_I = np.array([1.0, 0.0])
_J = np.array([0.0, 1.0])


def _vec2(name: str, value) -> np.ndarray:
    arr = np.asarray(value, dtype=float).reshape(-1)
    if arr.shape != (2,) or not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: expected 2 finite numbers, got {value!r}")
    return arr


@dataclass(frozen=True)
class PlanarSliderCrank:
    """Data of the planar slider crank, paper's frame (module docstring).

    Attributes
    ----------
    crank_length, rod_length : float
        :math:`|r_{12}|`, :math:`|r_{23}|` (length, > 0).
    offset : float
        ``h``: the slider line is ``{y = h}`` (length).
    masses : tuple of 3 floats
        :math:`m_1, m_2, m_3` (> 0).
    polar_inertias : tuple of 2 floats
        :math:`I_1, I_2` about the mass centres (mass·length², >= 0).
    crank_com, rod_com, slider_com : array, shape (2,)
        :math:`r_1, r_2, r_3` in link axes (x toward the next joint).
    gravity : array, shape (2,)
        Gravitational acceleration in the paper's frame.
    """

    crank_length: float
    rod_length: float
    offset: float
    masses: tuple[float, float, float]
    polar_inertias: tuple[float, float]
    crank_com: np.ndarray
    rod_com: np.ndarray
    slider_com: np.ndarray = field(default_factory=lambda: np.zeros(2))
    gravity: np.ndarray = field(default_factory=lambda: np.zeros(2))

    def __post_init__(self) -> None:
        for name in ("crank_length", "rod_length"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise ValueError(f"{name}: expected a positive length, got {v!r}")
        if not np.isfinite(self.offset):
            raise ValueError(f"offset: expected a finite length, got {self.offset!r}")
        if len(self.masses) != 3 or not all(np.isfinite(m) and m > 0 for m in self.masses):
            raise ValueError(f"masses: expected 3 positive numbers, got {self.masses!r}")
        if len(self.polar_inertias) != 2 or not all(np.isfinite(i) and i >= 0 for i in self.polar_inertias):
            raise ValueError(f"polar_inertias: expected 2 numbers >= 0, got {self.polar_inertias!r}")
        for name in ("crank_com", "rod_com", "slider_com", "gravity"):
            object.__setattr__(self, name, _vec2(name, getattr(self, name)))


@dataclass(frozen=True)
class PlanarPose:
    """Link vectors at ``n`` crank angles, paper's frame; vectors ``(n, 2)``, scalars ``(n,)``."""

    r12: np.ndarray
    r23: np.ndarray
    r1: np.ndarray
    r2: np.ndarray
    r3: np.ndarray
    theta: np.ndarray
    s: np.ndarray


def _rotate(angle: np.ndarray, local: np.ndarray) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([c * local[0] - s * local[1], s * local[0] + c * local[1]], axis=-1)


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("...i,...i->...", a, b)


def _e(v: np.ndarray) -> np.ndarray:
    """:math:`E v` for ``v`` ``(..., 2)``."""
    return np.stack([-v[..., 1], v[..., 0]], axis=-1)


def pose(model: PlanarSliderCrank, psi: np.ndarray) -> PlanarPose:
    """Loop closure (eq. 27) on the branch ``i . r23 > 0``.

    Raises
    ------
    ValueError
        If the rod cannot reach the slider line at some ``psi``.
    """
    psi = np.atleast_1d(np.asarray(psi, dtype=float))
    a1, a2, h = model.crank_length, model.rod_length, model.offset
    sin_t = (h - a1 * np.sin(psi)) / a2
    if np.any(np.abs(sin_t) > 1.0):
        bad = np.degrees(psi[np.abs(sin_t) > 1.0])
        raise ValueError(f"psi: the rod cannot reach the slider line at {bad.min():g}..{bad.max():g} deg")
    theta = np.arctan2(sin_t, np.sqrt(1.0 - sin_t**2))
    r12 = a1 * np.stack([np.cos(psi), np.sin(psi)], axis=-1)
    r23 = a2 * np.stack([np.cos(theta), np.sin(theta)], axis=-1)
    r1 = _rotate(psi, model.crank_com)
    r2 = _rotate(theta, model.rod_com)
    r3 = np.broadcast_to(model.slider_com, r12.shape).copy()
    return PlanarPose(r12, r23, r1, r2, r3, theta, (r12 + r23) @ _I)


@dataclass(frozen=True)
class Influence:
    """Influence coefficients (eq. 32) and their derivatives in ``psi``, each ``(n,)``.

    :math:`r_\\theta = \\dot\\theta/\\dot\\psi`, :math:`r_s = \\dot s/\\dot\\psi`,
    :math:`r_\\theta' = dr_\\theta/d\\psi`, :math:`r_s' = dr_s/d\\psi` (eq. 42).
    """

    r_theta: np.ndarray
    r_s: np.ndarray
    r_theta_prime: np.ndarray
    r_s_prime: np.ndarray


def influence(p: PlanarPose) -> Influence:
    """Eq. (32) and the derivative of eq. (30).

    Differentiating :math:`E(r_{12} + r_\\theta r_{23}) - r_s i = 0` in ``psi``
    (:math:`r_{12}' = E r_{12}`, :math:`r_{23}' = r_\\theta E r_{23}`):

    .. math:: -r_{12} + r_\\theta' E r_{23} - r_\\theta^2 r_{23} - r_s' i = 0

    whose ``j`` and :math:`r_{23}` components give

    .. math:: r_\\theta' = \\frac{j\\cdot r_{12} + r_\\theta^2\\, j\\cdot r_{23}}{i\\cdot r_{23}},\\qquad
              r_s' = -\\frac{r_{12}\\cdot r_{23} + r_\\theta^2 |r_{23}|^2}{i\\cdot r_{23}}.
    """
    i_r23 = p.r23 @ _I
    r_theta = -(p.r12 @ _I) / i_r23
    r_s = _dot(p.r23, _e(p.r12)) / i_r23
    r_theta_p = (p.r12 @ _J + r_theta**2 * (p.r23 @ _J)) / i_r23
    r_s_p = -(_dot(p.r12, p.r23) + r_theta**2 * _dot(p.r23, p.r23)) / i_r23
    return Influence(r_theta, r_s, r_theta_p, r_s_p)


def inertia_dyad(model: PlanarSliderCrank) -> np.ndarray:
    """Mechanism inertia dyad ``M = diag(M1, M2, M3)`` (eq. 2, 12, 14), shape ``(9, 9)``.

    The slider's polar moment is irrelevant (:math:`\\omega_3 = 0`) and set to 0.
    """
    m1, m2, m3 = model.masses
    i1, i2 = model.polar_inertias
    return np.diag([i1, m1, m1, i2, m2, m2, 0.0, m3, m3])


def twist_shaping_vector(model: PlanarSliderCrank, psi: np.ndarray) -> np.ndarray:
    """``u(psi)`` of :math:`t = u\\dot\\psi` (eq. 34-35, corrected), shape ``(n, 9)``.

    Order :math:`[\\omega_1, \\dot c_1, \\omega_2, \\dot c_2, \\omega_3, \\dot c_3]/\\dot\\psi`:

    .. math:: u = [1,\\; (E r_1)^T,\\; r_\\theta,\\; (E(r_{12} + r_\\theta r_2))^T,\\; 0,\\; r_s i^T]^T
    """
    p = pose(model, psi)
    k = influence(p)
    n = p.s.shape[0]
    c2 = _e(p.r12 + k.r_theta[:, None] * p.r2)
    c3 = k.r_s[:, None] * _I
    return np.column_stack([np.ones(n), _e(p.r1), k.r_theta, c2, np.zeros(n), c3])


def twist_shaping_derivative(model: PlanarSliderCrank, psi: np.ndarray) -> np.ndarray:
    """:math:`du/d\\psi` (so that :math:`\\dot u = u'\\dot\\psi`, eq. 38), shape ``(n, 9)``.

    .. math:: u' = [0,\\; -r_1^T,\\; r_\\theta',\\;
              (-r_{12} + r_\\theta' E r_2 - r_\\theta^2 r_2)^T,\\; 0,\\; r_s' i^T]^T
    """
    p = pose(model, psi)
    k = influence(p)
    n = p.s.shape[0]
    rt = k.r_theta[:, None]
    c2 = -p.r12 + k.r_theta_prime[:, None] * _e(p.r2) - rt**2 * p.r2
    return np.column_stack([np.zeros(n), -p.r1, k.r_theta_prime, c2, np.zeros(n), k.r_s_prime[:, None] * _I])


def constraint_matrix(model: PlanarSliderCrank, psi: np.ndarray) -> np.ndarray:
    """The ``8 x 9`` matrix ``A`` of :math:`A t = 0` (eq. 19-24), shape ``(n, 8, 9)``.

    Rows: crank–ground (2), rod–crank (2), slider–rod (2), :math:`-\\omega_3 = 0`,
    :math:`-j\\cdot\\dot c_3 = 0`; columns in the order of :func:`twist_shaping_vector`.
    With ``b_i = r_{i,i+1} - r_i``: block rows ``[-E r1, 1]``,
    ``[-E b1, -1, -E r2, 1]``, ``[-E b2, -1, -E r3, 1]``.
    """
    p = pose(model, psi)
    n = p.s.shape[0]
    a = np.zeros((n, 8, 9))
    eye = np.eye(2)
    b1, b2 = p.r12 - p.r1, p.r23 - p.r2
    a[:, 0:2, 0] = -_e(p.r1)
    a[:, 0:2, 1:3] = eye
    a[:, 2:4, 0] = -_e(b1)
    a[:, 2:4, 1:3] = -eye
    a[:, 2:4, 3] = -_e(p.r2)
    a[:, 2:4, 4:6] = eye
    a[:, 4:6, 3] = -_e(b2)
    a[:, 4:6, 4:6] = -eye
    a[:, 4:6, 6] = -_e(p.r3)
    a[:, 4:6, 7:9] = eye
    a[:, 6, 6] = -1.0
    a[:, 7, 7:9] = -_J
    return a


def generalized_inertia(model: PlanarSliderCrank, psi: np.ndarray) -> np.ndarray:
    """Eq. (40), shape ``(n,)``.

    .. math:: I = I_1 + m_1|r_1|^2 + r_\\theta^2 I_2 + m_2|r_{12} + r_\\theta r_2|^2 + m_3 r_s^2
    """
    p = pose(model, psi)
    k = influence(p)
    m1, m2, m3 = model.masses
    i1, i2 = model.polar_inertias
    a = p.r12 + k.r_theta[:, None] * p.r2
    return i1 + m1 * _dot(p.r1, p.r1) + k.r_theta**2 * i2 + m2 * _dot(a, a) + m3 * k.r_s**2


def generalized_inertia_derivative(model: PlanarSliderCrank, psi: np.ndarray) -> np.ndarray:
    """:math:`dI/d\\psi = 2u^T M u'` (``M`` is constant in the plane), ``(n,)``.

    .. math:: \\tfrac12 I' = r_\\theta r_\\theta' I_2 + m_2[r_\\theta'(r_{12} + r_\\theta r_2)^T r_2
              + r_\\theta(r_\\theta - 1)\\, r_{12}^T E r_2] + m_3 r_s r_s'
    """
    p = pose(model, psi)
    k = influence(p)
    _, m2, m3 = model.masses
    i2 = model.polar_inertias[1]
    a = p.r12 + k.r_theta[:, None] * p.r2
    rod = k.r_theta_prime * _dot(a, p.r2) + k.r_theta * (k.r_theta - 1.0) * _dot(p.r12, _e(p.r2))
    return 2.0 * (k.r_theta * k.r_theta_prime * i2 + m2 * rod + m3 * k.r_s * k.r_s_prime)


def coriolis(model: PlanarSliderCrank, psi: np.ndarray, psi_dot: np.ndarray | float) -> np.ndarray:
    """Eq. (41), corrected: :math:`C(\\psi, \\dot\\psi) = -\\tfrac12 I'(\\psi)\\dot\\psi`, ``(n,)``.

    So that :math:`I\\ddot\\psi = C\\dot\\psi + \\tau` (eq. 39).
    """
    return -0.5 * generalized_inertia_derivative(model, psi) * psi_dot


def gravity_torque(model: PlanarSliderCrank, psi: np.ndarray) -> np.ndarray:
    """:math:`\\tau^G = u^T w^G = \\sum_i m_i\\, g\\cdot\\dot c_i/\\dot\\psi`, ``(n,)``."""
    u = twist_shaping_vector(model, psi)
    m1, m2, m3 = model.masses
    g = model.gravity
    return m1 * (u[:, 1:3] @ g) + m2 * (u[:, 4:6] @ g) + m3 * (u[:, 7:9] @ g)


def generalized_force(model: PlanarSliderCrank, psi: np.ndarray, psi_dot: np.ndarray | float,
                      drive_torque: np.ndarray | float = 0.0, crank_damping: float = 0.0,
                      slider_damping: float = 0.0, slider_force: np.ndarray | float = 0.0) -> np.ndarray:
    """Eq. (43): :math:`\\tau = \\tau^A + \\tau^G + \\tau^D`, plus a load on the slider, ``(n,)``.

    Parameters
    ----------
    drive_torque : float or (n,)
        :math:`\\tau^A`, the motor torque on the crank (counter-clockwise positive).
    crank_damping, slider_damping : float
        :math:`c_1` (torque per rad/s) and :math:`c_4` (force per length/s):
        :math:`\\tau^D = -(c_1 + c_4 r_s^2)\\dot\\psi`.
    slider_force : float or (n,)
        Force on the slider along ``i``; contributes :math:`f\\,r_s` (``u^T w_3``).
    """
    k = influence(pose(model, psi))
    damping = -(crank_damping + slider_damping * k.r_s**2) * psi_dot
    return drive_torque + gravity_torque(model, psi) + damping + np.asarray(slider_force) * k.r_s


def acceleration(model: PlanarSliderCrank, psi: np.ndarray, psi_dot: np.ndarray | float,
                 tau: np.ndarray | float) -> np.ndarray:
    """Eq. (39) solved for :math:`\\ddot\\psi = (C\\dot\\psi + \\tau)/I`, ``(n,)``."""
    return (coriolis(model, psi, psi_dot) * psi_dot + tau) / generalized_inertia(model, psi)


def mass_centre(model: PlanarSliderCrank, psi: np.ndarray) -> np.ndarray:
    """Mass centre ``c`` of the moving links (eq. 44), paper's frame, ``(n, 2)``."""
    p = pose(model, psi)
    m1, m2, m3 = model.masses
    c1 = p.r1
    c2 = p.r12 + p.r2
    c3 = p.r12 + p.r23 + p.r3
    return (m1 * c1 + m2 * c2 + m3 * c3) / (m1 + m2 + m3)
