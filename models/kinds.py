"""The kinds of mechanism, and the one place a case's kind is decided.

A case table names its kind in ``[mechanism] kind`` (``docs/conventions.md``, "Case files", "Linkages",
"Loop tables"): ``slider-crank`` (the default of a table without one; :mod:`dualmech.models.case`),
``rssr``, ``rccc`` (:mod:`dualmech.models.linkages`) or ``loop`` (a joint table, :mod:`dualmech.models.loop`).
Each kind has its own reader, which checks the table into its case record; the engines that solve each kind
are registered in :data:`dualmech.validation.engines.ENGINES`.
"""

from __future__ import annotations

from typing import Any

from dualmech.models.case_format import SLIDER_CRANK

#: ``[mechanism] kind`` -> ``"module:Class"`` of its checked case record.
CASE_RECORDS: dict[str, str] = {
    SLIDER_CRANK: "dualmech.models.case:Case",
    "rssr": "dualmech.models.linkages.rssr_case:RssrCase",
    "rccc": "dualmech.models.linkages.rccc_case:RcccCase",
    "loop": "dualmech.models.loop.description:LoopMechanism",
}
#: Every kind dualmech solves.
KINDS = tuple(CASE_RECORDS)
_KIND_OF_RECORD = {record: kind for kind, record in CASE_RECORDS.items()}


def kind_of(case: Any) -> str:
    """The kind of ``case``: a checked case record (:data:`CASE_RECORDS`) or a parsed case table (its
    ``[mechanism] kind`` if that is one of :data:`KINDS`; otherwise the slider crank's, whose reader then
    refuses a kind it does not know in one line).  Never raises."""
    record = _KIND_OF_RECORD.get(f"{type(case).__module__}:{type(case).__qualname__}")
    if record is not None:
        return record
    mech = case.get("mechanism") if isinstance(case, dict) else None
    kind = mech.get("kind") if isinstance(mech, dict) else None
    return kind if isinstance(kind, str) and kind in KINDS else SLIDER_CRANK


def case_from_data(data: dict) -> Any:
    """The checked case record of the parsed case table ``data``, by its kind (:func:`kind_of`).

    Raises
    ------
    CaseError
        One line, for any invalid input.
    """
    if kind_of(data) == SLIDER_CRANK:
        from dualmech.models.case import case_from_dict

        return case_from_dict(data)
    from dualmech.models.linkages import linkage_case

    return linkage_case(data)
