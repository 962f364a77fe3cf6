"""The one registry of engines: every engine, every kind of mechanism it solves, and how.

``ENGINES[engine][kind]`` is the ``"module:function"`` that solves a checked case of ``kind`` (``[mechanism]
kind``: ``slider-crank``, the default of a case without one; ``rssr``, ``rccc``; ``loop``, a joint table)
into its result table: the in-house method (``models/``) and its judges (this package; a loop table's
generated from the table, :mod:`dualmech.validation.judges`).  The kind is a property of the case
(:func:`dualmech.models.kinds.kind_of`); an engine solves only the kinds listed under it.

Engines are imported lazily, so that solving with the in-house engine never imports Pinocchio or MuJoCo.
"""

from __future__ import annotations

from importlib import import_module
from pathlib import Path
from typing import Any, Callable

from dualmech.core.status import Status, is_status
from dualmech.core.table import ColumnTable
from dualmech.models.inputs import CaseError, show
from dualmech.models.kinds import KIND_HOMES, SLIDER_CRANK, kind_of

#: engine -> ``[mechanism] kind`` -> "module:function".
ENGINES: dict[str, dict[str, str]] = {
    "dualmech": {kind: home.solver for kind, home in KIND_HOMES.items()},  # each kind's own (models/kinds.py)
    "pinocchio": {SLIDER_CRANK: "dualmech.validation.judges.pinocchio_slider_crank.engine:solve_case",
                  "rssr": "dualmech.validation.judges.presets.engines:solve_pinocchio_rssr",
                  "rccc": "dualmech.validation.judges.presets.engines:solve_pinocchio_rccc",
                  "loop": "dualmech.validation.judges.pinocchio_loop.table:solve_table"},
    "mujoco": {SLIDER_CRANK: "dualmech.validation.judges.mujoco_slider_crank.engine:solve_case",
               "rssr": "dualmech.validation.judges.presets.engines:solve_mujoco_rssr",
               "rccc": "dualmech.validation.judges.presets.engines:solve_mujoco_rccc",
               "loop": "dualmech.validation.judges.mujoco_loop.table:solve_table"},
    "mujoco-sim": {SLIDER_CRANK: "dualmech.validation.judges.mujoco_slider_crank.sim:solve_case",
                   "rssr": "dualmech.validation.judges.presets.engines:simulate_rssr",
                   "rccc": "dualmech.validation.judges.presets.engines:simulate_rccc",
                   "loop": "dualmech.validation.judges.mujoco_loop.table:solve_sim_table"},
    "exudyn": {SLIDER_CRANK: "dualmech.validation.judges.presets.slider_crank:solve_case",
               "rssr": "dualmech.validation.judges.presets.engines:solve_exudyn_rssr",
               "rccc": "dualmech.validation.judges.presets.engines:solve_exudyn_rccc",
               "loop": "dualmech.validation.judges.exudyn_loop.table:solve_table"},
}
#: Registered engines that a matrix runs only where it names them (``engines = [...]``, ``--engines``): the
#: Exudyn judge (issue 33), slow: three step sizes, a run-in, shorter steps where its own error estimate asks
#: (2 to 33 s a table, where the other judges take a fraction of a second).
OPT_IN: tuple[str, ...] = ("exudyn",)
#: The engines of a matrix that names none: every registered engine but :data:`OPT_IN`.
DEFAULT_ENGINES: tuple[str, ...] = tuple(e for e in ENGINES if e not in OPT_IN)


def engines_for(kind: str) -> tuple[str, ...]:
    """The engines of :data:`DEFAULT_ENGINES` registered for cases of ``kind``, in :data:`ENGINES` order."""
    return tuple(e for e in DEFAULT_ENGINES if kind in ENGINES[e])


#: The in-house engine's streamed solve, by kind: ``(is_long, stream)``, each ``"module:function"``:
#: ``solve -o OUT`` of a case where ``is_long(case)`` writes it chunk by chunk with ``stream(case, OUT,
#: progress)``, which returns the summary (:mod:`dualmech.validation.solve_output`).
STREAMED: dict[str, tuple[str, str]] = {
    SLIDER_CRANK: ("dualmech.validation.solve_output:is_long",
                   "dualmech.validation.solve_output:stream_solve"),
    "loop": ("dualmech.validation.solve_output:is_long_loop",
             "dualmech.validation.solve_output:stream_loop_solve")}
#: Why the simulation (or the Exudyn judge) does not solve a case of a kind it is registered for (its
#: one-line refusal).
SIM_REFUSALS: dict[str, str] = {
    "rssr": "; its input is servo-driven through every angle of the case: the case must give "
            "loads.output_torque and its loop close at all of them",
    "loop": "; the simulation cuts the loop inside the ground, whose half hangs from the last joint: drive "
            "another joint",
    "loop-closes": "; its drive is servo-driven through every position of the table: its loop must close "
                   "(ok) at all of them",
    "exudyn": "; the Exudyn judge drives the first joint only (it prescribes the first link's own "
              "coordinate, against the ground; the other judges drive any joint)",
}

#: Engines run in a thread of the running process beside a pool's workers (under their registered function
#: only: a test's fake of the same name runs in a worker), each on slider-crank cases of at most so many crank
#: positions: a thread cannot be ended, so an interrupted run waits for the task it is running (at most
#: ~0.2 s under these bounds); a larger case runs in a worker, which can be ended.  Both are engines whose
#: library costs a process more to load than the thesis matrix's tasks cost to run, so it is loaded once,
#: here, instead of in every worker:
#:
#: * the in-house kernel: compiled, releases the GIL, ~2 ms a thesis case (10^5 positions: ~0.1 s); loading
#:   numba and the cached kernel costs a process ~0.85 s of CPU;
#: * Pinocchio: ~30 ms a thesis case (~85 us a position: 2000 positions ~0.2 s); importing it costs a process
#:   0.23 s of CPU.
IN_PROCESS_ENGINES: dict[str, tuple[str, int]] = {
    "dualmech": (ENGINES["dualmech"][SLIDER_CRANK], 100_000),
    "pinocchio": (ENGINES["pinocchio"][SLIDER_CRANK], 2_000),
}


def runs_here(engine: str, spec: str, raw: dict) -> bool:
    """Whether the task of ``engine`` under ``spec`` on the case table ``raw`` runs in the running process
    beside a pool (:data:`IN_PROCESS_ENGINES`; a table that does not parse runs in a worker, which stores
    its error)."""
    from dualmech.models.case import case_from_dict

    here, most = IN_PROCESS_ENGINES.get(engine, (None, 0))
    if here != spec or kind_of(raw) != SLIDER_CRANK:
        return False
    try:
        return case_from_dict(raw).motion.angles_deg.size <= most
    except ValueError:
        return False


def solves(engine: str, kind: str, case: Any) -> bool:
    """Whether ``engine`` solves ``case`` of ``kind``: the kind is registered under it, and for the
    simulation of a linkage (a servo drives the input through the case's angles) the case gives the output
    torque (an RCCC case always does: its drive torque is always solved; an RSSR case in output-torque mode)
    and its loop closes (``ok``) at every one of those angles: a trajectory cannot pass where it does not
    (the in-house status words decide that, as they decide which rows every judge is compared on).  A loop
    table's simulation needs the drive at a joint other than the last
    (:mod:`~dualmech.validation.judges.mujoco_loop.sim_mjcf`) and, as the RSSR's, its loop closed (``ok``)
    at every drive position: started at the edge of a gap, its servo took 20 deg of drive to settle (a
    user's RRCRC assembling from 125 deg).  The Exudyn judge drives the first joint only (every preset's
    table drives its crank, joint 1).  The slider
    crank's simulation decides for itself (its table marks what it cannot follow)."""
    if kind not in ENGINES.get(engine, {}):
        return False
    if engine == "exudyn":  # a preset's table (RSSR, RCCC, slider crank) drives its crank, joint 1
        return kind != "loop" or case.drive.joint == 0
    if engine != "mujoco-sim" or kind == SLIDER_CRANK:
        return True
    if kind == "loop" and case.drive.joint == len(case.joints) - 1:
        return False
    given = kind in ("rccc", "loop") or getattr(case, "mode", "") == "output"
    try:
        return given and bool(is_status(run_engine("dualmech", case).status, Status.OK).all())
    except ValueError:  # the in-house engine finds no start: the loop does not close there either
        return False


def spec_of(engine: str, kind: str) -> str:
    """The ``"module:function"`` of ``engine`` for ``kind``; a one-line CaseError naming the engines that
    solve that kind otherwise."""
    if engine not in ENGINES:
        raise CaseError(f"engine: expected one of {', '.join(ENGINES)}, got {show(engine)}")
    if kind not in ENGINES[engine]:
        valid = [e for e in ENGINES if kind in ENGINES[e]]
        raise CaseError(f"engine: {show(engine)} does not solve a {kind} case (valid: {', '.join(valid)})")
    return ENGINES[engine][kind]


def get_engine(name: str, kind: str = SLIDER_CRANK) -> Callable[[Any], ColumnTable]:
    """The solving function of engine ``name`` for cases of ``kind``."""
    module, func = spec_of(name, kind).split(":")
    return getattr(import_module(module), func)


def run_engine(name: str, case: Any) -> ColumnTable:
    """The checked ``case`` (a slider-crank :class:`~dualmech.models.case.Case`, an RSSR, RCCC or loop
    table case) solved by engine ``name``, by its kind."""
    return get_engine(name, kind_of(case))(case)


def solve_checked(engine: str, case: Any) -> ColumnTable:
    """``case`` (a checked case of any kind) solved by ``engine``: ``"dualmech"`` (the in-house dual-number
    method), ``"pinocchio"``, ``"mujoco"`` (the rigid judges; a loop table's are generated from it) or
    ``"mujoco-sim"`` (MuJoCo's simulation; of an RCCC case, an RSSR case in output-torque mode or a loop
    table driven at another joint than its last, its rows are the simulated input states) or ``"exudyn"``
    (the Exudyn judge of the case's joint table; a loop table driven at its first joint).

    Raises
    ------
    CaseError
        One line, for an engine that is not one or does not solve the case (naming those that do).
    """
    if engine not in ENGINES:
        raise CaseError(f"engine: expected one of {', '.join(ENGINES)}, got {show(engine)}")
    kind = kind_of(case)
    if not solves(engine, kind, case):
        valid = [e for e in ENGINES if solves(e, kind, case)]
        why = SIM_REFUSALS[_refusal(engine, kind, case)] if kind in ENGINES[engine] else ""
        raise CaseError(f"engine: {show(engine)} does not solve this {kind.upper()} case (valid: "
                        f"{', '.join(valid)}{why})")
    return run_engine(engine, case)


def refusal(engine: str, case: Any) -> str | None:
    """Why ``engine`` does not solve the checked ``case`` (:func:`solves`), one line, e.g. "the Exudyn judge
    drives the first joint only (...)"; ``None`` where it does."""
    kind = kind_of(case)
    if solves(engine, kind, case):
        return None
    if kind not in ENGINES.get(engine, {}):
        return f"{engine} does not solve a {kind} case"
    return SIM_REFUSALS[_refusal(engine, kind, case)].removeprefix("; ")


def _refusal(engine: str, kind: str, case: Any) -> str:
    """The key of :data:`SIM_REFUSALS` saying why ``engine`` (the simulation, or Exudyn) does not solve
    ``case`` of a kind registered under it (:func:`solves`)."""
    if kind != "loop":
        return "rssr"
    if engine == "exudyn":
        return "exudyn"
    return "loop" if case.drive.joint == len(case.joints) - 1 else "loop-closes"


def solve_linkage(source: str | Path | dict, engine: str = "dualmech") -> ColumnTable:
    """:func:`solve_checked` of a linkage case (a TOML file, a bundled case ``"rssr"`` / ``"rccc"`` /
    ``"rscr"`` ... or a parsed dict; a one-line CaseError for any invalid input)."""
    from dualmech.models.linkages import linkage_case

    return solve_checked(engine, linkage_case(source))
