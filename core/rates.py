"""Velocity and acceleration analysis with dual velocity vectors (thesis section 2.7).

At a closed position the dual velocity of the last link relative to the first
is the sum of the elementary screws times their rates, and it must vanish:

.. math:: \\sum_j \\hat s_j \\dot q_j = 0 \\qquad (\\text{eq. 29-37, in world coordinates})

Differentiating once more, each screw moves with the twist :math:`\\hat V_{c(j)}`
of the body that carries it, :math:`\\dot{\\hat s}_j = \\hat V_{c(j)} \\times \\hat s_j`:

.. math:: \\sum_j \\hat s_j \\ddot q_j + \\sum_j \\hat V_{c(j)} \\times \\hat s_j \\dot q_j = 0

which replaces the printed closed formulas (38a)-(42a) (errata E4-E5).  The
spin gauge adds, per gauged link, :math:`u\\cdot\\omega = 0` and
:math:`u\\cdot\\dot\\omega = 0` (:math:`\\omega\\cdot(\\omega\\times u)=0` makes the
second the derivative of the first).

The unknown rates come from the link twists, never from the Z-Y joint angles,
so the parametrization singularities of eq. (2)-(3) cannot reach them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dualmech.core.closure import least_squares
from dualmech.core.dual import Dual, dcross, scalar_type
from dualmech.core.loop import Chain, Loop, gauge_rows


@dataclass(frozen=True)
class Rates:
    """Rates and accelerations of a closed loop at ``n`` positions.

    Attributes
    ----------
    q_dot, q_ddot : numpy.ndarray, shape (n, loop.n_unknown)
        Unknown rates in the order of the tangent step (scalars, then 3 per
        spherical row: relative angular velocity in the axes of the frame before
        the joint).
    link_twist, link_accel : list of Dual, one ``(n, 3)`` per table row
        Absolute twist :math:`\\omega + \\varepsilon v_O` of the link each row carries,
        and its time derivative (spatial acceleration
        :math:`\\dot\\omega + \\varepsilon \\dot v_O`).
    """

    q_dot: np.ndarray
    q_ddot: np.ndarray
    link_twist: list[Dual]
    link_accel: list[Dual]


def _rate_matrix(chain: Chain, loop: Loop) -> tuple[np.ndarray, np.ndarray]:
    """Matrix ``(n, 6+g, k)`` of the unknown screws with gauge rows, and the screw-to-gauge rows
    ``(n, g, m)``."""
    n = chain.closure.re.shape[0]
    g = len(loop.spin_gauges)
    kind = scalar_type(chain.closure.re, chain.closure.du)
    mat = np.zeros((n, 6 + g, loop.n_unknown), kind)
    rows, _ = gauge_rows(chain, loop) if g else (np.zeros((n, 0, len(chain.screws)), kind), None)
    for j, s in enumerate(chain.screws):
        if s.var[0] == "unknown":
            mat[:, :3, s.var[1]] = s.line.re
            mat[:, 3:6, s.var[1]] = s.line.du
            mat[:, 6:, s.var[1]] = rows[:, :, j]
    return mat, rows


def _screw_values(chain: Chain, known: dict[str, np.ndarray], unknown: np.ndarray) -> np.ndarray:
    """Per-screw values ``(n, m)`` from the inputs' and the unknowns' rates."""
    return np.stack([known[s.var[1]] if s.var[0] == "input" else unknown[:, s.var[1]] for s in chain.screws],
                    axis=1)


def _motion_sum(chain: Chain, values: np.ndarray, upto_row: int | None = None) -> Dual:
    """:math:`\\sum_j \\hat s_j x_j` over the screws of rows ``<= upto_row`` (all if None)."""
    re = np.zeros(values.shape[:1] + (3,), scalar_type(values, chain.closure.re, chain.closure.du))
    du = np.zeros_like(re)
    for j, s in enumerate(chain.screws):
        if upto_row is None or s.row <= upto_row:
            re += s.line.re * values[:, j, None]
            du += s.line.du * values[:, j, None]
    return Dual(re, du)


def _transport(chain: Chain, rates: np.ndarray) -> list[Dual]:
    """Per screw, :math:`\\hat V_{c(j)}\\times\\hat s_j \\dot q_j` -- the rate at which the carried screw
    turns."""
    out = []
    cumulative = [Dual(np.zeros(rates.shape[:1] + (3,)), np.zeros(rates.shape[:1] + (3,)))]
    for j, s in enumerate(chain.screws):
        motion = s.line * rates[:, j, None]
        cumulative.append(cumulative[-1] + motion)
        out.append(dcross(cumulative[s.carrier], motion))
    return out


def solve_rates(chain: Chain, loop: Loop, input_rates: dict[str, np.ndarray],
                input_accels: dict[str, np.ndarray]) -> Rates:
    """Velocity and acceleration analysis of the closed loop ``chain``.

    Parameters
    ----------
    chain : Chain
        The loop evaluated at its closed positions.
    input_rates, input_accels : dict of name -> ``(n,)`` array
        First and second time derivatives of every input.

    Returns
    -------
    Rates
    """
    n = chain.closure.re.shape[0]
    mat, gauge = _rate_matrix(chain, loop)
    zeros = np.zeros(n * loop.n_unknown).reshape(n, loop.n_unknown)
    known = _screw_values(chain, input_rates, zeros)
    rhs_v = -np.concatenate([_motion_sum(chain, known).stacked(), np.einsum("ngm,nm->ng", gauge, known)],
                            axis=1)
    q_dot = least_squares(mat, rhs_v)

    rates = _screw_values(chain, input_rates, q_dot)
    transport = _transport(chain, rates)
    known_acc = _screw_values(chain, input_accels, zeros)
    bias_all = _sum_duals(transport, range(len(chain.screws)), n)
    bias_gauge = []
    for g, r in enumerate(loop.spin_gauges):
        sel = [j for j, s in enumerate(chain.screws) if s.row <= r]
        b = _sum_duals(transport, sel, n)
        _, axes = gauge_rows(chain, loop)
        bias_gauge.append(np.einsum("ni,ni->n", axes[:, g], b.re))
    rhs_a = -np.concatenate(
        [
            (_motion_sum(chain, known_acc) + bias_all).stacked(),
            np.einsum("ngm,nm->ng", gauge, known_acc) + (np.stack(bias_gauge, axis=1) if bias_gauge else 0.0),
        ],
        axis=1,
    )
    q_ddot = least_squares(mat, rhs_a)
    accels = _screw_values(chain, input_accels, q_ddot)

    twists, accs = [], []
    for i in range(len(loop.rows)):
        sel = [j for j, s in enumerate(chain.screws) if s.row <= i]
        twists.append(_motion_sum(chain, rates, i))
        accs.append(_motion_sum(chain, accels, i) + _sum_duals(transport, sel, n))
    return Rates(q_dot, q_ddot, twists, accs)


def _sum_duals(items: list[Dual], indices, n: int) -> Dual:
    re = np.zeros((n, 3))
    du = np.zeros((n, 3))
    for j in indices:
        re = re + items[j].re
        du = du + items[j].du
    return Dual(re, du)
