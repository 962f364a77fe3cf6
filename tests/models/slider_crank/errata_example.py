"""The thesis example the errata tests evaluate (``docs/errata.md``), and the rotation helpers they share.

Shapes are ``(S1, a1, a2, a4, alpha4)`` in inches and radians; the crank turns at 50 rpm.
"""

from __future__ import annotations

import math

import numpy as np

W1 = 2 * math.pi * 50 / 60  # thesis example: 50 rpm
PLANAR = (0.0, 12.0, 50.0, 30.0, math.radians(270.0))  # (S1, a1, a2, a4, alpha4)
SPATIAL_S1 = (3.5, 12.0, 50.0, 30.0, math.radians(270.0))
SPATIAL_TWIST = (0.0, 12.0, 50.0, 20.0, math.radians(232.0))
GRID = np.radians(np.arange(0.0, 360.0, 2.0))


def rz(t):
    """Rotations about z by the angles ``t``, ``t.shape + (3, 3)``."""
    c, s = np.cos(t), np.sin(t)
    out = np.zeros(t.shape + (3, 3))
    out[..., 0, 0], out[..., 0, 1], out[..., 1, 0], out[..., 1, 1], out[..., 2, 2] = c, -s, s, c, 1
    return out


def ry(t):
    """Rotations about y by the angles ``t``, ``t.shape + (3, 3)``."""
    c, s = np.cos(t), np.sin(t)
    out = np.zeros(t.shape + (3, 3))
    out[..., 0, 0], out[..., 0, 2], out[..., 2, 0], out[..., 2, 2], out[..., 1, 1] = c, s, -s, c, 1
    return out


def vee(m):
    """The axial vector of the skew part of ``m``, ``(..., 3)``."""
    return 0.5 * np.stack(
        [m[..., 2, 1] - m[..., 1, 2], m[..., 0, 2] - m[..., 2, 0], m[..., 1, 0] - m[..., 0, 1]], -1
    )
