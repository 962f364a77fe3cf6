"""Inverse dynamics of any single loop: every joint's reaction by batched least squares (the RSSR's and
RCCC's closed-form oracles', ``tests/linkage_oracles.py``; the product's inverse dynamics is
:mod:`dualmech.core.loop_reactions`).

Each moving body ``b`` obeys D'Alembert's principle with dual momentum (thesis eq. 59-64, in
world axes, moments about the world origin O; :mod:`dualmech.core.reactions`):

.. math:: \\sum_{j \\ni b} \\pm(f_j + \\varepsilon(P_j\\times f_j + m_j)) = \\dot{\\hat H}_b - \\hat W_b

where joint ``j`` exerts the force :math:`f_j` through its point :math:`P_j` and, if it
carries one, the moment :math:`m_j` (about :math:`P_j`) on its ``body`` and the opposite on
its ``other`` body (or the ground), and :math:`\\hat W_b` is the weight.  A given load adds one
row (``axis · m_j = value``).  The unknown force and moment components of all joints are
solved per position, batched, by an SVD least squares; the moment rows are divided by a
length so that every row is a force.  The relative residual is reported: it is rounding
noise when the equations are consistent (e.g. the zero-spin gauge of a ball-ball link is
only harmless for an axisymmetric link) and the solution is meaningless where the matrix
is rank-deficient (a dead centre of the given load).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dualmech.core.dual import Dual
from dualmech.core.reactions import Body, BodyMotion, force_at, momentum_rate


@dataclass(frozen=True)
class Joint:
    """A joint's reaction on ``body`` (index into the bodies) from ``other`` (-1: the ground).

    ``point`` ``(n, 3)`` world: where the force acts, and the point the moment is taken
    about; ``moment``: whether the joint carries a moment (a ball does not).
    """

    name: str
    body: int
    other: int
    point: np.ndarray
    moment: bool


@dataclass(frozen=True)
class GivenLoad:
    """A known component of a joint's moment (or, with ``force=True``, of its force):
    ``axis · m_joint = value`` (``axis`` ``(n, 3)``, ``value`` ``(n,)``).  A load given at a joint, or
    the zero a cylindrical joint transmits along its axis."""

    joint: int
    axis: np.ndarray
    value: np.ndarray
    force: bool = False


@dataclass(frozen=True)
class JointReactions:
    """Solved reactions at ``n`` positions: per joint name, ``force`` ``(n, 3)`` and ``moment``
    ``(n, 3)`` (about the joint's point; zeros for a ball), world axes; ``residual`` ``(n,)``
    ``|A x - b| / |b|`` of the weighted equations; ``condition`` ``(n,)`` the smallest singular
    value of the weighted matrix over its largest."""

    force: dict[str, np.ndarray]
    moment: dict[str, np.ndarray]
    residual: np.ndarray
    condition: np.ndarray


def _columns(joints: tuple[Joint, ...]) -> list[int]:
    """First unknown column of each joint (3 per force, 3 more per moment), then the total."""
    starts = [0]
    for j in joints:
        starts.append(starts[-1] + (6 if j.moment else 3))
    return starts


def solve_joint_reactions(bodies: tuple[Body, ...], motions: tuple[BodyMotion, ...],
                          joints: tuple[Joint, ...], gravity: np.ndarray, given: tuple[GivenLoad, ...],
                          length: np.ndarray) -> JointReactions:
    """Every joint's force and moment from the Newton-Euler equations of all moving bodies.

    Parameters
    ----------
    bodies, motions : one per moving body (mass properties; motion at ``n`` positions)
    joints : the loop's joints (their ``body`` / ``other`` index ``bodies``)
    gravity : ``(3,)`` or ``(n, 3)`` gravitational acceleration, world axes
    given : the known moment components (one per load given in the case)
    length : ``(n,)`` the length the moment rows are divided by (case units)
    """
    n = motions[0].com.shape[0]
    starts = _columns(joints)
    n_body = len(bodies)
    rows = 6 * n_body + len(given)
    a = np.zeros((n, rows, starts[-1]))
    b = np.zeros((n, rows))
    eye = np.broadcast_to(np.eye(3), (n, 3, 3))
    for j, joint in enumerate(joints):
        c = starts[j]
        p_cross = np.cross(joint.point[:, :, None], eye, axis=1)  # column k: P x e_k
        for target, sign in ((joint.body, 1.0), (joint.other, -1.0)):
            if target < 0:
                continue
            r = 6 * target
            a[:, r:r + 3, c:c + 3] += sign * eye
            a[:, r + 3:r + 6, c:c + 3] += sign * p_cross
            if joint.moment:
                a[:, r + 3:r + 6, c + 3:c + 6] += sign * eye
    for b_i, (body, motion) in enumerate(zip(bodies, motions)):
        mass = np.asarray(body.mass, dtype=float)[..., None]
        weight = force_at(motion.com, mass * np.broadcast_to(gravity, motion.com.shape))
        need: Dual = momentum_rate(body, motion) - weight
        b[:, 6 * b_i:6 * b_i + 3], b[:, 6 * b_i + 3:6 * b_i + 6] = need.re, need.du
    for g, load in enumerate(given):
        c = starts[load.joint] + (0 if load.force else 3)
        a[:, 6 * n_body + g, c:c + 3] = load.axis
        b[:, 6 * n_body + g] = load.value
    weight_rows = np.ones((n, rows))
    weight_rows[:, [6 * k + i for k in range(n_body) for i in (3, 4, 5)]] = 1.0 / length[:, None]
    weight_rows[:, 6 * n_body:] = np.where([g.force for g in given], 1.0, 1.0 / length[:, None])
    a_w, b_w = a * weight_rows[:, :, None], b * weight_rows
    u, s, vt = np.linalg.svd(a_w, full_matrices=False)
    with np.errstate(divide="ignore", invalid="ignore"):
        x = np.einsum("nji,nj->ni", vt, np.einsum("nji,nj->ni", u, b_w) / s)
        residual = np.linalg.norm(np.einsum("nij,nj->ni", a_w, x) - b_w, axis=1) / np.maximum(
            np.linalg.norm(b_w, axis=1), np.finfo(float).tiny)
    force, moment = {}, {}
    for j, joint in enumerate(joints):
        c = starts[j]
        force[joint.name] = x[:, c:c + 3]
        moment[joint.name] = x[:, c + 3:c + 6] if joint.moment else np.zeros((n, 3))
    return JointReactions(force, moment, residual, s[:, -1] / s[:, 0])
