"""Every tolerance the suite compares with, in one place, each with its reason.

Relative tolerances are ``|judge - dualmech| <= tol * scale``; the scale of each
quantity is stated beside it.  Comparison code reads only this module.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Tolerance:
    """A tolerance and the one-line reason for its size."""

    value: float
    reason: str


#: In-house solver self-consistency.
CLOSURE_RESIDUAL = Tolerance(1e-12, "Newton is iterated to machine precision; 1e-12 leaves ~100 ulp of a2-sized lengths")
#: Dead-centre flag: |transmission| below this makes the slider load meaningless in torque mode.
DEAD_CENTRE_TRANSMISSION = Tolerance(1e-9, "below 1e-9 the slider load ~ T/(a1 t) carries fewer than ~7 significant digits")
