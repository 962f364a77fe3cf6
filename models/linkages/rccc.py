"""The RCCC linkage (Yang 1971) by the dual-number method: one input revolute, three cylindrical joints.

::

    row  joint              theta      S      eta  alpha        a
    1    revolute (1)       theta1*    s1     0    alpha12      a12
    2    cylindrical (2)    theta2?    s2?    0    alpha23      a23
    3    cylindrical (3)    theta3?    s3?    0    alpha34      a34
    4    cylindrical (4)    theta4?    s4?    0    alpha41      a41

    * prescribed input   ? unknown

The primary (real) part of the loop equation is the spherical four-bar of the four axes, the
dual part is then linear in the slides: the start estimate solves the spherical part in closed
form (the axis ``z3`` on the two cones about ``z2`` and ``z4``, :func:`spherical_estimate`) with
the slides at 0 (:func:`estimate`); the closure finds the slides and polishes the angles.

The in-house engine is the loop engine on the RCCC's preset table (:mod:`dualmech.models.loop.preset_engine`;
its forward dynamics :mod:`dualmech.models.loop.preset_dynamics`), started from :func:`spherical_estimate`
and :func:`estimate` and read back by these columns and the RSSR's status rules.  (The closed-form pipeline
on this table, closure, rates and Newton-Euler reactions with each cylinder's zero axial force and moment
as rows, is the tests' oracle: ``tests/linkage_oracles.py``.)
"""

from __future__ import annotations

import math

import numpy as np

from dualmech.core.loop import LoopState
from dualmech.models.linkages.rccc_case import RcccGeometry
from dualmech.models.tables import TableSpec

JOINTS = ("j1", "j2", "j3", "j4")
#: Output columns of an RCCC result table, in order (``docs/conventions.md``, "RCCC").
COLUMNS: tuple[str, ...] = (
    "theta1_deg", "theta4_deg", "s4", "theta4_dot", "s4_dot", "theta4_ddot", "s4_ddot",
    *(f"{j}_{k}{axis}" for j in JOINTS for k in "fm" for axis in "xyz"),
    "drive_torque", "output_torque", "transmission_out", "residual", "dynamics_residual",
)
REACTIONS: tuple[str, ...] = COLUMNS[7:33] + ("dynamics_residual",)
POSE: tuple[str, ...] = ("theta4_deg", "s4", "transmission_out")
RATES: tuple[str, ...] = ("theta4_dot", "s4_dot", "theta4_ddot", "s4_ddot")
SPEC = TableSpec(COLUMNS, POSE, RATES, REACTIONS)


def _rot(axis: int, angle: np.ndarray) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    out = np.zeros(angle.shape + (3, 3))
    out[..., axis, axis] = 1.0
    out[..., i, i], out[..., j, j], out[..., i, j], out[..., j, i] = c, c, -s, s
    return out


def axes(geom: RcccGeometry, theta1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``z2`` ``(n, 3)`` (turning with the input) and ``z4`` ``(3,)`` (fixed), world axes."""
    z2 = (_rot(2, theta1) @ _rot(0, np.full_like(theta1, geom.alpha[0])))[:, :, 2]
    z4 = _rot(0, np.array(-geom.alpha[3]))[:, 2]
    return z2, z4


def spherical_estimate(geom: RcccGeometry, theta1: np.ndarray, branch: int
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Axis ``z3`` ``(n, 3)`` with ``z2·z3 = cos alpha23``, ``z3·z4 = cos alpha34`` and
    ``sign(det[z2, z3, z4]) = branch``, and the reach ``rho = |a z2 + b z4|^2`` (> 1: no assembly).

    ``z3 = a z2 + b z4 + c z2 x z4`` with ``a + b g = cos alpha23``, ``a g + b = cos alpha34``
    (``g = z2·z4``) and ``c^2 |z2 x z4|^2 = 1 - rho``; ``det[z2, z3, z4] = -c |z2 x z4|^2``.
    """
    z2, z4 = axes(geom, theta1)
    g = z2 @ z4
    c23, c34 = math.cos(geom.alpha[1]), math.cos(geom.alpha[2])
    with np.errstate(divide="ignore", invalid="ignore"):
        det = 1.0 - g**2
        a, b = (c23 - g * c34) / det, (c34 - g * c23) / det
        rho = a**2 + b**2 + 2 * a * b * g
        c = -branch * np.sqrt(np.maximum(1.0 - rho, 0.0) / det)
    return a[:, None] * z2 + b[:, None] * z4 + c[:, None] * np.cross(z2, z4), rho


def _angle(x_from: np.ndarray, x_to: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Angle about ``z`` from ``x_from`` to ``x_to`` (all ``(n, 3)``, the x's normal to ``z``)."""
    return np.arctan2(np.einsum("ni,ni->n", np.cross(x_from, x_to), z), np.einsum("ni,ni->n", x_from, x_to))


def estimate(geom: RcccGeometry, theta1: np.ndarray, z3: np.ndarray) -> LoopState:
    """Loop unknowns from the axis ``z3``: the joint angles of the spherical part, the slides 0."""
    z2, z4 = axes(geom, theta1)
    z4 = np.broadcast_to(z4, z2.shape)
    x2 = _rot(2, theta1)[:, :, 0]
    x3, x4 = (np.cross(za, zb) / np.sin(alpha) for za, zb, alpha in ((z2, z3, geom.alpha[1]),
                                                                      (z3, z4, geom.alpha[2])))
    x1 = np.broadcast_to([1.0, 0.0, 0.0], z2.shape)
    zero = np.zeros_like(theta1)
    scalars = np.stack([_angle(x2, x3, z2), zero, _angle(x3, x4, z3), zero, _angle(x4, x1, z4), zero], 1)
    return LoopState(scalars, np.zeros((theta1.shape[0], 0, 3, 3)))


