"""The RSSR spatial four-bar: its table's columns, status rules and own start estimate.

::

    row  joint              theta      S     eta  alpha     a      (thesis Table 1 pattern)
    1    revolute (1)       theta1*    s1    0    0         a1
    2    ball (2)           -- free rotation --   0         a2
    3    ball (3)           -- free rotation --   0         a3
    4    revolute (4)       theta4?    -h    0    alpha4    a4

    * prescribed input   ? unknown (the output angle is phi4 = pi - theta4)

The in-house engine is the loop engine on the RSSR's preset table (:mod:`dualmech.models.loop.preset_engine`;
its forward dynamics :mod:`dualmech.models.loop.preset_dynamics`), started from :func:`closed_form_phi` and
:func:`estimate` and read back by these columns and status rules (:func:`status_words`).  The coupler's spin
is fixed by the zero-spin gauge, as the slider crank's rod (``docs/conventions.md``, "RSSR").  The start
estimate of the output angle is the plane-free closed form ``A cos phi + B sin phi = C`` of the output pin's
circle meeting the sphere about ``P2`` (:func:`closed_form_phi`); it also decides ``no_assembly``
(``|C| > sqrt(A^2 + B^2)``) and the branch.  (The closed-form pipeline on this table, closure, rates and
Newton-Euler reactions position by position, is the tests' oracle: ``tests/linkage_oracles.py``.)
"""
from __future__ import annotations

import math

import numpy as np

from dualmech.core.loop import LoopState
from dualmech.core.status import Status, is_status
from dualmech.core.thresholds import (
    ASSEMBLY_LIMIT_CONDITION,
    ASSEMBLY_REACH,
    DEAD_CENTRE_TRANSMISSION,
    Tolerance,
)
from dualmech.models.angle_ranges import format_angle_ranges, no_assembly_ranges
from dualmech.models.linkages.rssr_case import RssrGeometry
from dualmech.models.tables import TableSpec

#: Closure residual accepted at the assembly limit (``|t4|`` in the band): there the loop's Jacobian is
#: singular, and a closure error of ~eps/|t| is the rounding of the pose, not a failure.
LIMIT_CLOSURE = Tolerance(
    1e-9, "the RCCC's slides close to ~1e-16/|t|: measured 2.7e-11 at |t| = 4e-6 (1e-9 deg from the edge), "
    "3.8e-12 at 4e-5; the pose there is given to that accuracy")
#: Output columns of an RSSR result table, in order (``docs/conventions.md``, "RSSR").
COLUMNS: tuple[str, ...] = (
    "theta1_deg", "phi4_deg", "phi4_dot", "phi4_ddot",
    "j1_fx", "j1_fy", "j1_fz", "j1_mx", "j1_my", "j1_mz",
    "j2_fx", "j2_fy", "j2_fz", "j3_fx", "j3_fy", "j3_fz",
    "j4_fx", "j4_fy", "j4_fz", "j4_mx", "j4_my", "j4_mz",
    "drive_torque", "output_torque", "transmission_in", "transmission_out", "residual", "dynamics_residual",
)
REACTIONS: tuple[str, ...] = COLUMNS[4:24] + ("dynamics_residual",)
POSE: tuple[str, ...] = ("phi4_deg", "transmission_out")
RATES: tuple[str, ...] = ("phi4_dot", "phi4_ddot", "transmission_in")
SPEC = TableSpec(COLUMNS, POSE, RATES, REACTIONS)


def crank_pin(geom: RssrGeometry, theta1: np.ndarray) -> np.ndarray:
    """``P2 = (a1 cos theta1, a1 sin theta1, s1)``, ``(n, 3)``."""
    return np.stack([geom.a1 * np.cos(theta1), geom.a1 * np.sin(theta1), np.full_like(theta1, geom.s1)], 1)


def output_pin(geom: RssrGeometry, phi: np.ndarray) -> np.ndarray:
    """``P3 = Q4 + a3 G4 (cos phi, sin phi, 0)``, ``(n, 3)``."""
    local = np.stack([np.cos(phi), np.sin(phi), np.zeros_like(phi)], 1)
    return geom.foot + geom.a3 * local @ geom.ground_rotation().T


def closed_form_phi(geom: RssrGeometry, theta1: np.ndarray, branch: int) -> tuple[np.ndarray, np.ndarray]:
    """Output angle on ``branch`` and the reach ratio ``rho = C / sqrt(A^2 + B^2)`` (``|rho| > 1``: no
    assembly), each ``(n,)``.

    ``|P3(phi) - P2|^2 = a2^2`` reads ``A cos phi + B sin phi = C`` with ``D = Q4 - P2``,
    ``A = 2 a3 D·x4``, ``B = 2 a3 D·y4``, ``C = a2^2 - a3^2 - |D|^2`` (``x4, y4`` the first columns
    of ``G4``).  Its phi-derivative is ``2 a2 a3 t4``, so the root with ``sign(t4) = branch`` is
    ``phi = atan2(B, A) - branch * acos(rho)``.
    """
    d = geom.foot - crank_pin(geom, theta1)
    g4 = geom.ground_rotation()
    a, b = 2 * geom.a3 * d @ g4[:, 0], 2 * geom.a3 * d @ g4[:, 1]
    c = geom.a2**2 - geom.a3**2 - np.einsum("ni,ni->n", d, d)
    with np.errstate(divide="ignore", invalid="ignore"):
        rho = c / np.hypot(a, b)
    return np.arctan2(b, a) - branch * np.arccos(np.clip(rho, -1.0, 1.0)), rho


def frame_x(u: np.ndarray) -> np.ndarray:
    """A rotation ``(n, 3, 3)`` whose x axis is the unit vector ``u`` ``(n, 3)``: the coupler frame of
    :func:`estimate` (``docs/conventions.md``, "RSSR": y and z any completion; this one).  Its y is
    ``ref x u`` normalized, ``ref`` the world x where ``|u_z| > 0.9``, else the world z."""
    ref = np.where(np.abs(u[:, 2:3]) > 0.9, np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0]))
    v = np.cross(ref, u)
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    return np.stack([u, v, np.cross(u, v)], axis=2)


def _rz(angle: np.ndarray) -> np.ndarray:
    c, s, z, o = np.cos(angle), np.sin(angle), np.zeros_like(angle), np.ones_like(angle)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2)


def estimate(geom: RssrGeometry, theta1: np.ndarray, phi: np.ndarray) -> LoopState:
    """Loop unknowns that point the coupler from ``P2`` at the output pin of angle ``phi`` ``(n,)``.

    The rotations close exactly; the coupler length closes only if ``phi`` is a solution.
    """
    p2, p3 = crank_pin(geom, theta1), output_pin(geom, phi)
    coupler = frame_x((p3 - p2) / np.linalg.norm(p3 - p2, axis=1, keepdims=True))
    theta4 = math.pi - phi
    ball2 = np.swapaxes(_rz(theta1), 1, 2) @ coupler
    ball3 = np.swapaxes(coupler, 1, 2) @ geom.ground_rotation() @ _rz(-theta4)
    return LoopState(theta4[:, None].copy(), np.stack([ball2, ball3], axis=1))


def assembles(rho: np.ndarray) -> np.ndarray:
    """Whether the output pin's circle meets the coupler's sphere: ``|rho| <= 1`` (to rounding), ``(n,)``."""
    return np.abs(rho) <= 1.0 + ASSEMBLY_REACH.value


def status_words(converged: np.ndarray, t1: np.ndarray, t4: np.ndarray, branch: int,
                 torque_mode: bool, residual: np.ndarray) -> np.ndarray:
    """Status words of every engine, in precedence: not_converged, branch_jump (``sign(t4) != branch``),
    assembly_limit (``|t4|`` below the band: the closure is singular, rates unbounded; also where the
    closure stopped short of its tolerance but within :data:`LIMIT_CLOSURE`), dead_centre (drive torque
    given and ``|t1|`` below the band); ``(n,)`` object array (``residual`` the closure residual)."""
    status = np.full(t4.shape, Status.OK.value, dtype=object)
    limit = ASSEMBLY_LIMIT_CONDITION.value
    status[torque_mode & (np.abs(t1) < DEAD_CENTRE_TRANSMISSION.value)] = Status.DEAD_CENTRE.value
    at_limit = np.abs(t4) < limit
    status[at_limit] = Status.ASSEMBLY_LIMIT.value
    status[(np.sign(t4) != branch) & ~at_limit] = Status.BRANCH_JUMP.value
    status[~converged & ~(at_limit & (residual <= LIMIT_CLOSURE.value))] = Status.NOT_CONVERGED.value
    return status


def no_assembly_messages(theta_deg: np.ndarray, status: np.ndarray, why: str) -> list[str]:
    """``["no_assembly: <why> at crank angles a..b, c..d deg"]`` for the ``no_assembly`` runs of ``status``
    ``(n,)`` (``theta_deg`` ``(n,)``), or ``[]``."""
    ranges = no_assembly_ranges(theta_deg, is_status(status, Status.NO_ASSEMBLY))
    return [f"no_assembly: {why} at crank angles {format_angle_ranges(ranges)} deg"] if ranges else []
