"""The result table of a linkage other than the slider crank: named columns, one row per crank position.

Like :class:`~dualmech.core.table.ResultTable` (same status words, same CSV writer), but
with the mechanism's own columns (``docs/conventions.md``, "RSSR"): the slider crank's
``S4`` or ``slider_load`` mean nothing for a four-bar.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np

from dualmech.core.table import ColumnTable, write_csv


class TableSpec(NamedTuple):
    """A mechanism's output columns in order, and which of them a status word gives: the ``pose``
    (assembled words), the ``rates`` (``ok``, ``dead_centre``), the ``reactions`` (``ok``)."""

    columns: tuple[str, ...]
    pose: tuple[str, ...]
    rates: tuple[str, ...]
    reactions: tuple[str, ...]

    @property
    def kinematics(self) -> tuple[str, ...]:
        """The pose and rate columns (compared column by column)."""
        return self.pose + self.rates

    @property
    def forces(self) -> tuple[str, ...]:
        """The reaction columns that are forces."""
        return tuple(c for c in self.reactions if "_f" in c)

    @property
    def moments(self) -> tuple[str, ...]:
        """The reaction columns that are moments or torques."""
        return tuple(c for c in self.reactions if "_m" in c or c.endswith("torque"))

    def unit_group(self, column: str) -> str:
        """The unit group of a compared column (its differences share the group's scale, as the slider
        crank's ``UNIT_GROUP``): ``force``, ``moment``, ``ratio`` (transmissions), else the output angle
        (``theta*``, ``phi*``) or slide (``s*``) and its derivative order (``angle``, ``angle_dot``,
        ``angle_ddot``, ``length``, ``length_dot``, ``length_ddot``)."""
        if column in self.forces:
            return "force"
        if column in self.moments:
            return "moment"
        if column.startswith("transmission"):
            return "ratio"
        base = "angle" if column.startswith(("theta", "phi")) else "length"
        for order in ("_ddot", "_dot"):
            if column.endswith(order):
                return base + order
        return base


@dataclass(frozen=True)
class LinkageTable(ColumnTable):
    """Columns of one engine's answer for one linkage case.

    ``columns`` name -> ``(n,)`` float arrays in the mechanism's column order; ``status``
    ``(n,)`` status words (:mod:`dualmech.core.status`); ``meta`` engine facts.
    """

    def to_csv(self, path: str | Path | None = None) -> str:
        """CSV text of every column (full precision), then ``status``; written to ``path`` if given."""
        return write_csv(self.columns, np.asarray(self.status), path)
