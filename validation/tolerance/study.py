"""A tolerance study end to end, judged: the Monte Carlo chunks run, sensitivities, spot checks, summary.

The study's parts live in :mod:`dualmech.models.tolerance` (sampling, batched solving of a chunk,
what a stored chunk holds: :mod:`~dualmech.models.tolerance.study`; sensitivities; statistics).
This module runs them in the study's folder (:mod:`~dualmech.validation.rundir`'s rules: locked, every
file atomic; a chunk fsynced when stored, so that a resume can rely on it, and recomputed if it is
damaged or of another study): the chunks in this process (:data:`IN_FLIGHT` at once, so that the kernel's
threads solve one chunk while this process reduces, stores and writes another), in a process pool
(``jobs``) or on a Dask cluster (``scheduler``) through :func:`dualmech.validation.run.executors.execute`,
each stored as it finishes and streamed into the samples files in design order; then the exact
sensitivities and their check, the judges' spot checks (:mod:`~dualmech.validation.tolerance.spot_checks`)
and ``DIR/summary.json`` with the library versions.  The report's figures, which need only the samples
and the statistics, may be drawn meanwhile (:class:`~dualmech.validation.tolerance.report.FigureDrawing`).
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import time
import zipfile
import zlib
from collections import deque
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import TYPE_CHECKING, Iterator

import numpy as np

from dualmech.models.kinds import kind_of
from dualmech.models.tolerance.designs import design_name
from dualmech.models.tolerance.differences import check_sensitivities
from dualmech.models.tolerance.plan import in_house, plan_of, record_of
from dualmech.models.tolerance.sampling import judge_picks, n_chunks
from dualmech.models.tolerance.study import (
    METHODS,
    SampleStream,
    StudyInput,
    check_size,
    chunk_arrays,
    chunk_name,
    chunk_part,
    finite_json,
    parquet_available,
    solve_chunk,
)
from dualmech.models.tolerance.summary import summarize
from dualmech.validation import rundir
from dualmech.validation.durable import json_text
from dualmech.validation.provenance import versions
from dualmech.validation.run.executors import execute
from dualmech.validation.tolerance.report import FigureDrawing
from dualmech.validation.tolerance.spot_checks import candidates, run_spot_checks

if TYPE_CHECKING:
    from dualmech.validation.progress import ProgressCallback, ProgressTasks

#: Chunks solved at once in this process (``jobs = 1``): the kernel releases the GIL, so while its
#: threads work on one chunk's positions this thread reduces, stores and writes another, and the
#: kernel's threads always have a next block queued.  Results are the same bits for any value.
IN_FLIGHT = 2


#: ``study.json``: the study a folder holds (:meth:`~dualmech.models.tolerance.study.StudyInput.identity`).
STUDY_FILE = "study.json"
#: What a damaged chunk file raises when read (a truncated zip, a cut array, a bad header).
DAMAGED_CHUNK = (zipfile.BadZipFile, zlib.error, EOFError, ValueError, KeyError, OSError)


def store_chunk(outdir: Path, study: StudyInput, entry: dict) -> None:
    """Store one finished chunk (a :func:`solve_chunk` result) in ``DIR/chunks/`` atomically and durably
    (:func:`~dualmech.validation.rundir.writing`: fsynced, renamed; a resume relies on it)."""
    with rundir.writing(outdir, chunk_name(entry["index"]), record=False) as (_, fd):
        with os.fdopen(os.dup(fd), "wb") as fh:
            np.savez(fh, **chunk_arrays(study, entry))


def load_chunk(outdir: Path, study: StudyInput, index: int
               ) -> tuple[np.ndarray, dict[str, np.ndarray]] | None:
    """Stored chunk ``index`` of ``study`` (key values, outputs), or ``None`` if it is absent, damaged or of
    another study (:func:`~dualmech.models.tolerance.study.chunk_part`): it is then solved again.  A link
    or special file in its place is a :class:`~dualmech.validation.rundir.RunDirError`."""
    data = rundir.read_bytes(outdir, chunk_name(index))
    if data is None:
        return None
    try:
        with np.load(io.BytesIO(data), allow_pickle=False) as stored:
            return chunk_part(study, index, {k: stored[k] for k in stored.files})
    except DAMAGED_CHUNK:
        return None


def prepare(outdir: Path, study: StudyInput) -> list[int]:
    """Open the study folder (locked by the caller): check or write ``study.json``; the chunks still to run
    (absent, damaged or foreign ones)."""
    check_size(study)
    identity = rundir.read_json(outdir, STUDY_FILE)
    wanted = json.loads(json_text(study.identity()))
    if identity is not None and identity != wanted:
        raise ValueError(f"output: {str(outdir)!r} holds another study (case, SPEC, n or seed differ); "
                         "use an empty folder")
    rundir.make_folder(outdir, "chunks")
    if identity is None:
        if any(rundir.inside(outdir, "chunks", folder=True).iterdir()):
            raise ValueError(f"output: {str(outdir)!r} holds chunks but no {STUDY_FILE}; use an empty folder")
        rundir.write_json(outdir, STUDY_FILE, wanted, pretty=True)
    return [c for c in range(n_chunks(study.n)) if load_chunk(outdir, study, c) is None]


def in_process(calls: list[tuple], leftovers: list[dict]) -> Iterator[dict]:
    """:func:`solve_chunk` on every call in this process, :data:`IN_FLIGHT` at once; yields in call order.

    The first chunk runs alone (the kernel's thread pool and compiled code are set up once).  Chunks
    that finished but were not yielded when the generator is closed early are appended to ``leftovers``.
    """
    if not calls:
        return
    yield solve_chunk(*calls[0])
    with ThreadPoolExecutor(IN_FLIGHT, thread_name_prefix="dualmech-chunk") as pool:
        queued = deque(pool.submit(solve_chunk, *call) for call in calls[1:1 + IN_FLIGHT])
        later = iter(calls[1 + IN_FLIGHT:])
        try:
            while queued:
                entry = queued.popleft().result()
                call = next(later, None)
                if call is not None:
                    queued.append(pool.submit(solve_chunk, *call))
                yield entry
        finally:
            for fut in queued:
                fut.cancel()
            leftovers.extend(f.result() for f in queued if not f.cancelled() and f.exception() is None)


def run_chunks(outdir: Path, study: StudyInput, todo: list[int], jobs: int, scheduler: str | None,
               stream: SampleStream | None = None, progress: ProgressCallback | None = None) -> int:
    """Solve the chunks ``todo``, storing each as it finishes (and handing it to ``stream``); how many ran.
    ``progress(done, len(todo), "chunk <index>")`` after each."""
    calls = [(study.case.raw, study.spec.to_dict(), study.n, study.seed, c) for c in todo]
    leftovers: list[dict] = []
    if jobs <= 1 and not scheduler:
        entries = in_process(calls, leftovers)
    else:
        entries = execute(solve_chunk, calls, jobs, scheduler, leftovers, label=lambda c: f"chunk {c[-1]}")
    done = 0
    try:
        for entry in entries:
            store_chunk(outdir, study, entry)
            if stream is not None:
                stream.add(entry["index"], entry["x"], entry["outputs"])
            done += 1
            if progress is not None:
                progress(done, len(todo), f"chunk {entry['index']}")
    finally:
        entries.close()
        for entry in leftovers:
            store_chunk(outdir, study, entry)
    return done


def monte_carlo(outdir: Path, study: StudyInput, jobs: int, scheduler: str | None,
                figures: FigureDrawing | None = None, tasks: ProgressTasks | None = None,
                ) -> tuple[dict, np.ndarray, dict[str, np.ndarray]]:
    """Run (or resume) the Monte Carlo part: (timing facts, key values ``(n, k)``, outputs ``(n,)``).

    ``figures`` is warmed once the folder is accepted (its worker starts while the chunks are solved);
    ``tasks``: the chunks' progress is shown as its task ``"tolerance: Monte Carlo"``.
    """
    todo = prepare(outdir, study)
    if figures is not None:
        figures.warm()
    start = time.perf_counter()
    files = ["samples.csv"] + (["samples.parquet"] if parquet_available() else [])
    with contextlib.ExitStack() as temporary:  # renamed onto their names only if the study ends
        paths = [temporary.enter_context(rundir.writing(outdir, f))[0] for f in files]

        def load(index: int) -> tuple[np.ndarray, dict[str, np.ndarray]]:
            part = load_chunk(outdir, study, index)
            if part is None:
                raise rundir.RunDirError(f"{outdir / chunk_name(index)}: changed or removed while the study "
                                         "ran; run the study again")
            return part

        stream = SampleStream(study, set(range(n_chunks(study.n))) - set(todo), paths[0],
                              paths[1] if len(paths) > 1 else None, load)
        try:
            with _task(tasks, "tolerance: Monte Carlo", "chunks") as bar:
                ran = run_chunks(outdir, study, todo, jobs, scheduler, stream, bar)
            x, samples = stream.finish()
        except BaseException:
            stream.abort()
            raise
    solve_s = time.perf_counter() - start
    return ({"chunks_run": ran, "chunks_resumed": n_chunks(study.n) - len(todo), "solve_s": solve_s,
             "files": files}, x, samples)


def _task(tasks: ProgressTasks | None, description: str, unit: str
          ) -> contextlib.AbstractContextManager[ProgressCallback | None]:
    """``tasks(description, unit=unit)``, or nothing to report to."""
    return contextlib.nullcontext() if tasks is None else tasks(description, unit=unit)


def _check_inputs(study: StudyInput, method: str, judge_samples: int) -> None:
    if method not in METHODS:
        raise ValueError(f"method: expected one of {', '.join(METHODS)}, got {method!r}")
    if judge_samples < 0:
        raise ValueError(f"judge-samples: expected 0 or more designs, got {judge_samples!r}")


def run_study(study: StudyInput, method: str, outdir: Path, jobs: int = 1, scheduler: str | None = None,
              judge_samples: int = 5, figures: FigureDrawing | None = None,
              tasks: ProgressTasks | None = None,
              ) -> tuple[dict, np.ndarray | None, dict[str, np.ndarray] | None]:
    """The whole study (module docstring): returns the summary (also in ``DIR/summary.json``) and the samples.

    ``outdir`` follows the run folder's rules (:mod:`~dualmech.validation.rundir`): new, empty or
    dualmech's, locked while the study runs, every file written atomically.

    Sampled key values ``(n, k)`` and outputs are ``None`` for ``method = "linear"``.  ``figures``: started
    (:meth:`~dualmech.validation.tolerance.report.FigureDrawing.start`) once the statistics are known,
    before the spot checks.  ``tasks``: the progress of the Monte Carlo chunks and of the spot checks is
    shown as two of its tasks (:data:`~dualmech.validation.run.runner.ProgressTasks`).
    """
    _check_inputs(study, method, judge_samples)
    with rundir.locked(outdir) as outdir:
        return _run_locked(study, method, outdir, jobs, scheduler, judge_samples, figures, tasks)


def _run_locked(study: StudyInput, method: str, outdir: Path, jobs: int, scheduler: str | None,
                judge_samples: int, figures: FigureDrawing | None, tasks: ProgressTasks | None,
                ) -> tuple[dict, np.ndarray | None, dict[str, np.ndarray] | None]:
    """:func:`run_study` in its locked folder."""
    timing: dict = {}
    x = samples = None
    if method != "linear":
        timing, x, samples = monte_carlo(outdir, study, jobs, scheduler, figures, tasks)
    start = time.perf_counter()
    plan, record = plan_of(study.case), record_of(study.case)
    table = in_house(record)(record)
    solved = plan.table_outputs([table], record)
    nominal = {name: float(solved[name][0]) for name in plan.outputs(record)}
    sens = plan.sensitivities(study.case, study.spec, table) if method != "mc" else None
    check = check_sensitivities(study.case, study.spec, sens).to_dict() if sens is not None else None
    timing["sensitivity_s"] = time.perf_counter() - start
    stats = summarize(study.spec, nominal, x, samples, sens, plan.groups(record))
    units = plan.units(study.case)
    if figures is not None:
        figures.start(finite_json({**stats, "keys": list(study.spec.keys), "units": units}), samples)
    if samples is not None:
        picks = judge_picks(judge_samples, study.seed, candidates(samples["status"]))
        designs = [plan.design(study.case, study.spec, x[i], design_name(int(i))) for i in picks]
    else:
        designs = [record] if judge_samples else []
    start = time.perf_counter()
    with _task(tasks, "tolerance: judges' spot checks", "designs") as bar:
        spots = run_spot_checks(designs, progress=bar)
    timing["judges_s"] = time.perf_counter() - start
    summary = {"n": study.n if samples is not None else 0, "seed": study.seed, "method": method,
               "case": study.case.name, "kind": kind_of(record), "mode": plan.mode(record),
               "keys": list(study.spec.keys), "units": units, "sensitivity_method": plan.method,
               "nominal_values": dict(zip(study.spec.keys,
                                          plan.nominal_values(study.case, study.spec).tolist())),
               "spec": study.spec.to_dict(), **stats, "sensitivity_check": check,
               "judges": [s.to_dict() for s in spots],
               "judges_passed": all(s.passed for s in spots), "timing": timing, "versions": versions()}
    summary = finite_json(summary)
    rundir.write_json(outdir, "summary.json", summary, pretty=True)
    return summary, x, samples
