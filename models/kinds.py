"""The kinds of mechanism, and the one place a case's kind is decided.

A case table names its kind in ``[mechanism] kind`` (``docs/conventions.md``, "Case files", "Linkages",
"Loop tables"): ``slider-crank`` (the default of a table without one; :mod:`dualmech.models.case`),
``rssr``, ``rccc`` (:mod:`dualmech.models.linkages`) or ``loop`` (a joint table, :mod:`dualmech.models.loop`).
Each kind has its own checked case record, reader, in-house solver and result-table spec, named here as
``"module:name"`` and imported at first use, so that this module depends on none of them (every kind's
modules may read it); the engines that solve each kind are registered in
:data:`dualmech.validation.engines.ENGINES`.
"""

from __future__ import annotations

from importlib import import_module
from typing import Any, NamedTuple

#: ``[mechanism] kind`` of the generalized slider crank (also a case table without ``[mechanism]``).
SLIDER_CRANK = "slider-crank"


class Kind(NamedTuple):
    """Where a kind's parts live, each ``"module:name"`` (``""``: the kind has none).

    ``record``: its checked case (a class); ``reader``: parsed case table -> record (one-line
    CaseError); ``solver``: its in-house engine (record -> result table); ``spec``: its table's
    :class:`~dualmech.models.tables.TableSpec`, or a function of the record (empty for the
    slider crank, whose table is :class:`~dualmech.core.table.ResultTable`); ``simulator``: its forward
    dynamics (record, duration, options -> a simulation); ``summary``: (table, record) -> the few lines
    ``dualmech solve`` prints; ``sim_summary``: simulation -> the lines ``dualmech simulate`` prints;
    ``sim_options``: the simulator's keyword options beyond the common ones (:data:`SIM_OPTIONS`);
    ``warnings``: record -> one line per implausible size (warnings, never errors); ``assembly``:
    record -> why the design assembles at no drive position, or ``None`` (``dualmech solve`` refuses
    such a design); ``joint_frames``: (record, table, path) -> writes the joint-frame table of
    ``solve --frames joint``; ``tolerance``: its
    :class:`~dualmech.models.tolerance.plan.TolerancePlan` (``dualmech tolerance``).
    """

    record: str
    reader: str
    solver: str
    spec: str
    simulator: str
    summary: str
    sim_summary: str
    sim_options: tuple[str, ...] = ()
    warnings: str = ""
    assembly: str = ""
    joint_frames: str = ""
    tolerance: str = ""


#: The forward-dynamics options every kind's simulator takes (``dualmech.simulate``).
SIM_OPTIONS = ("torque", "psi0", "psidot0", "damping", "samples", "method", "rtol", "atol", "max_evaluations",
               "time_limit", "progress")

_LINKAGES = "dualmech.models.linkages"
#: The tolerance plan of every kind whose table has a TableSpec (the RSSR, RCCC and loop tables).
_TABLE_TOLERANCE = "dualmech.models.tolerance.tables:PLAN"
#: Every kind dualmech solves.
KIND_HOMES: dict[str, Kind] = {
    SLIDER_CRANK: Kind("dualmech.models.case:Case", "dualmech.models.case:case_from_dict",
                       "dualmech.models.slider_crank.analysis:solve_case", "",
                       "dualmech.models.slider_crank.forward_dynamics:simulate",
                       "dualmech.models.design_summary:solve_summary",
                       "dualmech.models.simulation_summary:slider_crank_summary",
                       sim_options=("slider_load", "slider_damping"),
                       warnings="dualmech.models.plausibility:implausible",
                       assembly="dualmech.models.slider_crank.analysis:assembly_failure",
                       joint_frames="dualmech.models.joint_frames:write_joint_frame_csv",
                       tolerance="dualmech.models.tolerance.slider_crank:PLAN"),
    "rssr": Kind(f"{_LINKAGES}.rssr_case:RssrCase", f"{_LINKAGES}.rssr_case:rssr_from_dict",
                 "dualmech.models.loop.preset_engine:solve_rssr", f"{_LINKAGES}.rssr:SPEC",
                 "dualmech.models.loop.preset_dynamics:simulate", f"{_LINKAGES}:summary",
                 f"{_LINKAGES}.forward_dynamics:linkage_summary", tolerance=_TABLE_TOLERANCE),
    "rccc": Kind(f"{_LINKAGES}.rccc_case:RcccCase", f"{_LINKAGES}.rccc_case:rccc_from_dict",
                 "dualmech.models.loop.preset_engine:solve_rccc", f"{_LINKAGES}.rccc:SPEC",
                 "dualmech.models.loop.preset_dynamics:simulate", f"{_LINKAGES}:summary",
                 f"{_LINKAGES}.forward_dynamics:linkage_summary", tolerance=_TABLE_TOLERANCE),
    "loop": Kind("dualmech.models.loop.description:LoopMechanism",
                 "dualmech.models.loop.table_format:loop_from_dict",
                 "dualmech.models.loop.table:solve_loop_table", "dualmech.models.loop.columns:loop_spec",
                 "dualmech.models.loop.forward_dynamics:simulate", f"{_LINKAGES}:summary",
                 "dualmech.models.loop.forward_dynamics:loop_summary", tolerance=_TABLE_TOLERANCE),
}
KINDS = tuple(KIND_HOMES)
#: The kinds other than the slider crank (the linkages: their own case format and table columns).
LINKAGE_KINDS = tuple(k for k in KINDS if k != SLIDER_CRANK)
_KIND_OF_RECORD = {home.record: kind for kind, home in KIND_HOMES.items()}


def resolve(home: str) -> Any:
    """The object a ``"module:name"`` names (its module imported now)."""
    module, name = home.split(":")
    return getattr(import_module(module), name)


def is_record(case: Any) -> bool:
    """Whether ``case`` is a checked case record of a kind (:data:`KIND_HOMES`)."""
    return f"{type(case).__module__}:{type(case).__qualname__}" in _KIND_OF_RECORD


def declared_kind(data: Any) -> Any:
    """``[mechanism] kind`` of a parsed case table as written (any value), or ``None`` without one."""
    mech = data.get("mechanism") if isinstance(data, dict) else None
    return mech.get("kind") if isinstance(mech, dict) else None


def kind_of(case: Any) -> str:
    """The kind of ``case``: a checked case record (:data:`KIND_HOMES`) or a parsed case table (its
    ``[mechanism] kind`` if that is one of :data:`KINDS`; otherwise the slider crank's, whose reader then
    refuses a kind it does not know in one line).  Never raises."""
    record = _KIND_OF_RECORD.get(f"{type(case).__module__}:{type(case).__qualname__}")
    if record is not None:
        return record
    kind = declared_kind(case)
    return kind if isinstance(kind, str) and kind in KINDS else SLIDER_CRANK


def case_from_data(data: dict) -> Any:
    """The checked case record of the parsed case table ``data``, by its kind (:func:`kind_of`).

    Raises
    ------
    CaseError
        One line, for any invalid input.
    """
    return resolve(KIND_HOMES[kind_of(data)].reader)(data)
