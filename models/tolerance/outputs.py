"""What one sampled design delivers: stroke, peak joint loads, how much of the cycle assembles.

Every output is read from the in-house engine's columns (``docs/conventions.md``, "Output
columns"): a design's rows come as ``(designs, positions)`` blocks, either from the compiled
kernel (:func:`~dualmech.models.slider_crank.kernel.start_positions`, reduced block by block
by :class:`DesignReduction` without building a table per design) or from the engines' common
:class:`~dualmech.core.table.ResultTable` (:func:`design_outputs`, so the judges are read alike).
Per design (``docs/conventions.md``, "Tolerance analysis"):

* ``stroke`` -- ``max S4 - min S4`` over the assembled positions (:data:`~dualmech.core.status.ASSEMBLED`);
* ``peak_jN_force`` -- the largest ``|(jN_fx, jN_fy, jN_fz)|`` over the ``ok`` positions (N = 1..4);
* ``peak_j1_moment``, ``peak_j4_moment`` -- the largest moment magnitude (joint 1 about O,
  joint 4 about P3, as the columns);
* ``peak_drive_torque`` (max ``|drive_torque|``) when the slider load is given, or
  ``peak_slider_load`` (max ``|slider_load|``) when the drive torque is given;
* ``assembled_fraction`` -- share of the case's crank positions that assemble;
  ``dead_centres`` -- positions flagged ``dead_centre`` (torque mode; excluded from every peak,
  as are ``assembly_limit`` positions, whose reactions are not given); ``failed_positions`` --
  positions where the engine failed (``branch_jump``, ``not_converged``, ``not_finite``), ``branch_jumps``
  those of them where the loop closed on another branch than the one followed;
* ``status`` -- a :class:`DesignStatus`.

A peak is the maximum over the sampled crank angles; its crank position is the one
:func:`peak_positions` returns (the sensitivities are taken there).
"""

from __future__ import annotations

from enum import StrEnum
from typing import Mapping, Sequence

import numpy as np

from dualmech.core.status import ASSEMBLED, STATUSES, Status
from dualmech.core.table import ResultTable
from dualmech.models.units import column_unit


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
#: A column of each output's unit, and so its unit group (the loads' round-off is judged within a group).
OUTPUT_COLUMN: dict[str, str] = {"stroke": "S4", **{n: f"{p}x" for n, p in FORCES + MOMENTS},
                                 **{n: c for n, c in SOLVED_LOAD.values()}}
#: The loads' unit groups: an output is round-off against the largest peak of its group in the same design.
LOAD_GROUPS: dict[str, tuple[str, ...]] = {
    "force": tuple(n for n, _ in FORCES) + ("peak_slider_load",),
    "moment": tuple(n for n, _ in MOMENTS) + ("peak_drive_torque",),
}
#: Count columns beside the outputs.
COUNTS: tuple[str, ...] = ("assembled_fraction", "dead_centres", "failed_positions", "branch_jumps")
#: Position status words that are engine failures.
FAILURES: tuple[str, ...] = (Status.BRANCH_JUMP, Status.NOT_CONVERGED, Status.NOT_FINITE)


def _codes(words: frozenset[str] | tuple[str, ...]) -> np.ndarray:
    """Codes (positions in :data:`~dualmech.core.status.STATUSES`) of a set of status words."""
    return np.array(sorted(STATUSES.index(str(w)) for w in words), dtype=np.int8)


_ASSEMBLED, _FAILED = _codes(ASSEMBLED), _codes(FAILURES)
_OK, _DEAD = STATUSES.index(Status.OK), STATUSES.index(Status.DEAD_CENTRE)
_BRANCH = STATUSES.index(Status.BRANCH_JUMP)


def status_codes(words: np.ndarray) -> np.ndarray:
    """Status words (any shape) as codes into :data:`~dualmech.core.status.STATUSES`, same shape, int8."""
    unique, inverse = np.unique(np.asarray(words, dtype=str), return_inverse=True)
    return np.array([STATUSES.index(w) for w in unique], dtype=np.int8)[inverse].reshape(np.shape(words))


def output_names(mode: str) -> tuple[str, ...]:
    """The outputs of a design in load mode ``mode`` (``"torque"`` or ``"force"``), in column order."""
    return ("stroke",) + tuple(n for n, _ in FORCES + MOMENTS) + (SOLVED_LOAD[mode][0],)


def output_units(mode: str, units: str) -> dict[str, str]:
    """Each output's unit in the unit system ``units`` (``""`` where unstated), in :func:`output_names`
    order."""
    return {name: column_unit(OUTPUT_COLUMN[name], units) for name in output_names(mode)}


def needed_columns(mode: str) -> tuple[str, ...]:
    """The engine columns the outputs of load mode ``mode`` are read from."""
    vectors = tuple(f"{prefix}{a}" for _, prefix in FORCES + MOMENTS for a in "xyz")
    return ("S4",) + vectors + (SOLVED_LOAD[mode][1],)


#: Status code -> whether the row assembles (is failed): lookup tables, cheaper than ``np.isin`` per block.
IS_ASSEMBLED = np.isin(np.arange(len(STATUSES)), _ASSEMBLED)
_IS_FAILED = np.isin(np.arange(len(STATUSES)), _FAILED)


def _assembled(columns: Mapping[str, np.ndarray], codes: np.ndarray) -> np.ndarray:
    """Rows that assemble with a finite S4: the rows of the stroke."""
    return IS_ASSEMBLED[codes] & np.isfinite(columns["S4"])


def candidate_values(columns: Mapping[str, np.ndarray], codes: np.ndarray,
                     mode: str) -> dict[str, tuple[np.ndarray, ...]]:
    """Per output, the values it is the extreme of, ``(designs, positions)`` each, masked.

    ``stroke`` -> (S4 where assembled else -inf, S4 where assembled else +inf); every peak ->
    (its magnitude where the row is ``ok`` and it is finite, else -inf,).  ``columns``
    ``(designs, positions)`` in the units of the columns; ``codes`` the rows' status codes.
    """
    assembled = _assembled(columns, codes)
    ok = codes == _OK
    out: dict[str, tuple[np.ndarray, ...]] = {
        "stroke": (np.where(assembled, columns["S4"], -np.inf), np.where(assembled, columns["S4"], np.inf))}
    for name, prefix in FORCES + MOMENTS:
        x, y, z = (columns[f"{prefix}{a}"] for a in "xyz")
        out[name] = (_where_finite(ok, np.sqrt(x**2 + y**2 + z**2)),)
    name, column = SOLVED_LOAD[mode]
    out[name] = (_where_finite(ok, np.abs(columns[column])),)
    return out


def _where_finite(mask: np.ndarray, values: np.ndarray) -> np.ndarray:
    """``values`` where ``mask`` and finite, else -inf (a peak never comes from such a row)."""
    return np.where(mask & np.isfinite(values), values, -np.inf)


def _masked_max(mask: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Per design (row) the largest of ``values`` where ``mask`` and finite, else -inf, ``(d,)``."""
    return _where_finite(mask, values).max(axis=1)


def block_extremes(columns: Mapping[str, np.ndarray], codes: np.ndarray, mode: str) -> dict[str, np.ndarray]:
    """Per design, the extremes a block of positions gives each output, ``(d,)`` each.

    ``stroke`` -> its largest and smallest assembled S4 (``stroke_min``); a vector's peak -> the largest
    *squared* magnitude ``x**2 + y**2 + z**2`` (the square root is monotone, so the root of this maximum is
    bit for bit the largest magnitude, one root per design instead of one per position); the solved
    load -> its largest ``|value|``.  Masked as :func:`candidate_values` (``-inf``/``+inf`` where none).
    """
    assembled = _assembled(columns, codes)
    ok = codes == _OK
    s4 = columns["S4"]
    out = {"stroke": np.where(assembled, s4, -np.inf).max(axis=1),
           "stroke_min": np.where(assembled, s4, np.inf).min(axis=1)}
    for name, prefix in FORCES + MOMENTS:
        x, y, z = (columns[f"{prefix}{a}"] for a in "xyz")
        squared = np.square(x)
        squared += np.square(y)
        squared += np.square(z)
        out[name] = _masked_max(ok, squared)
    name, column = SOLVED_LOAD[mode]
    out[name] = _masked_max(ok, np.abs(columns[column]))
    return out


class DesignReduction:
    """Every output of ``m`` designs, reduced block by block over their positions (batched numpy).

    :meth:`add` takes a block of whole designs ``first .. first + d - 1`` at some of their
    positions; after every position of every design was added once, :meth:`result` gives
    what :func:`design_outputs` gives for their tables.  Vector peaks are kept squared
    (:func:`block_extremes`) until :meth:`result`.
    """

    def __init__(self, m: int, mode: str) -> None:
        self.mode = mode
        self.extremes = {name: np.full(m, -np.inf) for name in output_names(mode)}
        self.extremes["stroke_min"] = np.full(m, np.inf)
        self.counts = {k: np.zeros(m, dtype=np.int64)
                       for k in ("positions", "assembled", "dead", "failed", "branch")}

    def add(self, first: int, columns: Mapping[str, np.ndarray], codes: np.ndarray) -> None:
        """Fold in designs ``first ..`` at a block of positions: ``columns`` and ``codes`` ``(d, q)``."""
        rows = slice(first, first + codes.shape[0])
        for name, values in block_extremes(columns, codes, self.mode).items():
            fold = np.minimum if name == "stroke_min" else np.maximum
            fold(self.extremes[name][rows], values, out=self.extremes[name][rows])
        for name, count in position_counts(codes).items():
            self.counts[name][rows] += count

    def result(self) -> dict[str, np.ndarray]:
        """Every output, count and the status, arrays ``(m,)`` (module docstring)."""
        hi, lo = self.extremes["stroke"], self.extremes["stroke_min"]
        out = {"stroke": np.where(np.isfinite(hi) & np.isfinite(lo), hi - lo, np.nan)}
        vectors = {name for name, _ in FORCES + MOMENTS}
        for name in output_names(self.mode)[1:]:
            peak = self.extremes[name]
            found = np.isfinite(peak)
            out[name] = np.full(peak.shape, np.nan)
            out[name][found] = np.sqrt(peak[found]) if name in vectors else peak[found]
        return {**out, **design_counts(self.counts)}


def position_counts(codes: np.ndarray) -> dict[str, np.ndarray]:
    """Per design (row of the status codes ``codes`` ``(d, q)``), its positions, and those that assemble, are
    ``dead_centre``, failed or ``branch_jump``, ``(d,)`` each."""
    return {"positions": np.full(codes.shape[0], codes.shape[1], dtype=np.int64),
            "assembled": IS_ASSEMBLED[codes].sum(axis=1), "dead": (codes == _DEAD).sum(axis=1),
            "failed": _IS_FAILED[codes].sum(axis=1), "branch": (codes == _BRANCH).sum(axis=1)}


def design_counts(counts: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """:data:`COUNTS` and the :class:`DesignStatus` of designs whose :func:`position_counts` (summed over
    every position) are ``counts``, ``(m,)`` each."""
    frac = counts["assembled"] / counts["positions"]
    design = np.where(frac == 1.0, DesignStatus.OK.value, DesignStatus.PARTIAL.value).astype(object)
    design[frac == 0.0] = DesignStatus.NO_ASSEMBLY.value
    return {"assembled_fraction": frac, "dead_centres": counts["dead"].copy(),
            "failed_positions": counts["failed"].copy(), "branch_jumps": counts["branch"].copy(),
            "status": design}


def group_of(name: str, groups: Mapping[str, tuple[str, ...]]) -> tuple[str, ...]:
    """The outputs of ``name``'s unit group in ``groups`` (:data:`LOAD_GROUPS` or a table kind's): a value
    near 0 is judged by their peak; ``(name,)`` for an output of no group (a stroke, a range)."""
    return next((g for g in groups.values() if name in g), (name,))


def _stacked(tables: Sequence[ResultTable], mode: str) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """The needed columns and the status codes of ``m`` tables over the same angles, ``(m, p)``."""
    columns = {c: np.stack([t[c] for t in tables]) for c in needed_columns(mode)}
    return columns, status_codes(np.stack([np.asarray(t.status, dtype=str) for t in tables]))


def peak_positions(tables: Sequence[ResultTable], mode: str) -> dict[str, tuple[np.ndarray, ...]]:
    """Row indices behind every output, ``(m,)`` each (-1 if none): ``stroke`` -> (argmax S4, argmin S4),
    every peak -> (its argmax,)."""
    columns, codes = _stacked(tables, mode)
    out: dict[str, tuple[np.ndarray, ...]] = {}
    for name, values in candidate_values(columns, codes, mode).items():
        idx = (np.argmax(values[0], axis=1),) + ((np.argmin(values[1], axis=1),) if len(values) > 1 else ())
        rows = np.arange(codes.shape[0])
        out[name] = tuple(np.where(np.isfinite(v[rows, i]), i, -1) for v, i in zip(values, idx))
    return out


def design_outputs(tables: Sequence[ResultTable], mode: str) -> dict[str, np.ndarray]:
    """Every output, count and the status of ``m`` designs (module docstring), arrays ``(m,)``.

    ``tables`` are the designs' result tables, all over the same crank angles.
    """
    columns, codes = _stacked(tables, mode)
    reduction = DesignReduction(len(tables), mode)
    reduction.add(0, columns, codes)
    return reduction.result()
