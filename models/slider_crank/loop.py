"""The generalized slider crank as one instance of the link-joint table, and its positions in a batch.

::

    row  joint              theta     S      eta   alpha    a      (thesis Table 1)
    1    cylindrical (1)    theta1*   S1*    0     0        a1
    2    ball (2)           -- free rotation --    0        a2
    3    ball (3)           -- free rotation --    pi/2     0
    4    prismatic (4)      0         S4?    0     alpha4   a4

    * prescribed input   ? unknown

The thesis gives the balls Z-Y angles (theta2, eta2, theta3, eta3); those
five unknowns cannot close a spatial loop (errata E2), so each ball here is a
free rotation and the rod's spin is fixed by the zero-spin gauge
(``docs/conventions.md``).

:data:`LOOP` is the table; :class:`Batch` holds the positions of one or more cases with
their geometry per position (so cases share one batch), and the geometry derived from
them (``F``, ``k4``, ``P2``: :mod:`dualmech.models.mechanism`).  The in-house engine's
thresholds are named here too: the numpy solver (:mod:`dualmech.models.slider_crank.analysis`) and
the compiled kernel (:mod:`dualmech.models.slider_crank.kernel`) both read them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Sequence

import numpy as np

from dualmech.core.assembly import foot_s4, reach
from dualmech.core.loop import Loop, Row, inp, par, unk
from dualmech.core.motion import CrankState
from dualmech.core.thresholds import DEAD_CENTRE_TRANSMISSION
from dualmech.models.case import Case
from dualmech.models.mechanism import crank_pin, slider_line

#: |transmission| below which the in-house engine flags a torque-mode position a dead centre (its numpy
#: path and the compiled kernel read this name; the number and its reason: core/thresholds.py).
DEAD_CENTRE = DEAD_CENTRE_TRANSMISSION.value
#: Geometry steps of the continuation fallback (from the planar mechanism to the case).
CONTINUATION_STEPS = 8

LOOP = Loop(
    rows=(
        Row("joint1", theta=inp("theta1"), s=inp("S1"), a=par("a1")),
        Row("joint2", spherical=True, a=par("a2")),
        Row("joint3", spherical=True, alpha=math.pi / 2),
        Row("joint4", s=unk("S4"), alpha=par("alpha4"), a=par("a4")),
    ),
    spin_gauges=(1,),
    length_scale="a2",
)


@dataclass(frozen=True)
class Batch:
    """Positions of one or more cases, concatenated: crank state and geometry per position (``(n,)``)."""

    crank: CrankState
    a1: np.ndarray
    a2: np.ndarray
    a4: np.ndarray
    alpha4: np.ndarray  # radians

    @staticmethod
    def of(cases: Sequence[Case], cranks: Sequence[CrankState]) -> "Batch":
        counts = [len(c) for c in cranks]
        crank = CrankState(*(np.concatenate([getattr(c, f.name) for c in cranks])
                             for f in fields(CrankState)))
        geo = [(c.geometry.crank_length, c.geometry.rod_length, c.geometry.slider_offset,
                c.geometry.slider_twist) for c in cases]
        return Batch(crank, *(np.repeat(col, counts) for col in zip(*geo)))

    def __len__(self) -> int:
        return len(self.crank)

    def take(self, index: np.ndarray) -> "Batch":
        return Batch(self.crank.take(index), self.a1[index], self.a2[index], self.a4[index],
                     self.alpha4[index])

    def inputs(self) -> dict[str, np.ndarray]:
        """Inputs and parameters of :data:`LOOP`."""
        return {"theta1": self.crank.theta, "S1": self.crank.s, "a1": self.a1, "a2": self.a2,
                "a4": self.a4, "alpha4": self.alpha4}

    def slider_line(self) -> tuple[np.ndarray, np.ndarray]:
        """``F`` and ``k4`` per position, ``(n, 3)`` each (:func:`~dualmech.models.mechanism.slider_line`)."""
        return slider_line(self.a4, self.alpha4)

    def crank_pin(self) -> np.ndarray:
        """``P2`` ``(n, 3)`` from the prescribed crank state
        (:func:`~dualmech.models.mechanism.crank_pin`)."""
        return crank_pin(self.a1, self.crank.theta, self.crank.s)

    def foot_s4(self) -> np.ndarray:
        """``S4`` of the limit pose (:func:`~dualmech.core.assembly.foot_s4`), ``(n,)``."""
        return foot_s4(self.crank_pin(), *self.slider_line())

    def reach(self) -> np.ndarray:
        """Distance from ``P2`` to the slider line over ``a2`` (:func:`~dualmech.core.assembly.reach`),
        ``(n,)``."""
        return reach(self.crank_pin(), *self.slider_line(), self.a2)
