"""The benchmark's time inside an engine (:func:`dualmech.validation.benchmark.rows.library_time`), the main
job's
timing and the performance page.

No timing of the suite itself: a sleep stands for a library function whose time is known, a fake clock and
fake processes for the main job.
"""

from __future__ import annotations

import subprocess
import time
import types

import pytest

from dualmech.validation.benchmark import rows as benchmark
from dualmech.validation.benchmark.rows import library_time


def test_library_time_counts_the_library_functions_alone_and_restores_them() -> None:
    """Time in the module's functions of the given type is counted, time outside them is not, its classes
    stay classes, and every function is itself again afterwards."""
    lib = types.ModuleType("lib")
    lib.wait, lib.size, lib.Table = time.sleep, len, dict
    start = time.perf_counter()
    with library_time(lib, time.sleep) as spent:
        lib.wait(0.05)
        assert lib.size([1, 2]) == 2 and lib.Table is dict
        outside = time.perf_counter()
        time.sleep(0.05)  # not through the library
        outside = time.perf_counter() - outside
    assert 0.05 <= spent[0] <= time.perf_counter() - start - outside
    assert (lib.wait, lib.size) == (time.sleep, len)


def test_the_main_job_is_timed_in_fresh_processes_and_a_failure_is_no_figure(monkeypatch) -> None:
    """Each run is a new ``dualmech validate`` process into a new folder, the warm-up run is not counted, the
    figures are the runs' own; a run that exits non-zero raises instead of giving a time."""
    calls: list[list[str]] = []
    seconds = iter([10.0, 11.0, 13.0, 15.0, 19.0, 20.0])  # perf_counter: start/end of 3 runs

    def fake_run(argv, **_kwargs):
        calls.append(argv)
        return subprocess.CompletedProcess(argv, 0, "PASS", "")

    monkeypatch.setattr(benchmark.subprocess, "run", fake_run)
    monkeypatch.setattr(benchmark.time, "perf_counter", lambda: next(seconds))
    timing = benchmark.time_main_job(2)
    assert [a[3:5] for a in calls] == [["validate", "-o"]] * 3
    assert len({a[5] for a in calls}) == 3  # a fresh folder each time
    assert timing.walls == (2.0, 1.0)  # the first run (1.0 s) is the warm-up
    row = timing.lines()[2]
    assert "| 2 | 1.50 | 1.00-2.00 |" in row

    monkeypatch.setattr(benchmark.subprocess, "run",
                        lambda argv, **kw: subprocess.CompletedProcess(argv, 1, "", "FAIL: 3 of 9 checks\n"))
    monkeypatch.setattr(benchmark.time, "perf_counter", lambda: 0.0)
    with pytest.raises(RuntimeError, match=r"^main job: dualmech validate exited 1: FAIL: 3 of 9 checks$"):
        benchmark.time_main_job(1)


def test_the_performance_page_names_the_command_that_wrote_it() -> None:
    page = benchmark.performance_page("| a | b |", "dualmech benchmark -o docs/performance.md")
    assert page.startswith("# Performance\n")
    assert "one run of `dualmech benchmark -o docs/performance.md` on 20" in page
    assert page.endswith("| a | b |\n")
