"""Single-loop linkages other than the slider crank, from the same link-joint table and the same method.

:func:`solve_linkage` reads a case (a path, a bundled case ``"rssr"`` or a parsed
dict) whose ``[mechanism] kind`` names the linkage, and returns the in-house engine's
:class:`~dualmech.models.tables.LinkageTable` (``docs/conventions.md``, "RSSR", "RCCC").
Every engine (the judges: :mod:`dualmech.validation.judges`) solves them through
:func:`dualmech.validation.engines.solve_checked`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from dualmech.core.status import Status, is_status
from dualmech.models.design_summary import DesignSummary, peaks_of, status_counts
from dualmech.models.inputs import CaseError, show
from dualmech.models.kinds import KIND_HOMES, LINKAGE_KINDS, declared_kind, resolve
from dualmech.models.tables import LinkageTable, TableSpec
from dualmech.models.toml_input import read_toml
from dualmech.models.units import UNIT_SYSTEMS

#: The bundled RSSR and RCCC cases (``<stem>.toml``).
CASES = Path(__file__).resolve().parent / "cases"
#: The folders of every bundled linkage case (stems unique across them): :data:`CASES`, then the loop
#: tables' (``models/loop/cases/``).
CASE_FOLDERS: tuple[Path, ...] = (CASES, Path(__file__).resolve().parent.parent / "loop" / "cases")


def _bundled() -> dict[str, Path]:
    return {p.stem: p for folder in CASE_FOLDERS for p in folder.glob("*.toml")}


def bundled_names() -> list[str]:
    """Stems of the bundled linkage cases (``"rccc"``, ``"rscr"``, ``"rssr"``, ...), sorted."""
    return sorted(_bundled())


def bundled_path(name: str) -> Path:
    """File of the bundled linkage case ``name`` (a stem of :func:`bundled_names`); a one-line CaseError
    naming the valid ones otherwise."""
    bundled = bundled_names()
    if name not in bundled:
        raise CaseError(f"case: {show(name)} is neither a file nor a bundled linkage case "
                        f"(bundled: {', '.join(bundled)})")
    return _bundled()[name]


def read_linkage(source: str | Path | dict) -> dict:
    """The parsed case table of ``source``: a dict as is, else a TOML file or a bundled case's stem
    (``"rssr"``)."""
    if isinstance(source, dict):
        return source
    path = Path(source)
    return read_toml(path if path.is_file() else bundled_path(str(source)), CaseError)


def is_linkage(source: str | Path | dict) -> bool:
    """Whether ``source`` (a dict, a TOML file or a name) is a linkage case: ``[mechanism] kind`` in
    :data:`~dualmech.models.kinds.LINKAGE_KINDS`, or a bundled linkage stem.  Never raises: a slider-crank
    case or preset name is ``False`` (for the command line's dispatch)."""
    if isinstance(source, dict):
        return declared_kind(source) in LINKAGE_KINDS
    path = Path(source)
    if not path.is_file():
        return str(source) in _bundled()
    try:
        return declared_kind(read_toml(path, CaseError)) in LINKAGE_KINDS
    except CaseError:
        return False


def linkage_case(source: str | Path | dict) -> Any:
    """The checked case of a linkage (:class:`~dualmech.models.linkages.rssr_case.RssrCase`,
    :class:`~dualmech.models.linkages.rccc_case.RcccCase` or a loop table's
    :class:`~dualmech.models.loop.description.LoopMechanism`), by its ``[mechanism] kind``.

    Raises
    ------
    CaseError
        One line, for any invalid input (including a ``kind`` not one of
        :data:`~dualmech.models.kinds.LINKAGE_KINDS`).
    """
    data = read_linkage(source)
    kind = declared_kind(data)
    if kind in LINKAGE_KINDS:
        return resolve(KIND_HOMES[kind].reader)(data)
    raise CaseError(f"mechanism.kind: {show(kind)} is not a linkage dualmech solves here "
                    f"(valid: {', '.join(LINKAGE_KINDS)})")


def solve_linkage(source: str | Path | dict) -> LinkageTable:
    """Solve every crank position of a linkage case with the in-house dual-number method.

    The judges (Pinocchio, MuJoCo rigid and simulated) solve it through
    :func:`dualmech.validation.engines.solve_linkage` (``engine=``), beside the slider crank's engines.

    Raises
    ------
    CaseError
        One line, for any invalid input (including a ``kind`` not one of
        :data:`~dualmech.models.kinds.LINKAGE_KINDS`).
    """
    data = read_linkage(source)
    case = linkage_case(data)  # first: an unknown kind is a one-line CaseError
    return resolve(KIND_HOMES[declared_kind(data)].solver)(case)


def table_spec(kind: str, case: Any) -> TableSpec:
    """The :class:`~dualmech.models.tables.TableSpec` of ``case``'s table (a checked case of
    ``kind``): the RSSR's and RCCC's are fixed, a loop table's follows its joints."""
    spec = resolve(KIND_HOMES[kind].spec)
    return spec if isinstance(spec, TableSpec) else spec(case)


def table_summary(table: LinkageTable, spec: TableSpec, units: str = "consistent") -> DesignSummary:
    """The slider crank's :class:`~dualmech.models.design_summary.DesignSummary` of a linkage's or loop
    table's ``table`` by its ``spec``: the peak of every load of
    :attr:`~dualmech.models.tables.TableSpec.loads` over the ``ok`` rows, at the input value (the
    spec's key) where it occurs, and the ``dead_centre`` rows' input values; no stroke (NaN), no
    near-dead-centre warning.  Units of the label ``units`` (none for a label that is not a
    :data:`~dualmech.models.units.UNIT_SYSTEMS` key)."""
    ok = is_status(table.status, Status.OK)
    system = UNIT_SYSTEMS.get(units, UNIT_SYSTEMS["consistent"])
    loads = [(name, np.linalg.norm(np.stack([np.where(ok, table[c], np.nan) for c in cols]), axis=0),
              system.of(group), group) for name, cols, group in spec.loads]
    key = table[spec.key]
    name, unit = spec.key_label
    return DesignSummary(
        case=table.case, engine=table.engine, stroke=float("nan"), length_unit=system.of("length"),
        peaks=peaks_of(loads, key, "" if unit == "deg" else name),
        dead_centres=tuple(float(a) for a in key[is_status(table.status, Status.DEAD_CENTRE)]),
        near_dead_centres=(), statuses=status_counts(table.status),
    )


def summary(table: LinkageTable, case: Any = None) -> str:
    """A short text about a linkage table (of ``case``, unused: the table names it): engine, case, rows,
    status counts, worst closure residual (not over the ``no_assembly`` rows, whose residual is the least
    error of a loop that does not close, as the slider crank's), the engine's messages (e.g. the
    ``no_assembly`` ranges)."""
    words, counts = np.unique(np.asarray(table.status, dtype=str), return_counts=True)
    lines = [f"{table.engine}: {table.case}, {len(table)} positions: "
             + ", ".join(f"{c} {w}" for w, c in zip(words, counts))]
    residual = table.columns["residual"][~is_status(table.status, Status.NO_ASSEMBLY)]
    if np.isfinite(residual).any():
        lines.append(f"worst closure residual: {np.nanmax(residual):.3g}")
    return "\n".join(lines + list(table.meta.get("messages", [])))
