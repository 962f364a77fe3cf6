"""Where a row is ill-conditioned, a judge's tolerance grows with the conditioning, by a derived law.

A judge's row passes when its relative difference ``r_i`` (package docstring) is at most
``f_i tol + a_i``: ``f_i`` the joint-lock factor (:mod:`~dualmech.validation.compare.joint_lock`), ``a_i``
the sum of the allowances below, each the error that exact arithmetic to a stated precision leaves in
*correct* engines at that row, in units of ``r`` (``docs/conventions.md``, "Conditioning of a row"; the
constants and their evidence in :mod:`dualmech.validation.tolerances`):

* **Edge of assembly** (``S4`` and the stroke).  The closure
  :math:`(S_4 - s_0)^2 = a_2^2 c^2` has the double root :math:`s_0` at ``c = 0``; a loop closed to a
  relative length ``delta`` (residual, rounding of ``P2``, ``F``, ``k4``) moves :math:`c^2` by at most
  :math:`4\\delta`, hence ``S4`` by at most

  .. math:: a_2 H(c), \\qquad H(c) = \\sqrt{c^2 + 4\\delta} - \\sqrt{\\max(c^2 - 4\\delta, 0)}

  (``~2 delta / c`` where the root is simple, ``2 sqrt(delta)`` at the double root: the square root of
  the closure's precision).  ``H`` decreases with ``c``; each engine measures ``c`` with the same error,
  so ``c`` is bounded below by :math:`c_- = \\sqrt{\\max(\\min(c_R, c_J)^2 - 4\\delta, 0)}` and two
  engines may differ by ``2 a2 H(c_-)``, divided by the length scale ``s_g``.  The stroke
  (``max S4 - min S4``) may differ by twice the largest of these over the rows both engines assemble.
* **Beside a dead centre** (reactions, drive-torque mode).  A reaction is :math:`\\hat R / t`; ``t`` is
  a lever arm of order 1 computed to an absolute rounding ``tau``, so :math:`\\delta R = \\hat R\\,
  \\delta t / t^2`.  With ``s_g >= |R hat|`` and ``r_i`` already divided by ``s_g / |t|``, the row's
  allowance is ``tau / |t_i|``: the rounding grows as ``1/t^2``, one power of ``1/|t|`` faster than the
  condition factor.  ``tau`` is the larger of the two engines' (:func:`transmission_error`): the rigid
  engines' rounding, or the Exudyn judge's integration error of its transmission.  Compared rows have
  ``|t| >= DEAD_CENTRE_TRANSMISSION`` (below it every engine says ``dead_centre``), so this never exceeds
  ``tau / 1e-9``.
* **Aspect ratio** (every column).  The judges close the loop and solve for the rates relative to the
  loop's length scale ``L = a1 + a2 + |a4| + max|S1|``, so a quantity of the small link ``a = min(a1, a2)``
  carries ``~eps A`` of its scale, ``A = L / a`` (the condition number of a Jacobian whose columns are of
  sizes ``a`` and ``L``); the reactions pass through a second such solve (the rod's inertia, of lever
  ``L``, balanced through the crank, of lever ``a``) and carry ``~eps A^2``.  Allowances ``K eps A`` and
  ``K' eps A^2``, capped: beyond the cap a judge has too few digits to judge and its check fails.

A table of any kind with a ``closure_condition`` (a loop table, the RSSR, the RCCC) has one law of its own:

* **Closure condition** (every compared column).  Its engines close the loop to a relative length
  ``delta``; where the closure's normalized Jacobian has the condition ``c`` (beside an assembly limit or
  a joint lock), the pose moves by ``~delta / c``, the rates, solved with that Jacobian at that pose, by
  ``~delta / c^2``, the accelerations and the reactions (linear in them) by ``~delta / c^3``: the
  allowance is ``delta / c^k``, ``k`` the column's order (1 pose, 2 rates, 3 accelerations and reactions),
  ``c`` the smaller of the two engines' ``closure_condition``, at least ``sqrt(delta)`` for the pose (a
  fold's double root) and the band's ``LOOP_LIMIT_CONDITION`` for the others (rows below it give no
  rates).  So it adds ``delta`` at ``c = 1``, and at most ``3e-7`` (pose), ``1e-7`` (rates), ``1e-4``
  (accelerations, reactions) at the band.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dualmech.core.table import REACTION_COLUMNS, ResultTable
from dualmech.core.thresholds import LOOP_LIMIT_CONDITION
from dualmech.models.case import Case
from dualmech.validation.tolerances import (
    ASPECT_KINEMATICS,
    ASPECT_REACTIONS,
    CLOSURE_PRECISION,
    CONDITIONING_CAP,
    TRANSMISSION_ERROR,
    TRANSMISSION_ROUNDING,
)

#: The allowances' names, as a check's detail names the ones that were needed.
EDGE, DEAD_CENTRE, ASPECT = "edge of assembly", "beside a dead centre", "aspect ratio"
CLOSURE = "closure condition"
#: The words a check whose tolerance was widened by a row's conditioning carries in its detail.
CONDITIONED = "conditioned"
_EPS = float(np.finfo(float).eps)


@dataclass(frozen=True)
class Conditioning:
    """What the laws need of a case: the rod length ``a2`` and the aspect ratio ``A`` (module docstring)."""

    rod_length: float
    aspect: float

    @classmethod
    def of(cls, case: Case, reference: ResultTable) -> "Conditioning":
        """From the case's geometry and the reference's ``S1`` column."""
        g = case.geometry
        s1 = np.abs(reference["S1"])
        s1_max = float(s1[np.isfinite(s1)].max()) if np.isfinite(s1).any() else 0.0
        length = g.crank_length + g.rod_length + abs(g.slider_offset) + s1_max
        return cls(float(g.rod_length), float(length / min(g.crank_length, g.rod_length)))


def edge_error(condition: np.ndarray) -> np.ndarray:
    """``H(c)`` of the module docstring, shape of ``condition``: ``|delta S4| / a2`` of one engine."""
    four_delta = 4.0 * CLOSURE_PRECISION.value
    c2 = np.square(condition)
    return np.sqrt(c2 + four_delta) - np.sqrt(np.maximum(c2 - four_delta, 0.0))


def edge_allowance(reference: ResultTable, judge: ResultTable, rod_length: float) -> np.ndarray:
    """``2 a2 H(c_-)`` per row, shape ``(n,)``, in the length unit; 0 where a ``c`` is not given."""
    with np.errstate(invalid="ignore"):
        c = np.fmin(np.abs(reference["closure_condition"]), np.abs(judge["closure_condition"]))
    low = np.sqrt(np.maximum(np.square(c) - 4.0 * CLOSURE_PRECISION.value, 0.0))
    return np.where(np.isfinite(c), 2.0 * rod_length * edge_error(low), 0.0)


def closure_allowance(order: int, reference: object, judge: object) -> np.ndarray:
    """``delta / c^order`` per row (module docstring, "Closure condition"), shape ``(n,)``, in units of ``r``;
    ``reference``, ``judge``: tables with a ``closure_condition`` column; 0 where a ``c`` is not given."""
    delta = CLOSURE_PRECISION.value
    with np.errstate(invalid="ignore"):
        c = np.fmin(np.abs(reference["closure_condition"]), np.abs(judge["closure_condition"]))
        floor = np.sqrt(delta) if order == 1 else LOOP_LIMIT_CONDITION.value
        allowance = delta / np.maximum(c, floor) ** order
    return np.where(np.isfinite(c), allowance, 0.0)


def transmission_error(engine: str) -> float:
    """``tau`` of the dead-centre law for ``engine``'s transmission: the rigid engines' rounding
    (``TRANSMISSION_ROUNDING``), or the larger error of an engine's own (``TRANSMISSION_ERROR``: the Exudyn
    judge's, from its integrated multipliers)."""
    return TRANSMISSION_ERROR.get(engine, TRANSMISSION_ROUNDING).value


def aspect_allowance(quantity: str, aspect: float) -> float:
    """``K eps A`` (kinematics) or ``K' eps A^2`` (reactions), at most ``CONDITIONING_CAP``."""
    law = ASPECT_REACTIONS.value * _EPS * aspect**2 if quantity in REACTION_COLUMNS else \
        ASPECT_KINEMATICS.value * _EPS * aspect
    return min(law, CONDITIONING_CAP.value)


def allowances(quantity: str, mode: str, reference: ResultTable, judge: ResultTable, scale: float,
               conditioning: Conditioning) -> dict[str, np.ndarray]:
    """Each law's ``a_i`` for ``quantity`` (module docstring), shape ``(n,)``, in units of ``r``.

    ``scale`` is the quantity's unit-group scale ``s_g``; laws that do not apply are left out.
    """
    n = len(reference)
    out = {ASPECT: np.full(n, aspect_allowance(quantity, conditioning.aspect))}
    if quantity == "S4":
        out[EDGE] = edge_allowance(reference, judge, conditioning.rod_length) / scale
    if mode == "torque" and quantity in REACTION_COLUMNS:
        t = np.abs(reference["transmission"])
        tau = max(transmission_error(reference.engine), transmission_error(judge.engine))
        with np.errstate(divide="ignore", invalid="ignore"):
            out[DEAD_CENTRE] = np.where(t > 0, tau / t, 0.0)
    return out


def stroke_allowance(reference: ResultTable, judge: ResultTable, length: float,
                     conditioning: Conditioning) -> dict[str, float]:
    """Each law's allowance on the stroke difference over ``length`` (module docstring)."""
    both = np.isfinite(reference["S4"]) & np.isfinite(judge["S4"])
    edge = edge_allowance(reference, judge, conditioning.rod_length)[both]
    return {ASPECT: aspect_allowance("stroke", conditioning.aspect),
            EDGE: 2.0 * float(edge.max()) / length if edge.size else 0.0}


def within(rel: np.ndarray, rows: np.ndarray, tol: float, factor: np.ndarray | float,
           allowance: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray, str]:
    """``r_i`` scaled to ``tol`` by each row's tolerance ``f_i tol + a_i`` (``r_i tol / tol_i``), the
    ``rows`` where the laws were needed to pass, and the phrase naming the laws that give a tenth or more
    of the allowance there (``""`` if none was needed).  ``tol > 0``; arrays ``(n,)``."""
    extra = sum(allowance.values()) if allowance else np.zeros_like(rel)
    base = factor * tol
    with np.errstate(invalid="ignore"):
        needed = rows & (rel > base) & (rel <= base + extra)
    phrase = ""
    if needed.any():
        laws = [name for name, a in allowance.items() if (a[needed] >= 0.1 * extra[needed]).any()]
        phrase = f"{CONDITIONED} ({', '.join(laws)}): tolerance +{extra[needed].max():.3g}"
    return rel * tol / (base + extra), needed, phrase
