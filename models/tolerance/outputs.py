"""What one sampled design delivers: stroke, peak joint loads, how much of the cycle assembles.

Every output is read from the engines' common :class:`~dualmech.core.table.ResultTable`
(``docs/conventions.md``, "Output columns"), so the in-house solver and the judges are read
alike.  Per design (``docs/conventions.md``, "Tolerance analysis"):

* ``stroke`` -- ``max S4 - min S4`` over the assembled positions (:data:`~dualmech.core.status.ASSEMBLED`);
* ``peak_jN_force`` -- the largest ``|(jN_fx, jN_fy, jN_fz)|`` over the ``ok`` positions (N = 1..4);
* ``peak_j1_moment``, ``peak_j4_moment`` -- the largest moment magnitude (joint 1 about O,
  joint 4 about P3, as the columns);
* ``peak_drive_torque`` (max ``|drive_torque|``) when the slider load is given, or
  ``peak_slider_load`` (max ``|slider_load|``) when the drive torque is given;
* ``assembled_fraction`` -- share of the case's crank positions that assemble;
  ``dead_centres`` -- positions flagged ``dead_centre`` (torque mode; excluded from every peak,
  as are ``assembly_limit`` positions, whose reactions are not given); ``failed_positions`` --
  positions where the engine failed (``branch_jump``, ``not_converged``, ``not_finite``);
* ``status`` -- a :class:`DesignStatus`.

A peak is the maximum over the sampled crank angles; its crank position is the one
:func:`peak_positions` returns (the sensitivities are taken there).
"""

from __future__ import annotations

from enum import StrEnum
from typing import Sequence

import numpy as np

from dualmech.core.status import ASSEMBLED, Status, is_status
from dualmech.core.table import ResultTable


class DesignStatus(StrEnum):
    """Status of one sampled design (a whole crank cycle)."""

    OK = Status.OK.value  # every position assembles
    PARTIAL = "partial"  # some positions assemble, some do not (or the engine failed there)
    NO_ASSEMBLY = Status.NO_ASSEMBLY.value  # no position assembles


#: Joints and the column prefixes of their force and moment vectors.
FORCES: tuple[tuple[str, str], ...] = (("peak_j1_force", "j1_f"), ("peak_j2_force", "j2_f"),
                                      ("peak_j3_force", "j3_f"), ("peak_j4_force", "j4_f"))
MOMENTS: tuple[tuple[str, str], ...] = (("peak_j1_moment", "j1_m"), ("peak_j4_moment", "j4_m"))
#: The solved load's peak: its name and column, per load mode (the given one is not an output).
SOLVED_LOAD: dict[str, tuple[str, str]] = {"torque": ("peak_slider_load", "slider_load"),
                                           "force": ("peak_drive_torque", "drive_torque")}
#: Count columns beside the outputs.
COUNTS: tuple[str, ...] = ("assembled_fraction", "dead_centres", "failed_positions")
#: Position status words that are engine failures.
FAILURES: tuple[str, ...] = (Status.BRANCH_JUMP, Status.NOT_CONVERGED, Status.NOT_FINITE)


def output_names(mode: str) -> tuple[str, ...]:
    """The outputs of a design in load mode ``mode`` (``"torque"`` or ``"force"``), in column order."""
    return ("stroke",) + tuple(n for n, _ in FORCES + MOMENTS) + (SOLVED_LOAD[mode][0],)


def _magnitude(tables: Sequence[ResultTable], prefix: str) -> np.ndarray:
    """``|(x, y, z)|`` of a vector column triple, ``(m, p)``."""
    parts = [np.stack([t[f"{prefix}{a}"] for t in tables]) for a in "xyz"]
    return np.sqrt(parts[0] ** 2 + parts[1] ** 2 + parts[2] ** 2)


def _masked_arg(values: np.ndarray, mask: np.ndarray, largest: bool) -> np.ndarray:
    """Index ``(m,)`` of the largest (smallest) finite ``values`` ``(m, p)`` where ``mask``; -1 if none."""
    ok = mask & np.isfinite(values)
    fill = -np.inf if largest else np.inf
    filled = np.where(ok, values, fill)
    idx = np.argmax(filled, axis=1) if largest else np.argmin(filled, axis=1)
    return np.where(ok.any(axis=1), idx, -1)


def _at(values: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """``values[i, idx[i]]``, NaN where ``idx`` is -1."""
    got = values[np.arange(values.shape[0]), np.maximum(idx, 0)]
    return np.where(idx >= 0, got, np.nan)


def _peak_quantities(tables: Sequence[ResultTable], mode: str) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Per peak output: the values it maximises ``(m, p)`` and the rows it may use ``(m, p)``."""
    status = np.stack([np.asarray(t.status, dtype=str) for t in tables])
    usable = status == Status.OK.value
    out = {name: (_magnitude(tables, prefix), usable) for name, prefix in FORCES + MOMENTS}
    name, column = SOLVED_LOAD[mode]
    out[name] = (np.abs(np.stack([t[column] for t in tables])), usable)
    return out


def peak_positions(tables: Sequence[ResultTable], mode: str) -> dict[str, tuple[np.ndarray, ...]]:
    """Row indices behind every output, ``(m,)`` each (-1 if none): ``stroke`` -> (argmax S4, argmin S4),
    every peak -> (its argmax,)."""
    status = np.stack([np.asarray(t.status, dtype=str) for t in tables])
    assembled = is_status(status.ravel(), *ASSEMBLED).reshape(status.shape)
    s4 = np.stack([t["S4"] for t in tables])
    out: dict[str, tuple[np.ndarray, ...]] = {
        "stroke": (_masked_arg(s4, assembled, True), _masked_arg(s4, assembled, False))}
    for name, (values, usable) in _peak_quantities(tables, mode).items():
        out[name] = (_masked_arg(values, usable, True),)
    return out


def design_outputs(tables: Sequence[ResultTable], mode: str) -> dict[str, np.ndarray]:
    """Every output, count and the status of ``m`` designs (module docstring), arrays ``(m,)``.

    ``tables`` are the designs' result tables, all over the same crank angles.
    """
    status = np.stack([np.asarray(t.status, dtype=str) for t in tables])
    flat = status.ravel()
    assembled = is_status(flat, *ASSEMBLED).reshape(status.shape)
    s4 = np.stack([t["S4"] for t in tables])
    where = peak_positions(tables, mode)
    hi, lo = where["stroke"]
    out = {"stroke": _at(s4, hi) - _at(s4, lo)}
    for name, (values, _) in _peak_quantities(tables, mode).items():
        out[name] = _at(values, where[name][0])
    frac = assembled.mean(axis=1)
    out["assembled_fraction"] = frac
    out["dead_centres"] = (status == Status.DEAD_CENTRE.value).sum(axis=1)
    out["failed_positions"] = is_status(flat, *FAILURES).reshape(status.shape).sum(axis=1)
    design = np.where(frac == 1.0, DesignStatus.OK.value, DesignStatus.PARTIAL.value).astype(object)
    design[frac == 0.0] = DesignStatus.NO_ASSEMBLY.value
    out["status"] = design
    return out
