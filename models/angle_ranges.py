"""Crank-angle ranges of a case's rows, and the messages that name them (where a mechanism cannot assemble).

Every engine and message writes a run of rows the same way: ``(first, last)`` crank angles in degrees,
``"a..b, c..d"`` in text.
"""

from __future__ import annotations

import numpy as np


def no_assembly_ranges(theta_deg: np.ndarray, mask: np.ndarray) -> list[tuple[float, float]]:
    """Contiguous runs of ``mask`` as (first, last) crank angles in degrees."""
    return row_ranges(theta_deg, np.flatnonzero(mask))


def row_ranges(theta_deg: np.ndarray, rows: np.ndarray) -> list[tuple[float, float]]:
    """Runs of consecutive indices in ``rows`` (increasing) as (first, last) crank angles in degrees."""
    if rows.size == 0:
        return []
    cut = np.flatnonzero(np.diff(rows) != 1)
    starts, ends = rows[np.r_[0, cut + 1]], rows[np.r_[cut, rows.size - 1]]
    return [(float(theta_deg[a]), float(theta_deg[b])) for a, b in zip(starts, ends)]


def status_messages(theta_deg: np.ndarray, no_assembly: np.ndarray) -> list[str]:
    """The in-house engine's messages about a case's rows: where it cannot assemble (``no_assembly``, a
    ``(n,)`` mask of the rows whose status is ``no_assembly``)."""
    return no_assembly_message(no_assembly_ranges(theta_deg, no_assembly))


def no_assembly_message(ranges: list[tuple[float, float]]) -> list[str]:
    """The message naming the crank-angle ranges (degrees) where the rod cannot reach the slider line."""
    if not ranges:
        return []
    return ["no_assembly: the rod cannot reach the slider line at crank angles "
            f"{format_angle_ranges(ranges)} deg"]


def format_angle_ranges(ranges: list[tuple[float, float]]) -> str:
    """``"a..b, c..d"``: crank-angle ranges (degrees) as every message about them writes them; a range of one
    value is that value (``"230"``, not ``"230..230"``)."""
    return ", ".join(f"{a:g}" if a == b else f"{a:g}..{b:g}" for a, b in ranges)
