"""A tolerance study end to end, judged: the Monte Carlo chunks run, sensitivities, spot checks, summary.

The study's parts live in :mod:`dualmech.models.tolerance` (sampling, batched solving of a chunk,
its storage and resumption: :mod:`~dualmech.models.tolerance.study`; sensitivities; statistics).
This module runs them: the chunks in this process, in a process pool (``jobs``) or on a Dask
cluster (``scheduler``) through :func:`dualmech.validation.executors.execute`, each stored as it
finishes; then the exact sensitivities and their check, the judges' spot checks
(:mod:`~dualmech.validation.tolerance_judges`) and ``DIR/summary.json`` with the library versions.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from dualmech.models.slider_crank import solve_case
from dualmech.models.tolerance import sensitivity
from dualmech.models.tolerance.designs import design_name
from dualmech.models.tolerance.differences import check_sensitivities
from dualmech.models.tolerance.outputs import design_outputs, output_names
from dualmech.models.tolerance.sampling import judge_picks, n_chunks
from dualmech.models.tolerance.spec import design_case, nominal_values
from dualmech.models.tolerance.study import (
    METHODS,
    StudyInput,
    finite_json,
    gather,
    prepare,
    solve_chunk,
    store_chunk,
    write_samples,
)
from dualmech.models.tolerance.summary import summarize
from dualmech.validation.executors import execute
from dualmech.validation.provenance import versions
from dualmech.validation.tolerance_judges import candidates, run_spot_checks


def run_chunks(outdir: Path, study: StudyInput, todo: list[int], jobs: int, scheduler: str | None) -> int:
    """Solve the chunks ``todo``, storing each as it finishes; returns how many ran."""
    calls = [(study.case.raw, study.spec.to_dict(), study.n, study.seed, c) for c in todo]
    leftovers: list[dict] = []
    done = 0
    try:
        for entry in execute(solve_chunk, calls, jobs, scheduler, leftovers):
            store_chunk(outdir, entry)
            done += 1
    finally:
        for entry in leftovers:
            store_chunk(outdir, entry)
    return done


def monte_carlo(outdir: Path, study: StudyInput, jobs: int, scheduler: str | None) -> dict:
    """Run (or resume) the Monte Carlo part; returns timing facts."""
    todo = prepare(outdir, study)
    start = time.perf_counter()
    ran = run_chunks(outdir, study, todo, jobs, scheduler)
    solve_s = time.perf_counter() - start
    files = write_samples(outdir, study)
    return {"chunks_run": ran, "chunks_resumed": n_chunks(study.n) - len(todo), "solve_s": solve_s,
            "files": files}


def run_study(study: StudyInput, method: str, outdir: Path, jobs: int = 1, scheduler: str | None = None,
              judge_samples: int = 5) -> tuple[dict, np.ndarray | None, dict[str, np.ndarray] | None]:
    """The whole study (module docstring): returns the summary (also in ``DIR/summary.json``) and the samples.

    Sampled key values ``(n, k)`` and outputs are ``None`` for ``method = "linear"``.
    """
    if method not in METHODS:
        raise ValueError(f"method: expected one of {', '.join(METHODS)}, got {method!r}")
    if judge_samples < 0:
        raise ValueError(f"judge-samples: expected 0 or more designs, got {judge_samples!r}")
    if method != "mc" and not study.case.joints.is_default:
        j = study.case.joints
        raise ValueError(f"method: {method!r} needs the exact sensitivities, which cover the default joints "
                         f"only (cylindrical crank, ball-ball rod), not crank = {j.crank!r}, rod_slider = "
                         f"{j.rod_slider!r} (valid: --method mc)")
    outdir = Path(outdir)
    timing: dict = {}
    x = samples = None
    if method != "linear":
        timing = monte_carlo(outdir, study, jobs, scheduler)
        x, samples = gather(outdir, study)
    else:
        outdir.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    table = solve_case(study.case)
    mode = study.case.loads.mode
    solved = design_outputs([table], mode)
    nominal = {name: float(solved[name][0]) for name in output_names(mode)}
    sens = sensitivity.sensitivities(study.case, study.spec, table) if method != "mc" else None
    check = check_sensitivities(study.case, study.spec, sens).to_dict() if sens is not None else None
    timing["sensitivity_s"] = time.perf_counter() - start
    stats = summarize(study.spec, nominal, x, samples, sens)
    if samples is not None:
        picks = judge_picks(judge_samples, study.seed, candidates(samples["status"]))
        designs = [design_case(study.case, study.spec, x[i], design_name(int(i))) for i in picks]
    else:
        designs = [study.case] if judge_samples else []
    start = time.perf_counter()
    spots = run_spot_checks(designs)
    timing["judges_s"] = time.perf_counter() - start
    summary = {"n": study.n if samples is not None else 0, "seed": study.seed, "method": method,
               "case": study.case.name, "mode": study.case.loads.mode, "keys": list(study.spec.keys),
               "nominal_values": dict(zip(study.spec.keys, nominal_values(study.case, study.spec).tolist())),
               "spec": study.spec.to_dict(), **stats, "sensitivity_check": check,
               "judges": [s.to_dict() for s in spots],
               "judges_passed": all(s.passed for s in spots), "timing": timing, "versions": versions()}
    summary = finite_json(summary)
    (outdir / "summary.json").write_text(json.dumps(summary, indent=1, sort_keys=True) + "\n")
    return summary, x, samples
