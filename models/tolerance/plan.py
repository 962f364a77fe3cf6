"""What a tolerance study needs of a kind of mechanism, and the study's case of any kind.

The study's steps (sampling, chunks, statistics, the report: :mod:`~dualmech.models.tolerance.study`,
:mod:`~dualmech.models.tolerance.summary`, :mod:`dualmech.validation.tolerance`) are one code path for
every kind; what differs -- which keys may vary, how a sampled design is built and solved, which outputs it
has, how its derivatives are taken -- is the kind's :class:`TolerancePlan`, named ``"module:name"`` in the
kind table (:data:`~dualmech.models.kinds.KIND_HOMES`, ``tolerance``): the slider crank's
(:mod:`~dualmech.models.tolerance.slider_crank`: its compiled kernel's arrays, complex-step derivatives)
and the table kinds' (:mod:`~dualmech.models.tolerance.tables`: the RSSR, RCCC and loop tables by their
:class:`~dualmech.models.tables.TableSpec`).

A study's case is the slider crank's :class:`~dualmech.models.case.Case` (which keeps its case table as
``raw``), or a :class:`TableCase`: another kind's checked record with the case table it was read from (a
SPEC addresses the table's keys, and the chunks' workers rebuild the case from it).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from dualmech.models.case import Case
from dualmech.models.catalogue import bundled_case_path, load_mechanism
from dualmech.models.inputs import CaseError
from dualmech.models.kinds import KIND_HOMES, kind_of, resolve
from dualmech.models.tolerance.sensitivity import Sensitivities
from dualmech.models.tolerance.spec import Spec
from dualmech.models.toml_input import read_toml


@dataclass(frozen=True)
class TableCase:
    """A checked case of a kind other than the slider crank (``record``) and the case table ``raw`` it was
    read from; ``name`` is the record's, ``units`` the table's label (``"consistent"`` where it states
    none; a loop table's record has none)."""

    raw: dict
    record: Any
    name: str = field(init=False)
    units: str = field(init=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "name", self.record.name)
        object.__setattr__(self, "units", str(self.raw.get("units", "consistent")))


#: A study's case: the slider crank's, or another kind's with its table.
StudyCase = Case | TableCase


@dataclass(frozen=True)
class TolerancePlan:
    """A kind's parts of a tolerance study (``case``: a :data:`StudyCase`; ``record``: a checked record, the
    nominal one or a sampled design).

    ``keys(case)``: the keys a SPEC may vary; ``nominal_values(case, spec)``: their values ``(k,)`` (a
    :class:`~dualmech.models.tolerance.spec.SpecError` naming the valid keys for one that is not);
    ``design(case, spec, values, name)``: a sampled design's record (a one-line CaseError where the kind's
    reader refuses it); ``outputs(record)``, ``units(case)``: the outputs in order and their units;
    ``groups(record)``: the loads' unit groups {group: outputs} (round-off is judged within a group);
    ``mode(record)``: the load mode (``summary.json``'s ``mode``); ``table_outputs(tables, record)``: every
    output, count and status of the designs whose result tables are ``tables`` ``(m,)``;
    ``analyse(case, spec, x, first)``: the same of the sampled designs ``x`` ``(m, k)`` (design ``first``
    first), batched; ``sensitivities(case, spec, table)``: ``d output / d key`` at the nominal design (its
    table ``table``); ``points(case, spec, sens, x)``: each output of the designs ``x`` at the drive
    positions of its derivative, ``(m,)`` each (the central differences that check the sensitivities);
    ``masses(case)``: the line about the nominal design's body masses ``dualmech tolerance`` prints;
    ``method``: how the sensitivities are taken (``summary.json``).
    """

    keys: Callable[[Any], tuple[str, ...]]
    nominal_values: Callable[[Any, Spec], np.ndarray]
    design: Callable[[Any, Spec, np.ndarray, str], Any]
    outputs: Callable[[Any], tuple[str, ...]]
    units: Callable[[Any], dict[str, str]]
    groups: Callable[[Any], Mapping[str, tuple[str, ...]]]
    mode: Callable[[Any], str]
    table_outputs: Callable[[Sequence[Any], Any], dict[str, np.ndarray]]
    analyse: Callable[[Any, Spec, np.ndarray, int], dict[str, np.ndarray]]
    sensitivities: Callable[[Any, Spec, Any], Sensitivities]
    points: Callable[[Any, Spec, Sensitivities, np.ndarray], dict[str, np.ndarray]]
    masses: Callable[[Any], str]
    method: str


def record_of(case: StudyCase) -> Any:
    """The checked record of a study's case (the slider crank's case is its own)."""
    return case.record if isinstance(case, TableCase) else case


def plan_of(case: Any) -> TolerancePlan:
    """The :class:`TolerancePlan` of a study's case or a checked record, by its kind."""
    return resolve(KIND_HOMES[kind_of(record_of(case))].tolerance)


def in_house(record: Any) -> Callable[[Any], Any]:
    """The in-house solver of ``record``'s kind (checked record -> result table)."""
    return resolve(KIND_HOMES[kind_of(record)].solver)


def study_case(source: Any) -> StudyCase:
    """The study's case of ``source``: a slider-crank :class:`~dualmech.models.case.Case` as is, a case
    table (dict), a case file or a bundled preset name of any kind (``dualmech cases``).

    Raises
    ------
    CaseError
        One line: an invalid case, or another kind's checked record without its table (a SPEC addresses
        the case table's keys: give its file, name or table).
    """
    record = load_mechanism(source)  # every kind's one-line errors
    if isinstance(record, Case):
        return record
    if record is source:
        raise CaseError(f"case: the tolerance study of a {kind_of(source)} case needs its case table (a SPEC "
                        "varies the table's keys): give its file, its bundled name or its table (dict)")
    if isinstance(source, dict):
        return TableCase(source, record)
    path = Path(source)
    return TableCase(read_toml(path if path.is_file() else bundled_case_path(str(source)), CaseError), record)
