"""The gate of ``dualmech selftest`` on one scratch copy: its matrix with baseline semantics, then its tests.

Each part runs in a fresh Python process that imports the scratch copy only (:data:`BOOT`).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from dualmech.validation.selftest.catalogue import Catalogue
from dualmech.validation.selftest.scratch import PACKAGES

#: Exit code of :data:`BOOT` when the scratch copy is not what gets imported (an ERROR, never a kill).
WRONG_IMPORT = 97
#: One thread for the BLAS and the compiled kernel of each gate process: mutants run side by side.
_ENV = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "NUMBA_NUM_THREADS": "1",
        "MPLBACKEND": "Agg", "PYTHONDONTWRITEBYTECODE": "1", "HYPOTHESIS_PROFILE": "selftest"}


#: Prelude of every gate process: ``python -c BOOT+code SCRATCH ...`` imports ``dualmech`` from SCRATCH only.
BOOT = f"""\
import os, sys
_root = os.path.abspath(sys.argv[1])
sys.meta_path[:] = [f for f in sys.meta_path
                    if not str(getattr(f, "__module__", "")).startswith("__editable__")]
sys.path_hooks[:] = [h for h in sys.path_hooks if "__editable__" not in str(getattr(h, "__module__", ""))]
sys.path[:] = [os.path.join(_root, ".pkg"), _root] + [p for p in sys.path if "__editable__" not in p]
sys.path_importer_cache.clear()
from importlib.machinery import PathFinder
_path = sys.path
for _name in {list(PACKAGES)!r}:  # found, not imported: importing would run the code under test
    _spec = PathFinder.find_spec(_name, _path)
    _file = str(_spec.origin) if _spec is not None else "nowhere"
    if not os.path.abspath(_file).startswith(os.path.join(_root, ".pkg") + os.sep):
        print(f"selftest: {{_name}} found in {{_file}}, not in {{_root}}", file=sys.stderr)
        sys.exit({WRONG_IMPORT})
    if _name == "dualmech":
        _path = list(_spec.submodule_search_locations)
"""

_MATRIX_GATE = "from dualmech.validation.selftest.gate import gate_main\nsys.exit(gate_main(sys.argv[2:]))\n"
_TEST_GATE = "import pytest\nsys.exit(pytest.main(['-x', '-q', '-p', 'no:cacheprovider', *sys.argv[2:]]))\n"


@dataclass(frozen=True)
class GateRun:
    """One run of the gate on one scratch copy.

    ``verdict``: ``"pass"``, ``"matrix"`` (a check failed), ``"baseline"`` (only a
    regression), ``"incomplete"`` (work missing), ``"crash"`` (the matrix step raised),
    ``"tests"``, ``"timeout"`` or ``"error"`` (the harness could not judge: a stale
    fault, the wrong package imported).
    """

    verdict: str
    seconds: float
    detail: str = ""

    @property
    def killed(self) -> bool:
        return self.verdict not in ("pass", "error")


def gate_main(argv: list[str]) -> int:
    """The matrix part of the gate, run inside a scratch copy (``python -c BOOT...``).

    ``argv``: ``MATRIX OUTDIR BASELINE_IN|- BASELINE_OUT|-``.  Runs the matrix in
    this process, compares, checks (or writes) the baseline and writes the JUnit
    file as ``dualmech validate --baseline --junit`` does (everything but the
    report), and returns the exit code ``validate`` would
    (:func:`~dualmech.validation.exit_codes.exit_code`: 0 PASS, 1 FAIL or a
    regression, 3 INCOMPLETE).  Prints one JSON line: ``verdict``, ``checks``,
    ``failures``, ``regressions`` (a few of each) and their counts.
    """
    from dualmech.validation.compare import compare_run
    from dualmech.validation.compare.baseline import (
        baseline_summary,
        compare_baseline,
        read_baseline,
        write_baseline,
    )
    from dualmech.validation.compare.junit import describe, write_junit
    from dualmech.validation.exit_codes import exit_code
    from dualmech.validation.matrix import load_matrix
    from dualmech.validation.run.runner import load_entries, run_matrix, run_versions, timings

    matrix_file, outdir, baseline_in, baseline_out = argv
    matrix = load_matrix(matrix_file)
    baseline = read_baseline(baseline_in, matrix.name) if baseline_in != "-" else None  # before the run
    outcome = run_matrix(matrix, outdir, jobs=1)
    comparison = compare_run(matrix, outcome.results)
    summary = baseline_summary(matrix, comparison, outcome.results)
    regressions = compare_baseline(summary, baseline) if baseline is not None else []
    write_junit(Path(outdir) / "junit.xml", matrix, comparison, timings(load_entries(outdir, matrix)),
                regressions=regressions, versions=run_versions(Path(outdir)))
    if baseline_out != "-":
        write_baseline(baseline_out, summary)
    failures = comparison.failures()
    print(json.dumps({"verdict": str(comparison.verdict), "checks": len(comparison.checks),
                      "failures": [describe(c) for c in failures[:3]], "n_failures": len(failures),
                      "regressions": [str(r) for r in regressions[:3]], "n_regressions": len(regressions)}))
    return exit_code(comparison.verdict, regressions)


def _python(scratch: Path, code: str, args: list[str], timeout: float) -> tuple[int | None, str, str]:
    """Run ``python -c BOOT+code scratch *args`` in ``scratch``; ``None`` as exit code on timeout.

    The process is listed while it runs, for :func:`stop_gates`; an exception here (an interrupt of
    the selftest's own thread) kills it, as ``subprocess.run`` would.
    """
    env = {**os.environ, **_ENV}
    env.pop("NUMBA_CACHE_DIR", None)  # keep the kernel cache in the copy (it carries the warm one)
    cmd = [sys.executable, "-c", BOOT + code, str(scratch), *args]
    if _STOPPING.is_set():  # the selftest was interrupted: start nothing more
        return None, "", "stopped: the selftest was interrupted"
    with subprocess.Popen(cmd, cwd=scratch, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                          text=True) as proc:
        _RUNNING.add(proc)
        try:
            out, err = proc.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            proc.kill()
            out, err = proc.communicate()
            return None, out, err
        except BaseException:
            proc.kill()
            raise
        finally:
            _RUNNING.discard(proc)
    return proc.returncode, out, err


#: The gate processes running now (:func:`_python`), each started by one of the selftest's threads.
_RUNNING: set[subprocess.Popen] = set()
#: Set by :func:`stop_gates` until :func:`stop_gates` ``(False)``: no new gate process is started.
_STOPPING = threading.Event()


def stop_gates(stop: bool = True) -> None:
    """Kill every gate process running now and start no more (the selftest was interrupted): their threads
    then end at once, not after the gate step (minutes), and the gates' pool workers end with them
    (PR_SET_PDEATHSIG).  ``stop=False``: gates may run again (a selftest begins)."""
    if not stop:
        _STOPPING.clear()
        return
    _STOPPING.set()
    for proc in list(_RUNNING):
        proc.kill()


def _decode(data: bytes | str | None) -> str:
    return data.decode(errors="replace") if isinstance(data, bytes) else (data or "")


def _last_line(text: str) -> str:
    lines = [ln.strip() for ln in text.strip().splitlines() if ln.strip()]
    return lines[-1] if lines else ""


def _matrix_verdict(code: int | None, out: str, err: str) -> tuple[str, str]:
    if code is None:
        return "timeout", "matrix step timed out"
    if code == WRONG_IMPORT:
        return "error", _last_line(err)
    report = None
    for line in reversed(out.splitlines()):
        if line.startswith("{"):
            report = json.loads(line)
            break
    if report is None:
        return "crash", _last_line(err) or f"exit code {code}"
    if code == 0:
        return "pass", f"{report['checks']} checks"
    if report["verdict"] == "FAIL":
        return "matrix", f"{report['n_failures']} checks fail, e.g. {report['failures'][0]}"
    if report["n_regressions"]:
        return "baseline", f"{report['n_regressions']} regressions, e.g. {report['regressions'][0]}"
    return "incomplete", f"exit code {code}: {report['verdict']}, e.g. {(report['failures'] or ['?'])[0]}"


def _tests_verdict(code: int | None, out: str, err: str) -> tuple[str, str]:
    if code is None:
        return "timeout", "tests timed out"
    if code == WRONG_IMPORT:
        return "error", _last_line(err)
    if code == 0:
        return "pass", _last_line(out)
    failed = [ln for ln in out.splitlines() if ln.startswith(("FAILED", "ERROR"))]
    return "tests", (failed[0] if failed else _last_line(out) or _last_line(err))[:200]


def run_gate(scratch: Path, catalogue: Catalogue, baseline_in: Path | None, baseline_out: Path | None,
             timeout: float, tests_first: bool = False) -> GateRun:
    """The gate on one scratch copy: the matrix part, then (if it passes) the test part.

    ``tests_first`` swaps the order (for faults in the comparison: they leave every
    engine's numbers as they were, and their unit tests decide faster); the second
    part runs only when the first passes.
    """
    start = time.perf_counter()
    args = [str(scratch / catalogue.matrix), str(scratch / ".run"),
            str(baseline_in) if baseline_in else "-", str(baseline_out) if baseline_out else "-"]
    parts = [lambda: _matrix_verdict(*_python(scratch, _MATRIX_GATE, args, timeout))]
    if catalogue.tests:
        parts.append(lambda: _tests_verdict(*_python(scratch, _TEST_GATE, list(catalogue.tests), timeout)))
    verdict, detail = "pass", ""
    for part in reversed(parts) if tests_first else parts:
        verdict, detail = part()
        if verdict != "pass":
            break
    return GateRun(verdict, time.perf_counter() - start, detail)
