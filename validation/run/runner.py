"""Run a validation matrix: every case on every engine, in parallel, stored as it finishes.

A run directory holds::

    run.json              the expanded matrix, machine, versions, timings
    cases/<case id>.json  one file per case: every engine's table (or its error)

Each case file is written atomically (a temporary file, fsync, then :func:`os.replace`)
each time one of its engines is done, so an interrupted run loses no finished result,
and ``resume=True`` runs only the (case, engine) pairs that are missing, failed,
or whose fingerprint (:func:`~dualmech.validation.provenance.result_fingerprint`:
case content, engine, its libraries' versions, the dualmech source) has changed.
An engine that raised is stored as one line (``"<Type>: <message>"``); its full
traceback goes to ``run.log`` in the run directory.

Work is spread over processes (:class:`concurrent.futures.ProcessPoolExecutor`,
``jobs`` of them, default all cores) or, with ``scheduler``, over a Dask
distributed cluster; one task is one (case, engine).  Results always come back
to this process, which alone writes the files, so cluster workers need no shared
file system.
"""

from __future__ import annotations

import json
import os
import platform
import time
import traceback
from dataclasses import dataclass
from datetime import datetime, timezone
from importlib import import_module
from pathlib import Path
from typing import Any

from dualmech.core.table import ColumnTable
from dualmech.models.kinds import case_from_data, kind_of
from dualmech.validation import rundir
from dualmech.validation.durable import json_text
from dualmech.validation.engines import ENGINES, runs_here
from dualmech.validation.matrix import Matrix, matrix_from_dict
from dualmech.validation.progress import ProgressCallback
from dualmech.validation.provenance import (
    KEY_LIBRARIES,
    case_fingerprint,
    key_versions,
    machine,
    result_fingerprint,
    versions,
)
from dualmech.validation.run.executors import check_address, execute
from dualmech.validation.rundir import CASE_FORMAT, RUN_FORMAT, locked
from dualmech.validation.rundir.tables import entry_result, table_to_dict

CASES_DIR = "cases"
RUN_FILE = "run.json"
LOG_FILE = "run.log"

#: Rough cost of one case per engine (thesis cases, CPU s x 10): tasks go to the workers longest first, so
#: that a run does not end with one worker on a long task and the other idle (an engine not listed: 1).
ENGINE_COST = {"exudyn": 120.0, "mujoco-sim": 5.0, "mujoco": 1.0, "pinocchio": 0.3, "dualmech": 0.3}

#: What a run takes as its engines: engine -> ``"module:function"`` for cases of every kind (a test's fake),
#: or engine -> ``[mechanism] kind`` -> ``"module:function"`` (:data:`~dualmech.validation.engines.ENGINES`).
Registry = dict[str, Any]



@dataclass(frozen=True)
class RunOutcome:
    """What :func:`run_matrix` did.

    Attributes
    ----------
    results : dict
        Case id -> engine -> its result table (a slider crank's
        :class:`~dualmech.core.table.ResultTable`), or the error text when it raised.
    ran, skipped : int
        (case, engine) tasks run now, and taken from earlier files (``resume``).
    seconds : float
        Wall time of this invocation.
    """

    results: dict[str, dict[str, ColumnTable | str]]
    ran: int
    skipped: int
    seconds: float


# ----------------------------------------------------------------------------- files

class CaseFileText:
    """The text of one case file, kept up to date as its engines finish.

    Each entry is encoded once (a case file is rewritten as each of its engines finishes);
    the text is what ``json.dumps`` gives for ``{"format", "id", "fingerprint", "raw", "engines"}``,
    the engines in ``engines`` order.
    """

    def __init__(self, case_id: str, raw: dict, engines: tuple[str, ...], kept: dict[str, dict]) -> None:
        head = {"format": CASE_FORMAT, "id": case_id, "fingerprint": case_fingerprint(raw), "raw": raw}
        self._head = json_text(head)[:-1]  # without its closing brace
        self._engines = tuple(engines)
        self.entries: dict[str, dict] = dict(kept)
        self._texts = {e: json_text(v) for e, v in kept.items()}

    def add(self, entry: dict) -> str:
        """Take ``entry`` (its engine's, replacing any earlier one); return the file's text.  Encoded before
        it is taken: a Ctrl-C during the encoding leaves the entries and their texts in step."""
        text = json_text(entry)
        self._texts[entry["engine"]] = text
        self.entries[entry["engine"]] = entry
        body = ", ".join(f"{json.dumps(k)}: {self._texts[k]}" for k in self._engines if k in self.entries)
        return f'{self._head}, "engines": {{{body}}}}}'


def case_name(case_id: str) -> str:
    """The case file of one case, relative to its run folder."""
    return f"{CASES_DIR}/{case_id}.json"


def case_file(outdir: Path, case_id: str) -> Path:
    """Where the results of one case are stored."""
    return Path(outdir) / case_name(case_id)


def read_case_file(outdir: Path, case_id: str) -> dict | None:
    """The stored case file of ``case_id`` in the run folder ``outdir``, checked
    (:func:`~dualmech.validation.rundir.check_case_file`); ``None`` if absent or of an older format.

    A file that is not valid JSON, breaks the format, is a link or a special file is a one-line
    :class:`~dualmech.validation.rundir.RunDirError`.
    """
    data = rundir.read_json(outdir, case_name(case_id))
    if not isinstance(data, dict) or data.get("format") != CASE_FORMAT:
        return None
    return rundir.check_case_file(data, case_file(outdir, case_id), case_id)


def load_entries(outdir: Path, matrix: Matrix) -> dict[str, dict[str, dict]]:
    """Stored entries (see :func:`run_task`) of ``matrix``'s cases and engines in ``outdir``.

    Cases without a file, or whose file was made from a different case definition, are left out.
    """
    entries = {}
    for mc in matrix.cases:
        data = read_case_file(outdir, mc.id)
        if data is None or data.get("fingerprint") != case_fingerprint(mc.raw):
            continue
        per = {e: v for e, v in data["engines"].items() if e in matrix.engines}
        if per:
            entries[mc.id] = per
    return entries


def load_results(outdir: Path, matrix: Matrix) -> dict[str, dict[str, ColumnTable | str]]:
    """Every stored result of ``matrix`` in ``outdir``: case id -> engine -> table or error text."""
    kinds = {mc.id: kind_of(mc.raw) for mc in matrix.cases}
    return {cid: {e: entry_result(v, kinds[cid]) for e, v in per.items()}
            for cid, per in load_entries(outdir, matrix).items()}


def timings(entries: dict[str, dict[str, dict]]) -> dict[str, dict[str, float]]:
    """Case id -> engine -> seconds, from stored entries."""
    return {cid: {e: float(v.get("seconds", 0.0)) for e, v in per.items()} for cid, per in entries.items()}


def load_run(outdir: Path) -> tuple[Matrix, dict]:
    """The matrix and metadata of a stored run directory (``run.json`` checked against
    :data:`~dualmech.validation.rundir.RUN_SCHEMA`, its matrix's names and engines too)."""
    path = Path(outdir) / RUN_FILE
    run = rundir.read_json(outdir, RUN_FILE, rundir.RUN_SCHEMA)
    if run is None:
        raise ValueError(f"run directory: {outdir} has no {RUN_FILE} (run `dualmech validate -o {outdir}` "
                         "first)")
    try:
        return matrix_from_dict(run["matrix"]), run
    except ValueError as err:
        raise rundir.RunDirError(f"{path}: matrix: {err}") from None


# ----------------------------------------------------------------------------- environment

def default_jobs() -> int:
    """All cores this process may use."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


# ----------------------------------------------------------------------------- work

def run_task(case_id: str, case_raw: dict, engine: str, spec: str) -> dict:
    """Solve one case with one engine (runs in a worker); never raises.

    Returns a JSON-ready entry: ``engine``, ``spec``, ``seconds``, ``host``, the
    ``fingerprint`` and ``versions`` of what produced it (:mod:`~dualmech.validation.provenance`),
    and either ``table`` (:func:`table_to_dict`) or ``error`` (one line, ``"<Type>: <message>"``)
    with ``traceback`` (the full text).
    """
    start = time.perf_counter()
    entry: dict[str, Any] = {"case": case_id, "engine": engine, "spec": spec, "host": platform.node(),
                             "fingerprint": result_fingerprint(case_raw, engine, spec),
                             "versions": versions(KEY_LIBRARIES)}
    try:
        module, func = spec.split(":")
        table = getattr(import_module(module), func)(case_from_data(case_raw))
        if not isinstance(table, ColumnTable):
            raise TypeError(f"{spec} returned {type(table).__name__}, not a result table")
        entry.update(table=table_to_dict(table), error=None)
    except Exception as err:  # an engine's failure is a result to report, not a crash of the run
        entry.update(table=None, error=error_line(err), traceback=traceback.format_exc(limit=12))
    entry["seconds"] = time.perf_counter() - start
    return entry


def error_line(err: BaseException, width: int = 300) -> str:
    """``"<Type>: <first line of the message>"``, at most ``width`` characters (array dumps cut)."""
    lines = str(err).strip().splitlines()
    line = f"{type(err).__name__}: {lines[0].strip() if lines else ''}".rstrip(": ")
    return line if len(line) <= width else line[: width - 1] + "…"


def _log_failure(outdir: Path, entry: dict) -> None:
    """Append a failed entry's traceback to the run's log file."""
    stamp = datetime.now(timezone.utc).isoformat(timespec="seconds")
    head = f"--- {stamp} {entry['case']} / {entry['engine']}: {entry['error']}\n"
    rundir.append_text(outdir, LOG_FILE, head + entry.get("traceback", "") + "\n")


def task_spec(registry: Registry, engine: str, raw: dict) -> str:
    """The ``"module:function"`` that runs ``engine`` on the case table ``raw``: the engine's own for every
    kind, or the one registered for the case's kind (:func:`~dualmech.models.kinds.kind_of`); a one-line
    ValueError for a kind the engine does not solve."""
    entry = registry[engine]
    if isinstance(entry, str):
        return entry
    kind = kind_of(raw)
    if kind not in entry:
        raise ValueError(f"engines: {engine!r} does not solve a {kind} case (it solves: {', '.join(entry)})")
    return entry[kind]


def _plan(matrix: Matrix, outdir: Path, resume: bool, registry: Registry
          ) -> tuple[list[tuple[str, str]], dict[str, dict]]:
    """Tasks to run, and the entries kept from earlier files, per case."""
    tasks, kept = [], {}
    for mc in matrix.cases:
        old = read_case_file(outdir, mc.id) if resume else None
        entries = {}
        if old is not None:
            current = {e: result_fingerprint(mc.raw, e, task_spec(registry, e, mc.raw))
                       for e in matrix.engines_of(mc)}
            entries = {e: v for e, v in old["engines"].items()
                       if e in current and not v.get("error") and v.get("fingerprint") == current[e]}
        kept[mc.id] = entries
        tasks += [(mc.id, e) for e in matrix.engines_of(mc) if e not in entries]
    return tasks, kept


def run_matrix(
    matrix: Matrix,
    outdir: str | Path,
    *,
    jobs: int | None = None,
    resume: bool = False,
    scheduler: str | None = None,
    progress: ProgressCallback | None = None,
    registry: Registry | None = None,
) -> RunOutcome:
    """Run every case of ``matrix`` on every engine and store the results in ``outdir``.

    Parameters
    ----------
    matrix : Matrix
    outdir : path
        Run directory (created).
    jobs : int, optional
        Worker processes; default all cores. 1 runs in this process.
    resume : bool
        Keep stored results that are still valid; run only the rest.
    scheduler : str, optional
        Address of a Dask distributed scheduler (``tcp://host:port``); replaces ``jobs``.
    progress : callable, optional
        ``progress(done, total, label)`` after each finished (case, engine).
    registry : dict, optional
        Engine name -> ``"module:function"`` (every kind) or kind -> ``"module:function"`` (:data:`Registry`);
        default :data:`~dualmech.validation.engines.ENGINES`.
    """
    start = time.perf_counter()
    registry = dict(ENGINES if registry is None else registry)
    jobs = default_jobs() if jobs is None else jobs
    if jobs < 1:
        raise ValueError(f"jobs: expected a number of processes >= 1, got {jobs}")
    if scheduler is not None:
        scheduler = check_address(scheduler)
    missing = [e for e in matrix.engines if e not in registry]
    if missing:
        raise ValueError(f"engines: {missing[0]!r} is not registered (valid: {', '.join(registry)})")
    for mc in matrix.cases:  # before the folder is touched: an engine that cannot solve a case's kind
        for e in matrix.engines_of(mc):
            task_spec(registry, e, mc.raw)
    with locked(outdir) as outdir:
        return _run_locked(matrix, outdir, jobs, resume, scheduler, progress, registry, start)


def _run_info(matrix: Matrix, jobs: int, resume: bool, scheduler: str | None,
              registry: Registry) -> dict:
    """What ``run.json`` says of a run when it starts (its end adds seconds, ran and skipped)."""
    return {
        "format": RUN_FORMAT,
        "matrix": matrix.to_dict(),
        "started": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "jobs": 1 if scheduler else jobs,
        "scheduler": scheduler,
        "machine": machine(),
        "versions": versions(),
        "registry": {e: " ".join(sorted({task_spec(registry, e, mc.raw) for mc in matrix.cases
                                         if e in matrix.engines_of(mc)})) for e in matrix.engines},
        "resumed": resume,
    }


def _run_locked(matrix: Matrix, outdir: Path, jobs: int, resume: bool, scheduler: str | None,
                progress: ProgressCallback | None, registry: Registry, start: float) -> RunOutcome:
    """:func:`run_matrix` in its locked output folder."""
    rundir.make_folder(outdir, CASES_DIR)
    tasks, kept = _plan(matrix, outdir, resume, registry)
    raws = {mc.id: mc.raw for mc in matrix.cases}
    info = _run_info(matrix, jobs, resume, scheduler, registry)
    rundir.write_json(outdir, RUN_FILE, info)

    files = {cid: CaseFileText(cid, raws[cid], matrix.engines, kept[cid]) for cid in raws}
    calls = [(cid, raws[cid], e, task_spec(registry, e, raws[cid])) for cid, e in tasks]
    calls.sort(key=lambda call: -ENGINE_COST.get(call[2], 1.0))  # the longest first (stable)

    listed: set[str] = set()  # case files already in the manifest (listing one rereads and checks it)

    def store(entry: dict) -> None:
        """Write the entry's case file at once (a case whose other engines are still running is partial)."""
        cid = entry["case"]
        if entry.get("error"):
            _log_failure(outdir, entry)
        rundir.write_file(outdir, case_name(cid), files[cid].add(entry), record=cid not in listed)
        listed.add(cid)

    leftovers: list[dict] = []
    storing: list[dict] = []  # the entry being stored, where a Ctrl-C may land
    stream = execute(run_task, calls, jobs, scheduler, leftovers, here=lambda c: runs_here(c[2], c[3], c[1]),
                     label=lambda c: f"{c[0]} {c[2]}")
    try:
        for n_done, entry in enumerate(stream, start=1):
            storing.append(entry)
            store(entry)
            storing.clear()
            if progress is not None:
                progress(n_done, len(calls), f"{entry['case']} {entry['engine']}")
    finally:  # interrupted or not: every task that finished is stored, the one being stored again
        stream.close()
        for entry in storing + leftovers:
            store(entry)

    seconds = time.perf_counter() - start
    info.update(seconds=seconds, ran=len(calls), skipped=sum(len(v) for v in kept.values()))
    rundir.write_json(outdir, RUN_FILE, info)
    results = {cid: {e: entry_result(f.entries[e], kind_of(raws[cid])) for e in matrix.engines
                     if e in f.entries}
               for cid, f in files.items() if f.entries}  # as load_results reads them: the matrix's order
    return RunOutcome(results, len(calls), info["skipped"], seconds)


def run_versions(outdir: Path) -> dict[str, str]:
    """The key library versions recorded in the run directory's ``run.json``."""
    return key_versions(load_run(outdir)[1])
