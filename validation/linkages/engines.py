"""Registry of the engines that solve a linkage case (RSSR, RCCC, a loop table) into a
:class:`~dualmech.models.linkages.table.LinkageTable`: the in-house method (``models/linkages/``,
``models/loop/``) and its judges (this package; a loop table's generated ones in
:mod:`dualmech.validation.judges`), as :mod:`dualmech.validation.engines` is for the slider crank.

Engines are imported lazily: solving with ``dualmech`` never imports Pinocchio or MuJoCo.  Every entry
is a function ``solve(case) -> LinkageTable`` of the checked case
(:func:`~dualmech.models.linkages.linkage_case`).
"""

from __future__ import annotations

from importlib import import_module
from pathlib import Path
from typing import Any

from dualmech.core.status import Status, is_status
from dualmech.models.inputs import CaseError, show
from dualmech.models.linkages import linkage_case, linkage_kind, read_linkage
from dualmech.models.linkages.table import LinkageTable

#: engine -> ``[mechanism] kind`` -> "module:function"; an engine solves only the kinds listed under it.
ENGINES: dict[str, dict[str, str]] = {
    "dualmech": {"rssr": "dualmech.models.linkages.rssr:solve_rssr",
                 "rccc": "dualmech.models.linkages.rccc:solve_rccc",
                 "loop": "dualmech.models.loop.table:solve_loop_table"},
    "pinocchio": {"rssr": "dualmech.validation.linkages.pinocchio_rssr:solve_pinocchio",
                  "rccc": "dualmech.validation.linkages.pinocchio_rccc:solve_pinocchio_rccc",
                  "loop": "dualmech.validation.judges.pinocchio_loop.table:solve_table"},
    "mujoco": {"rssr": "dualmech.validation.linkages.mujoco_rssr:solve_mujoco",
               "rccc": "dualmech.validation.linkages.mujoco_rccc:solve_mujoco_rccc",
               "loop": "dualmech.validation.judges.mujoco_loop.table:solve_table"},
    "mujoco-sim": {"rssr": "dualmech.validation.linkages.mujoco_rssr_sim:solve_mujoco_sim",
                   "rccc": "dualmech.validation.linkages.mujoco_rccc_sim:solve_mujoco_sim_rccc"},
}
#: Why an engine does not solve a kind at all (for its one-line refusal).
NOT_FOR: dict[tuple[str, str], str] = {
    ("mujoco-sim", "loop"): "; a loop table's generated MJCF cuts the loop with a weld that would lock the "
                            "cut joint: it is not a model for MuJoCo's simulation yet",
}


def solves(engine: str, kind: str, case: Any) -> bool:
    """Whether ``engine`` solves ``case`` of ``kind``: the kind is registered under it, and for the
    simulation (a servo drives the input through the case's angles) the case gives the output torque (an
    RCCC case always does: its drive torque is always solved; an RSSR case in output-torque mode) and its
    loop closes (``ok``) at every one of those angles: a trajectory cannot pass where it does not (the
    in-house status words decide that, as they decide which rows every judge is compared on)."""
    if kind not in ENGINES.get(engine, {}):
        return False
    if engine != "mujoco-sim":
        return True
    given = kind == "rccc" or getattr(case, "mode", "") == "output"
    return given and bool(is_status(solve_case("dualmech", kind, case).status, Status.OK).all())


def solve_linkage(source: str | Path | dict, engine: str = "dualmech") -> LinkageTable:
    """Solve every crank position of a linkage case (a TOML file, a bundled case ``"rssr"`` / ``"rccc"`` /
    ``"rscr"`` ... or a parsed dict) with ``engine``: ``"dualmech"`` (the in-house dual-number method),
    ``"pinocchio"``, ``"mujoco"`` (the rigid judges; a loop table's are generated from it) or
    ``"mujoco-sim"`` (MuJoCo's simulation of an RCCC case or an RSSR case in output-torque mode: its rows are
    the simulated input states; not a loop table).

    Raises
    ------
    CaseError
        One line, for any invalid input, and for an engine that does not solve the case.
    """
    if engine not in ENGINES:
        raise CaseError(f"engine: {show(engine)} does not solve linkages (valid: {', '.join(ENGINES)})")
    data = read_linkage(source)
    case = linkage_case(data)
    kind = linkage_kind(data)
    if not solves(engine, kind, case):
        valid = [e for e in ENGINES if solves(e, kind, case)]
        why = ("; its input is servo-driven through every angle of the case: the case must give "
               "loads.output_torque and its loop close at all of them") if kind in ENGINES[engine] else \
            NOT_FOR.get((engine, kind), "")
        raise CaseError(f"engine: {show(engine)} does not solve this {kind.upper()} case (valid: "
                        f"{', '.join(valid)}{why})")
    return solve_case(engine, kind, case)


def solve_case(engine: str, kind: str, case: Any) -> LinkageTable:
    """``case`` (checked, of ``kind``) solved by ``engine``, which must solve it (:func:`solves`)."""
    module, function = ENGINES[engine][kind].split(":")
    return getattr(import_module(module), function)(case)
