"""The result table of every kind other than the slider crank (the RSSR, the RCCC, any loop table): named
columns, one row per input position, described by the kind's :class:`TableSpec`.

Like :class:`~dualmech.core.table.ResultTable` (same status words, same CSV writer), but with the
mechanism's own columns (``docs/conventions.md``, "RSSR", "RCCC", "Loop tables"): the slider crank's
``S4`` or ``slider_load`` mean nothing for a four-bar.  Each kind's engines, gate
(:mod:`dualmech.validation.compare.tables`) and report read a table through its spec, never a column name
of their own.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np

from dualmech.core.status import ASSEMBLED
from dualmech.core.table import ColumnTable, write_csv


class TableSpec(NamedTuple):
    """A mechanism's output columns in order, and which of them a status word gives: the ``pose``
    (assembled words), the ``rates`` (``ok``, ``dead_centre``), the ``reactions`` (``ok``); ``key`` the
    column of each row's input value (the crank angle in degrees, or a loop table's driven coordinate), on
    which two engines' rows are matched; ``output`` the column the report plots against it (default the
    first pose column); ``posed`` the words that give the pose (a loop table's ``joint_lock`` gives none)."""

    columns: tuple[str, ...]
    pose: tuple[str, ...]
    rates: tuple[str, ...]
    reactions: tuple[str, ...]
    key: str = "theta1_deg"
    output: str = ""
    posed: frozenset[str] = ASSEMBLED

    @property
    def shown(self) -> str:
        """The column the report plots against the key: ``output`` if given, else the first pose column."""
        return self.output or self.pose[0]

    @property
    def key_label(self) -> tuple[str, str]:
        """The key's name and unit for messages: ``("theta1", "deg")`` of ``theta1_deg``, ``("s1", "")`` of a
        slide (in the case's length unit)."""
        return (self.key[:-4], "deg") if self.key.endswith("_deg") else (self.key, "")

    @property
    def kinematics(self) -> tuple[str, ...]:
        """The pose and rate columns (compared column by column)."""
        return self.pose + self.rates

    @property
    def forces(self) -> tuple[str, ...]:
        """The reaction columns that are forces."""
        return tuple(c for c in self.reactions if "_f" in c or c.startswith("effort_s"))

    @property
    def moments(self) -> tuple[str, ...]:
        """The reaction columns that are moments or torques."""
        return tuple(c for c in self.reactions
                     if "_m" in c or c.endswith("torque") or c.startswith(("effort_theta", "effort_eta")))

    @property
    def loads(self) -> tuple[tuple[str, tuple[str, ...], str], ...]:
        """The loads the table gives, as ``(name, columns, unit group)``: each joint's force and moment
        (``<joint>_f{x,y,z}``, ``<joint>_m{x,y,z}``: ``"j1 |f|"``, ``"joint1 |m|"``) in column order, then
        every scalar effort (``"|drive_torque|"``, ``"|effort_theta4|"``); not the ``dynamics_residual``."""
        vectors: dict[tuple[str, str], list[str]] = {}
        scalars = []
        for column in (*self.forces, *self.moments):
            joint, _, component = column.rpartition("_")
            if joint and len(component) == 2 and component[0] in "fm" and component[1] in "xyz":
                vectors.setdefault((joint, component[0]), []).append(column)
            else:
                scalars.append(column)
        joints = sorted(vectors, key=lambda jk: self.columns.index(vectors[jk][0]))
        return (*((f"{j} |{k}|", tuple(vectors[j, k]), "force" if k == "f" else "moment") for j, k in joints),
                *((f"|{c}|", (c,), "force" if c in self.forces else "moment")
                  for c in sorted(scalars, key=self.columns.index)))

    def unit_group(self, column: str) -> str:
        """The unit group of a compared column (its differences share the group's scale, as the slider
        crank's ``UNIT_GROUP``): ``force`` (``*_f*``, a loop table's ``effort_s*``), ``moment`` (``*_m*``,
        ``*torque``, ``effort_theta*``, ``effort_eta*``), ``ratio`` (transmissions, a loop table's
        ``closure_condition``), else an angle
        (``theta*``, ``phi*``, ``eta*``) or slide (``s*``) and its derivative order (``angle``,
        ``angle_dot``, ``angle_ddot``, ``length``, ``length_dot``, ``length_ddot``)."""
        if column in self.forces:
            return "force"
        if column in self.moments:
            return "moment"
        if column.startswith("transmission") or column == "closure_condition":
            return "ratio"
        base = "angle" if column.startswith(("theta", "phi", "eta")) else "length"
        for order in ("_ddot", "_dot"):
            if column.endswith(order):
                return base + order
        return base

    def period(self, column: str) -> float | None:
        """The period of an angle column, on which two values are the same angle: 360 for ``*_deg``, 2 pi for
        another angle (a loop table's ``theta<i>``, ``eta<i>`` in rad); ``None`` for every other column."""
        if column.endswith("_deg"):
            return 360.0
        return 2.0 * np.pi if self.unit_group(column) == "angle" else None


@dataclass(frozen=True)
class LinkageTable(ColumnTable):
    """Columns of one engine's answer for one linkage case.

    ``columns`` name -> ``(n,)`` float arrays in the mechanism's column order; ``status``
    ``(n,)`` status words (:mod:`dualmech.core.status`); ``meta`` engine facts.
    """

    def to_csv(self, path: str | Path | None = None) -> str:
        """CSV text of every column (full precision), then ``status``; written to ``path`` if given."""
        return write_csv(self.columns, np.asarray(self.status), path)
