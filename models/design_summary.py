"""What a designer wants first from one solved case: stroke, peak joint loads and where, dead centres.

Computed from a :class:`~dualmech.core.table.ResultTable` alone (any engine's), so the
report and ``dualmech solve`` print the same numbers; units come from the case's label
(:mod:`dualmech.models.units`).  Peaks are taken over the ``ok`` rows: a dead centre
has no finite reactions, and is listed instead.

A peak is judged against the case's own scale of its unit group (the largest force peak, or the
largest moment peak): at most :data:`~dualmech.core.thresholds.ROUND_OFF_RELATIVE` of it, the load
is **structurally zero** (the solver's round-off: shown as 0 with that level, no angle); varying by
no more than that over the ``ok`` rows, it is **constant** (its value, no angle).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from dualmech.core.status import Status, is_status
from dualmech.core.table import ResultTable
from dualmech.core.thresholds import ROUND_OFF_RELATIVE
from dualmech.models.case import Case
from dualmech.models.plausibility import masses_line
from dualmech.models.units import column_unit

#: |transmission| below this is a warning: the slider load (torque mode) or the drive torque (force mode)
#: is more than 20x its value at the best transmission; real mechanisms are designed well above it.
NEAR_DEAD_CENTRE_TRANSMISSION = 0.05
#: Joints, their force columns and, where the joint carries one, their moment columns.
JOINTS: tuple[tuple[str, tuple[str, ...], tuple[str, ...]], ...] = (
    ("joint 1 (crank bearing)", ("j1_fx", "j1_fy", "j1_fz"), ("j1_mx", "j1_my", "j1_mz")),
    ("joint 2 (crank pin ball)", ("j2_fx", "j2_fy", "j2_fz"), ()),
    ("joint 3 (slider pin)", ("j3_fx", "j3_fy", "j3_fz"), ("j3_mx", "j3_my", "j3_mz")),  # moment: universal
    ("joint 4 (slider guide)", ("j4_fx", "j4_fy", "j4_fz"), ("j4_mx", "j4_my", "j4_mz")),
)

#: The name of every peak a summary gives, in order.
PEAK_NAMES: tuple[str, ...] = tuple(
    f"{joint} |{kind}|" for joint, forces, moments in JOINTS
    for kind, cols in (("force", forces), ("moment", moments))
    if cols) + ("|drive_torque|", "|slider_load|")
#: What a :class:`Peak` is: a genuine peak at an angle, a constant magnitude, or the solver's round-off.
PEAK, CONSTANT, ZERO = "peak", "constant", "zero"


@dataclass(frozen=True)
class Peak:
    """The largest magnitude of a quantity over the ok rows, and the crank angle where it occurs.

    ``kind`` is :data:`PEAK`, :data:`CONSTANT` (``theta_deg`` NaN: every ok row has it) or :data:`ZERO`
    (``value`` 0, ``theta_deg`` NaN, ``round_off`` the largest magnitude the solver left); ``scale`` is the
    case's scale of the unit group it was judged against (module docstring).  ``theta_deg`` is the row's
    input value: the crank angle in degrees, or where ``key`` names it (a loop table driven by a slide,
    ``"s1"``), that coordinate in the case's units.
    """

    name: str
    value: float
    theta_deg: float
    unit: str
    kind: str = PEAK
    round_off: float = 0.0
    scale: float = float("nan")
    key: str = ""

    @property
    def where(self) -> str:
        """Where the peak is, for a table cell: ``at 55°`` (``at s1 = 0.05`` for a ``key``), ``constant``, or
        the round-off level."""
        if self.kind == ZERO:
            level = f"round-off {self.round_off:.1e} {self.unit}".rstrip()  # no unit: no trailing space
            return level if self.round_off > 0 else "exactly 0"
        if self.kind == CONSTANT:
            return "constant"
        return f"at {self.key} = {self.theta_deg:g}" if self.key else f"at {self.theta_deg:g}°"

    def __str__(self) -> str:
        where = {ZERO: f"({self.where})", CONSTANT: "(constant)"}.get(
            self.kind, f"at {self.theta_deg:g} deg")
        value = "0" if self.kind == ZERO else f"{self.value:.6g}"
        return f"{self.name}: {value} {self.unit} {where}".replace("  ", " ")


@dataclass(frozen=True)
class DesignSummary:
    """The engineering summary of one solved case (module docstring); a mechanism without a slider
    (:func:`dualmech.models.linkages.table_summary`) has no stroke (NaN) and no near-dead-centre warning
    (empty)."""

    case: str
    engine: str
    stroke: float
    length_unit: str
    peaks: tuple[Peak, ...]
    dead_centres: tuple[float, ...]
    near_dead_centres: tuple[float, ...]
    statuses: dict[str, int]

    @property
    def unsolved(self) -> str:
        """The positions the engine gave no ``ok`` or ``dead_centre`` answer at, by word
        (``"no_assembly 25, branch_jump 1"``), or ``"none"``: what the peaks were not taken over."""
        others = [f"{w} {n}" for w, n in self.statuses.items() if w not in (Status.OK, Status.DEAD_CENTRE)]
        return ", ".join(others) or "none"

    def lines(self) -> list[str]:
        """The summary as text, one fact per line, with units."""
        out = [f"case {self.case} ({self.engine}): "
               + ", ".join(f"{w} {n}" for w, n in self.statuses.items()),
               f"stroke: {self.stroke:.9g} {self.length_unit}".rstrip()]
        out += [f"peak {p}" for p in self.peaks if np.isfinite(p.value)]
        if self.dead_centres:
            out.append(f"dead centres (no finite reactions) at theta1 = {_angles(self.dead_centres)} deg")
        if self.near_dead_centres:
            out.append(f"warning: |transmission| < {NEAR_DEAD_CENTRE_TRANSMISSION:g} (near a dead centre) at "
                       f"theta1 = {_angles(self.near_dead_centres)} deg")
        return out


def _angles(values: tuple[float, ...], limit: int = 8) -> str:
    shown = ", ".join(f"{v:g}" for v in values[:limit])
    return shown + (f", ... ({len(values)} positions)" if len(values) > limit else "")


def _peak(name: str, magnitude: np.ndarray, theta: np.ndarray, unit: str, key: str = "") -> Peak:
    """The largest finite ``magnitude`` and its input value; NaN for both when there is none (no ok row)."""
    finite = np.isfinite(magnitude)
    if not finite.any():
        return Peak(name, float("nan"), float("nan"), unit, key=key)
    i = int(np.flatnonzero(finite)[np.argmax(magnitude[finite])])
    return Peak(name, float(magnitude[i]), float(theta[i]), unit, key=key)


def _judged(peak: Peak, magnitude: np.ndarray, scale: float) -> Peak:
    """``peak`` as :data:`ZERO` or :data:`CONSTANT` when it is, against the group's ``scale``."""
    if not np.isfinite(peak.value):
        return peak
    level = ROUND_OFF_RELATIVE.value * scale
    nan = float("nan")
    if peak.value <= level:
        return replace(peak, value=0.0, theta_deg=nan, kind=ZERO, round_off=peak.value, scale=scale)
    spread = peak.value - float(np.nanmin(magnitude))
    if spread <= level:
        return replace(peak, theta_deg=nan, kind=CONSTANT, scale=scale)
    return replace(peak, scale=scale)


def peaks_of(loads: list[tuple[str, np.ndarray, str, str]], theta: np.ndarray, key: str = ""
           ) -> tuple[Peak, ...]:
    """The :class:`Peak` of every load ``(name, magnitude per row (NaN off the ok rows), unit, unit group
    "force" or "moment")``, judged against its group's largest peak (module docstring); ``theta`` the rows'
    input values, named by ``key`` if not the crank angle."""
    found = [(_peak(name, magnitude, theta, unit, key), magnitude, group)
             for name, magnitude, unit, group in loads]
    scales = {g: max((p.value for p, _, pg in found if pg == g and np.isfinite(p.value)), default=0.0)
              for g in ("force", "moment")}
    return tuple(_judged(p, magnitude, scales[g]) for p, magnitude, g in found)


def status_counts(status: np.ndarray) -> dict[str, int]:
    """How many rows have each status word."""
    words, counts = np.unique(np.asarray(status, dtype=str), return_counts=True)
    return {str(w): int(n) for w, n in zip(words, counts)}


def design_summary(table: ResultTable, units: str = "consistent") -> DesignSummary:
    """The :class:`DesignSummary` of ``table`` in the unit system ``units``."""
    ok = is_status(table.status, Status.OK)
    theta = table["theta1_deg"]

    def on_ok(column: str) -> np.ndarray:
        return np.where(ok, table[column], np.nan)

    loads = []  # (name, its magnitudes over the rows, unit, unit group)
    for joint, forces, moments in JOINTS:
        for kind, cols in (("force", forces), ("moment", moments)):
            if cols:
                magnitude = np.linalg.norm(np.stack([on_ok(c) for c in cols]), axis=0)
                loads.append((f"{joint} |{kind}|", magnitude, column_unit(cols[0], units), kind))
    for column, group in (("drive_torque", "moment"), ("slider_load", "force")):
        loads.append((f"|{column}|", np.abs(on_ok(column)), column_unit(column, units), group))
    s4 = table["S4"][is_status(table.status, Status.OK, Status.DEAD_CENTRE, Status.ASSEMBLY_LIMIT)]
    s4 = s4[np.isfinite(s4)]
    t = np.abs(table["transmission"])
    near = np.isfinite(t) & (t < NEAR_DEAD_CENTRE_TRANSMISSION) & ok
    return DesignSummary(
        case=table.case, engine=table.engine,
        stroke=float(s4.max() - s4.min()) if s4.size else float("nan"),
        length_unit=column_unit("S4", units),
        peaks=peaks_of(loads, theta),  # every name of PEAK_NAMES, in order
        dead_centres=tuple(float(a) for a in theta[is_status(table.status, Status.DEAD_CENTRE)]),
        near_dead_centres=tuple(float(a) for a in theta[near]),
        statuses=status_counts(table.status),
    )


def solve_summary(table: ResultTable, case: Case) -> str:
    """What ``dualmech solve`` prints about a slider crank's table: the design summary with the body masses,
    the worst closure residual, the engine's notes; units from ``case.units``."""
    lines = design_summary(table, case.units).lines()
    lines.insert(1, masses_line(case))
    res = table["residual"][table.status != Status.NO_ASSEMBLY]  # there: the reach's excess, not a closure's
    if np.isfinite(res).any():
        lines.append(f"worst closure residual: {np.nanmax(res):.3g}")
    lines += list(table.meta.get("messages", []))
    return "\n".join(lines)
