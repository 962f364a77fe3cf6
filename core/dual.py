"""Dual numbers, dual 3-vectors and dual 3x3 matrices over a leading batch axis.

A dual quantity is :math:`\\hat a = a + \\varepsilon a^\\circ` with
:math:`\\varepsilon^2 = 0` (Clifford; thesis section 2.4).  Here it is a pair of
real numpy arrays of equal shape: ``re`` (primary part) and ``du`` (dual part).
The trailing axes say what it is -- ``(...)`` a dual number, ``(..., 3)`` a dual
vector, ``(..., 3, 3)`` a dual matrix -- and the leading axes ``...`` are batch
axes (crank positions, cases).

Conventions (``docs/conventions.md``):

* A unit dual vector :math:`\\hat s = s + \\varepsilon\\, p \\times s` is the line
  through point ``p`` with direction ``s`` (Plücker coordinates, moment about the
  world origin).  A twist is :math:`\\omega + \\varepsilon v_O` and a wrench
  :math:`f + \\varepsilon m_O`, with ``v_O`` the velocity of the body point at the
  origin and ``m_O`` the moment about the origin.
* The dual rotation matrix of a frame at ``p`` with orientation ``R`` is
  :math:`\\hat M = R + \\varepsilon [p]_\\times R`; it maps dual vectors in the frame
  to the reference frame, so thesis matrix (1) reads
  :math:`\\hat M_1 = Z(\\hat\\theta_1) X(\\hat\\alpha_1)` with
  :math:`\\hat\\theta_1 = \\theta_1 + \\varepsilon S_1`, :math:`\\hat\\alpha_1 = 0 + \\varepsilon a_1`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Dual:
    """A dual array :math:`re + \\varepsilon\\, du`; ``re`` and ``du`` have equal shapes."""

    re: np.ndarray
    du: np.ndarray

    # -- construction ---------------------------------------------------------
    @staticmethod
    def of(re: np.ndarray | float, du: np.ndarray | float = 0.0) -> "Dual":
        """Build from a primary and a dual part, broadcasting them to one shape."""
        kind = scalar_type(re, du)
        re_arr, du_arr = np.broadcast_arrays(np.asarray(re, dtype=kind), np.asarray(du, dtype=kind))
        return Dual(re_arr, du_arr)

    @property
    def shape(self) -> tuple[int, ...]:
        return self.re.shape

    # -- arithmetic -----------------------------------------------------------
    def __add__(self, other: "Dual") -> "Dual":
        return Dual(self.re + other.re, self.du + other.du)

    def __sub__(self, other: "Dual") -> "Dual":
        return Dual(self.re - other.re, self.du - other.du)

    def __neg__(self) -> "Dual":
        return Dual(-self.re, -self.du)

    def __mul__(self, other: "Dual | np.ndarray | float") -> "Dual":
        """Elementwise product:

        .. math:: (a+\\varepsilon a^\\circ)(b+\\varepsilon b^\\circ)
                  = ab + \\varepsilon(ab^\\circ + a^\\circ b)
        """
        if isinstance(other, Dual):
            return Dual(self.re * other.re, self.re * other.du + self.du * other.re)
        return Dual(self.re * other, self.du * other)

    __rmul__ = __mul__

    def __matmul__(self, other: "Dual") -> "Dual":
        """Dual matrix product (matrix @ matrix, or matrix @ vector when ``other`` is ``(..., 3)``)."""
        if other.re.ndim == self.re.ndim - 1:  # matrix @ vector
            re = np.einsum("...ij,...j->...i", self.re, other.re)
            du = np.einsum("...ij,...j->...i", self.re, other.du) + np.einsum(
                "...ij,...j->...i", self.du, other.re
            )
            return Dual(re, du)
        return Dual(self.re @ other.re, self.re @ other.du + self.du @ other.re)

    @property
    def T(self) -> "Dual":
        """Transpose of a dual matrix (last two axes)."""
        return Dual(np.swapaxes(self.re, -1, -2), np.swapaxes(self.du, -1, -2))

    def column(self, k: int) -> "Dual":
        """Column ``k`` of a dual matrix, a dual vector ``(..., 3)``."""
        return Dual(self.re[..., :, k], self.du[..., :, k])

    def take(self, index: np.ndarray | slice) -> "Dual":
        """Select along the leading batch axis."""
        return Dual(self.re[index], self.du[index])

    def stacked(self) -> np.ndarray:
        """Primary and dual parts of a dual vector as one real ``(..., 6)`` array."""
        return np.concatenate([self.re, self.du], axis=-1)


# -- the scalar field --------------------------------------------------------------

def scalar_type(*values: np.ndarray | float | complex) -> np.dtype:
    """float64, or complex128 where any of ``values`` is complex.

    The numpy core computes over either: complex numbers carry the complex-step derivatives of the
    tolerance study (:mod:`dualmech.models.tolerance.sensitivity`) through the solver's own code, so
    every array the core creates takes the type of its inputs, and every function it applies is
    analytic where a derivative passes (:func:`norm`, not ``numpy.linalg.norm``).
    """
    return np.result_type(*values, np.float64)


def norm(v: np.ndarray, axis: int = -1, keepdims: bool = False) -> np.ndarray:
    """Euclidean length :math:`\\sqrt{v\\cdot v}` along ``axis``.

    The same sum of squares as ``numpy.linalg.norm`` for real ``v``, but analytic in ``v`` (no
    conjugate, no modulus), so a complex step passes through it (:func:`scalar_type`).
    """
    return np.sqrt(np.add.reduce(v * v, axis=axis, keepdims=keepdims))


# -- dual functions (Taylor expansion: f(a + eps b) = f(a) + eps b f'(a)) ----------

def dsin(x: Dual) -> Dual:
    """:math:`\\sin\\hat x = \\sin x + \\varepsilon x^\\circ \\cos x` (thesis section 2.4)."""
    return Dual(np.sin(x.re), x.du * np.cos(x.re))


def dcos(x: Dual) -> Dual:
    """:math:`\\cos\\hat x = \\cos x - \\varepsilon x^\\circ \\sin x`."""
    return Dual(np.cos(x.re), -x.du * np.sin(x.re))


def dsqrt(x: Dual) -> Dual:
    """:math:`\\sqrt{\\hat x} = \\sqrt x + \\varepsilon x^\\circ / (2\\sqrt x)`, for ``x.re > 0``."""
    root = np.sqrt(x.re)
    return Dual(root, x.du / (2.0 * root))


def dcross(a: Dual, b: Dual) -> Dual:
    """Dual cross product of dual vectors:
    :math:`a\\times b + \\varepsilon(a\\times b^\\circ + a^\\circ\\times b)`.

    For a twist ``a`` and a line or twist ``b`` this is the rate of change of
    ``b`` carried by the motion ``a`` (the Lie bracket of screws).
    """
    return Dual(np.cross(a.re, b.re), np.cross(a.re, b.du) + np.cross(a.du, b.re))


def ddot(a: Dual, b: Dual) -> Dual:
    """Dual inner product of dual vectors, a dual number ``(...)``."""
    return Dual(np.einsum("...i,...i->...", a.re, b.re),
                np.einsum("...i,...i->...", a.re, b.du) + np.einsum("...i,...i->...", a.du, b.re))


# -- the rotation builders of thesis sections 2.2 and 2.4 -------------------------

def _rotation(axis: int, angle: Dual) -> Dual:
    c, s = dcos(angle), dsin(angle)
    shape = angle.shape + (3, 3)
    kind = scalar_type(c.re, c.du)
    re, du = np.zeros(shape, kind), np.zeros(shape, kind)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    re[..., axis, axis] = 1.0
    re[..., i, i] = c.re
    re[..., j, j] = c.re
    re[..., i, j] = -s.re
    re[..., j, i] = s.re
    du[..., i, i] = c.du
    du[..., j, j] = c.du
    du[..., i, j] = -s.du
    du[..., j, i] = s.du
    return Dual(re, du)


def rot_x(alpha: Dual) -> Dual:
    """:math:`[X(\\hat\\alpha)]`: rotation ``alpha.re`` about and slide ``alpha.du`` along i."""
    return _rotation(0, alpha)


def rot_y(eta: Dual) -> Dual:
    """:math:`[Y(\\hat\\eta)]`: rotation about and slide along j."""
    return _rotation(1, eta)


def rot_z(theta: Dual) -> Dual:
    """:math:`[Z(\\hat\\theta)]`: rotation about and slide along k."""
    return _rotation(2, theta)


def identity(batch: tuple[int, ...] = ()) -> Dual:
    """The dual identity matrix :math:`\\hat I` (thesis eq. 6)."""
    eye = np.broadcast_to(np.eye(3), batch + (3, 3)).copy()
    return Dual(eye, np.zeros_like(eye))


def from_pose(rotation: np.ndarray, origin: np.ndarray) -> Dual:
    """Dual matrix :math:`R + \\varepsilon [p]_\\times R` of a frame at ``origin`` with orientation
    ``rotation``."""
    return Dual(rotation, skew(origin) @ rotation)


def origin(m: Dual) -> np.ndarray:
    """Origin ``p`` of the frame of dual matrix :math:`R + \\varepsilon [p]_\\times R`, shape ``(..., 3)``."""
    return vee(m.du @ np.swapaxes(m.re, -1, -2))


def skew(v: np.ndarray) -> np.ndarray:
    """Cross-product matrix :math:`[v]_\\times` of ``v`` ``(..., 3)``, shape ``(..., 3, 3)``."""
    out = np.zeros(v.shape + (3,), scalar_type(v))
    out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
    out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
    return out


def vee(m: np.ndarray) -> np.ndarray:
    """Axial vector of the skew-symmetric part of ``m`` ``(..., 3, 3)``, shape ``(..., 3)``."""
    return 0.5 * np.stack(
        [m[..., 2, 1] - m[..., 1, 2], m[..., 0, 2] - m[..., 2, 0], m[..., 1, 0] - m[..., 0, 1]], axis=-1
    )
