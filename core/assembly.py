"""Edges of assembly: how far a position is from the limit where the loop stops closing.

The rod (length ``a2``) joins the crank pin ``P2`` to the slider pin ``P3`` on the
slider line through ``F`` with direction ``k4`` (``docs/conventions.md``).  With
``rho`` the distance from ``P2`` to that line, the loop closes iff ``rho <= a2``;
at ``rho = a2`` the rod is normal to the slider line and the two assembly
branches meet.  The **closure condition**

.. math:: c = |u\\cdot k_4| = \\frac{|(P_3 - P_2)\\cdot k_4|}{|P_3 - P_2|}
          = \\sqrt{1 - (\\rho/a_2)^2} \\in [0, 1]

is the sine of the angle between the rod and the plane normal to the slider
axis; ``1/c`` is the closure's gain from a loop residual to ``S4``, rates carry
``1/c`` and accelerations and reactions ``1/c^3``.  Every engine computes ``c``
from its own pose and classifies its rows with :func:`edge_status`, so that all
engines treat the edge the same way.  Arrays have a leading batch axis ``n``;
points and directions are ``(n, 3)`` or ``(3,)`` in world axes.
"""

from __future__ import annotations

import numpy as np

from dualmech.core.status import Status, is_status


def reach(p2: np.ndarray, foot: np.ndarray, k4: np.ndarray, a2: float | np.ndarray) -> np.ndarray:
    """``rho / a2``, shape ``(n,)``: distance from ``P2`` to the slider line over the rod length."""
    d = np.atleast_2d(p2) - foot
    along = d @ k4 if np.ndim(k4) == 1 else np.einsum("ni,ni->n", d, k4)
    return np.sqrt(np.maximum(np.einsum("ni,ni->n", d, d) - along**2, 0.0)) / a2


def foot_s4(p2: np.ndarray, foot: np.ndarray, k4: np.ndarray) -> np.ndarray:
    """``S4`` of the foot of the perpendicular from ``P2`` on the slider line (``P3 = F - S4 k4``), ``(n,)``.

    The limit pose: where the rod lies at ``c = 0``.
    """
    d = np.atleast_2d(p2) - foot
    return -(d @ k4 if np.ndim(k4) == 1 else np.einsum("ni,ni->n", d, k4))


def on_branch(p2: np.ndarray, p3: np.ndarray, k4: np.ndarray) -> np.ndarray:
    """``(P3 - P2)·k4 < 0``, shape ``(n,)``: the pose is on the assembly branch of ``docs/conventions.md``.

    The branch the thesis starts from (planar, ``theta1 = 0``: ``S4 = +sqrt(a2^2 - (a1 + a4)^2)``);
    a solution on the other one is ``branch_jump``.  ``p2``, ``p3`` ``(n, 3)``; ``k4`` ``(3,)`` or ``(n, 3)``.
    """
    rod = np.atleast_2d(p3) - np.atleast_2d(p2)
    return (rod @ k4 if np.ndim(k4) == 1 else np.einsum("ni,ni->n", rod, k4)) < 0


def closure_condition(p2: np.ndarray, p3: np.ndarray, k4: np.ndarray) -> np.ndarray:
    """``c = |(P3 - P2)·k4| / |P3 - P2|`` of a closed pose, shape ``(n,)``."""
    rod = np.atleast_2d(p3) - np.atleast_2d(p2)
    along = rod @ k4 if np.ndim(k4) == 1 else np.einsum("ni,ni->n", rod, k4)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.abs(along) / np.linalg.norm(rod, axis=1)


def edge_status(status: np.ndarray, closed: np.ndarray, rho: np.ndarray, condition: np.ndarray,
                reach_tol: float, band: float) -> tuple[np.ndarray, np.ndarray]:
    """Status words and closure condition of every row, with the edges of assembly applied.

    Parameters
    ----------
    status : numpy.ndarray of str, shape (n,)
        The engine's words after its closure (``ok``, ``not_converged``, ``branch_jump``, ``no_assembly``).
    closed : numpy.ndarray of bool, shape (n,)
        Where the closure converged on the conventions' branch (``condition`` is then the pose's own ``c``).
    rho : numpy.ndarray, shape (n,)
        :func:`reach` of each row.
    condition : numpy.ndarray, shape (n,)
        :func:`closure_condition` of the engine's pose (read only where ``closed``).
    reach_tol, band : float
        ``ASSEMBLY_REACH`` and ``ASSEMBLY_LIMIT_CONDITION`` of ``core/thresholds.py``.

    Returns
    -------
    status : numpy.ndarray of object, shape (n,)
        ``no_assembly`` where ``rho > 1 + reach_tol`` (proven by geometry, whatever the
        solver said); ``assembly_limit`` where ``c < band`` (the solver's own ``c`` where
        it closed, else :math:`\\sqrt{1-\\min(\\rho, 1)^2}`), also where the solver failed
        that close to the edge; ``not_converged`` where a solver that claimed
        ``no_assembly`` had the slider line within reach; the rest unchanged.
    condition : numpy.ndarray, shape (n,)
        ``c`` per row, NaN at ``no_assembly`` rows.
    """
    out = np.asarray(status, dtype=object).copy()
    geometric = np.sqrt(1.0 - np.minimum(np.real(rho), 1.0) ** 2)  # real: a status, not differentiated
    c = np.where(closed, condition, geometric)
    beyond = rho > 1.0 + reach_tol
    out[~beyond & is_status(out, Status.NO_ASSEMBLY)] = Status.NOT_CONVERGED.value
    out[~beyond & (c < band)] = Status.ASSEMBLY_LIMIT.value
    out[beyond] = Status.NO_ASSEMBLY.value
    return out, np.where(beyond, np.nan, c)
