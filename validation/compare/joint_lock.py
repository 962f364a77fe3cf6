"""Near a universal joint's lock: how fast its cross turns, and how much a judge's tolerance may widen there.

With a universal joint at the slider (``docs/conventions.md``, "Rod spin") the joint's cross keeps its
rod-side axis ``a = (u x k4)/|u x k4|``; it turns about ``k4`` by the angle ``psi`` of ``w``, the rod
direction ``u`` projected on the plane normal to ``k4`` (``|w| = sin(rod, k4) = sqrt(1 - c^2)``, ``c``
the closure condition).  Its turning rate per unit crank rate is

.. math::

    \\kappa = \\left|\\frac{d\\psi}{d\\theta_1}\\right|
            = \\frac{|k_4 \\cdot (w \\times du/d\\theta_1)|}{|w|^2},

which grows like ``1/sin`` as the rod passes the slider axis: the conditioning of the simulated loop near
the lock, as ``1/|t|`` is the reactions' near a dead centre.  A judge's tolerance of a rate or reaction
column is multiplied row by row by

.. math::

    f_i = \\min\\left(\\text{cap}, \\max\\left(1, (\\kappa_i/\\kappa_0)^p\\right)\\right)

on the rows whose rod lies within :data:`~dualmech.validation.tolerances.JOINT_LOCK_NEIGHBOURHOOD` of the
slider axis (1 elsewhere), with ``kappa_0``, ``p`` and each judge's ``cap`` in
:mod:`dualmech.validation.tolerances` (the law and its evidence: ``docs/conventions.md``, "Near a joint
lock").  A check whose tolerance was widened says :data:`NEAR_JOINT_LOCK` in its detail.
"""

from __future__ import annotations

import numpy as np

from dualmech.core.table import ResultTable
from dualmech.models.case import Case
from dualmech.validation.compare.results import POSE_COLUMNS
from dualmech.validation.tolerances import (
    JOINT_LOCK_NEIGHBOURHOOD,
    SIM_JOINT_LOCK_EXPONENT,
    SIM_JOINT_LOCK_RATE,
)

#: The pseudo-quantity of each judge's largest widening (``validation/matrix/tolerances.py``).
JOINT_LOCK_CAP = "joint_lock_cap"


def lock_rate(case: Case, table: ResultTable) -> np.ndarray:
    """``kappa`` of the module docstring per row, shape ``(n,)``, from ``table``'s pose (``S1``, ``S4``).

    0 on every row of a case without a universal joint at the slider; NaN where ``S4`` is not given.
    """
    n = len(table)
    if not case.joints.universal:
        return np.zeros(n)
    g, m = case.geometry, case.motion
    theta = np.radians(table["theta1_deg"])
    p2 = np.stack([g.crank_length * np.cos(theta), g.crank_length * np.sin(theta), table["S1"]], -1)
    dp2 = np.stack([-g.crank_length * np.sin(theta), g.crank_length * np.cos(theta),
                    m.axial_amplitude * m.axial_cycles * np.cos(m.axial_cycles * theta)], -1)
    k4 = g.k4
    d = g.foot - table["S4"][:, None] * k4 - p2  # P3 - P2
    with np.errstate(all="ignore"):  # rows without S4, and the assembly limit (d.k4 = 0): NaN
        ds4 = -np.einsum("ij,ij->i", d, dp2) / (d @ k4)  # |P3 - P2| = a2 held: dS4/dtheta1
        length = np.linalg.norm(d, axis=1)[:, None]
        u, du = d / length, (-ds4[:, None] * k4 - dp2) / length
        w = u - (u @ k4)[:, None] * k4
        return np.abs(np.cross(w, du) @ k4) / np.einsum("ij,ij->i", w, w)


def lock_factor(rate: np.ndarray, condition: np.ndarray, cap: float) -> np.ndarray:
    """``f_i`` of the module docstring, shape ``(n,)``: ``rate`` (``kappa``) and the reference's
    ``closure_condition`` per row; 1 outside the neighbourhood, where either is not finite, or if
    ``cap <= 1``."""
    with np.errstate(all="ignore"):
        sine = np.sqrt(np.clip(1.0 - np.square(condition), 0.0, None))
        near = np.isfinite(rate) & (sine < JOINT_LOCK_NEIGHBOURHOOD.value)
        law = np.power(np.where(near, rate, 0.0) / SIM_JOINT_LOCK_RATE.value, SIM_JOINT_LOCK_EXPONENT.value)
    return np.where(near, np.clip(law, 1.0, max(cap, 1.0)), 1.0)


def widened(quantity: str) -> bool:
    """Whether ``quantity``'s tolerance is widened near a lock: rates and reactions, not the pose."""
    return quantity not in POSE_COLUMNS
