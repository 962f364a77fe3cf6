"""The result table every engine writes: one row per crank position.

Every column is defined in ``docs/conventions.md`` ("Output columns"); this
module holds their names and order, the status words, and CSV output.  The
in-house solver, Pinocchio and MuJoCo all return a :class:`ResultTable`, so
comparison code never needs to know which engine produced one.
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from dualmech.core.status import STATUSES  # noqa: F401  (re-exported: the status words)

KINEMATIC_COLUMNS: tuple[str, ...] = ("theta1_deg", "S1", "S4", "S4_dot", "S4_ddot")
REACTION_COLUMNS: tuple[str, ...] = (
    "j1_fx", "j1_fy", "j1_fz", "j1_mx", "j1_my", "j1_mz",
    "j2_fx", "j2_fy", "j2_fz",
    "j3_fx", "j3_fy", "j3_fz",
    "j4_fx", "j4_fy", "j4_fz", "j4_mx", "j4_my", "j4_mz",
    "slider_load", "drive_torque",
)
DIAGNOSTIC_COLUMNS: tuple[str, ...] = ("transmission", "residual", "closure_condition")
NUMERIC_COLUMNS: tuple[str, ...] = KINEMATIC_COLUMNS + REACTION_COLUMNS + DIAGNOSTIC_COLUMNS
COLUMNS: tuple[str, ...] = NUMERIC_COLUMNS + ("status",)

FORCE_COLUMNS: tuple[str, ...] = tuple(
    c for c in REACTION_COLUMNS if "_f" in c or c == "slider_load"
)
MOMENT_COLUMNS: tuple[str, ...] = tuple(
    c for c in REACTION_COLUMNS if "_m" in c or c == "drive_torque"
)



@dataclass(frozen=True)
class ResultTable:
    """Columns of one engine's answer for one case.

    Attributes
    ----------
    engine : str
        ``"dualmech"``, ``"pinocchio"``, ``"mujoco"`` or ``"mujoco-sim"``.
    case : str
        The case name.
    columns : dict[str, numpy.ndarray]
        Every name of :data:`NUMERIC_COLUMNS`, each of shape ``(n,)``, float.
        Reactions are NaN where ``status`` is not ``ok``.
    status : numpy.ndarray of str, shape (n,)
        One word of :data:`STATUSES` per position.
    meta : dict
        Engine-specific facts (versions, iterations, timings) for reports.
    """

    engine: str
    case: str
    columns: dict[str, np.ndarray]
    status: np.ndarray
    meta: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        missing = [c for c in NUMERIC_COLUMNS if c not in self.columns]
        if missing:
            raise ValueError(f"columns: missing {missing}")
        n = self.status.shape[0]
        for name, col in self.columns.items():
            if col.shape != (n,):
                raise ValueError(f"columns[{name!r}]: expected shape ({n},), got {col.shape}")

    def __len__(self) -> int:
        return self.status.shape[0]

    def __getitem__(self, name: str) -> np.ndarray:
        return self.status if name == "status" else self.columns[name]

    def to_csv(self, path: str | Path | None = None) -> str:
        """Write the table as CSV (all :data:`COLUMNS`, full precision); return the text."""
        buf = io.StringIO()
        writer = csv.writer(buf, lineterminator="\n")
        writer.writerow(COLUMNS)
        data = [self.columns[c] for c in NUMERIC_COLUMNS]
        for i in range(len(self)):
            writer.writerow([repr(float(col[i])) for col in data] + [self.status[i]])
        text = buf.getvalue()
        if path is not None:
            Path(path).write_text(text)
        return text


def read_csv(path: str | Path, engine: str = "", case: str = "") -> ResultTable:
    """Read a table written by :meth:`ResultTable.to_csv`."""
    with Path(path).open() as fh:
        rows = list(csv.DictReader(fh))
    columns = {c: np.array([float(r[c]) for r in rows]) for c in NUMERIC_COLUMNS}
    status = np.array([r["status"] for r in rows], dtype=object)
    return ResultTable(engine, case, columns, status)
