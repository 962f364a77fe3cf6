"""Reactions in the thesis's joint frames {1}-{4}, for comparison with its notation 1F1i ... 4T4k.

The mapping (``docs/conventions.md``, "Joint-frame table"):

=========  ==========================================  ===============================  ==========
columns    quantity                                    frame axes (world components)    moment at
=========  ==========================================  ===============================  ==========
1F1, 1T1   ground on crank                             {1}: x, y, z                     O
2F2        rod on crank, at P2 (= -j2)                 {2}: i = (c1, s1, 0), j = (-s1, c1, 0), k = z    --
3F3, 3T3   slider on rod, at P3 (= -j3, -j3_m)         {3}: i = u, j = z x u / |z x u|, k = i x j        --
4F4, 4T4   ground on slider                            {4}: i = x, j = (0, c a4, -s a4), k = k4         P3
=========  ==========================================  ===============================  ==========

Frame {3} is the rod frame of the thesis's Z-Y parametrization (eq. 2); it is
undefined where the rod is parallel to the crank axis (there ``j`` is NaN).
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from dualmech.core.table import ResultTable
from dualmech.models.case import Case

JOINT_FRAME_COLUMNS: tuple[str, ...] = (
    "theta1_deg",
    "1F1i", "1F1j", "1F1k", "1T1i", "1T1j", "1T1k",
    "2F2i", "2F2j", "2F2k",
    "3F3i", "3F3j", "3F3k", "3T3i", "3T3j", "3T3k",
    "4F4i", "4F4j", "4F4k", "4T4i", "4T4j", "4T4k",
)


def _vec(table: ResultTable, prefix: str) -> np.ndarray:
    return np.stack([table[f"{prefix}{a}"] for a in "xyz"], axis=1)


def joint_frame_columns(case: Case, table: ResultTable) -> dict[str, np.ndarray]:
    """The joint-frame components of a result table, as ``(n,)`` arrays keyed by
    :data:`JOINT_FRAME_COLUMNS`."""
    g = case.geometry
    th = np.radians(table["theta1_deg"])
    c1, s1 = np.cos(th), np.sin(th)
    zero = np.zeros_like(th)
    p2 = np.stack([g.crank_length * c1, g.crank_length * s1, table["S1"]], 1)
    a, k4 = g.slider_twist, g.k4
    p3 = g.foot - table["S4"][:, None] * k4
    u = (p3 - p2) / g.rod_length
    j3 = np.cross([0.0, 0.0, 1.0], u)
    with np.errstate(invalid="ignore", divide="ignore"):
        j3 /= np.linalg.norm(j3, axis=1, keepdims=True)
    frames = {
        "2": np.stack([np.stack([c1, s1, zero], 1), np.stack([-s1, c1, zero], 1),
                       np.tile([0.0, 0, 1], (len(th), 1))], 1),
        "3": np.stack([u, j3, np.cross(u, j3)], 1),
        "4": np.broadcast_to(np.array([[1.0, 0, 0], [0, np.cos(a), -np.sin(a)], k4]), (len(th), 3, 3)),
    }
    out = {"theta1_deg": table["theta1_deg"]}
    parts = {
        "1F1": _vec(table, "j1_f"), "1T1": _vec(table, "j1_m"),
        "2F2": np.einsum("nij,nj->ni", frames["2"], -_vec(table, "j2_f")),
        "3F3": np.einsum("nij,nj->ni", frames["3"], -_vec(table, "j3_f")),
        "3T3": np.einsum("nij,nj->ni", frames["3"], -_vec(table, "j3_m")),  # a universal joint's; else 0
        "4F4": np.einsum("nij,nj->ni", frames["4"], _vec(table, "j4_f")),
        "4T4": np.einsum("nij,nj->ni", frames["4"], _vec(table, "j4_m")),
    }
    for name, arr in parts.items():
        for k, axis in enumerate("ijk"):
            out[f"{name}{axis}"] = arr[:, k]
    return out


def write_joint_frame_csv(case: Case, table: ResultTable, path: str | Path) -> None:
    """Write :func:`joint_frame_columns` (plus ``status``) as CSV."""
    cols = joint_frame_columns(case, table)
    with Path(path).open("w", newline="") as fh:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(JOINT_FRAME_COLUMNS + ("status",))
        for i in range(len(table)):
            writer.writerow([repr(float(cols[c][i])) for c in JOINT_FRAME_COLUMNS] + [table.status[i]])
