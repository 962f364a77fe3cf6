"""The main job's timing (``validation/benchmark/main_job.py``): fresh processes; a failing run gives no
figure."""

from __future__ import annotations

import subprocess

import pytest

from dualmech.validation.benchmark import main_job


def test_the_main_job_is_timed_in_fresh_processes_and_a_failure_is_no_figure(monkeypatch) -> None:
    """Each run is a new ``dualmech validate`` process into a new folder, the warm-up run is not counted, the
    figures are the runs' own; a run that exits non-zero raises instead of giving a time."""
    calls: list[list[str]] = []
    seconds = iter([10.0, 11.0, 13.0, 15.0, 19.0, 20.0])  # perf_counter: start/end of 3 runs

    def fake_run(argv, **_kwargs):
        calls.append(argv)
        return subprocess.CompletedProcess(argv, 0, "PASS", "")

    monkeypatch.setattr(main_job.subprocess, "run", fake_run)
    monkeypatch.setattr(main_job.time, "perf_counter", lambda: next(seconds))
    timing = main_job.time_main_job(2)
    assert [a[3:5] for a in calls] == [["validate", "-o"]] * 3
    assert len({a[5] for a in calls}) == 3  # a fresh folder each time
    assert timing.walls == (2.0, 1.0)  # the first run (1.0 s) is the warm-up
    row = timing.lines()[2]
    assert "| 2 | 1.50 | 1.00-2.00 |" in row

    monkeypatch.setattr(main_job.subprocess, "run",
                        lambda argv, **kw: subprocess.CompletedProcess(argv, 1, "", "FAIL: 3 of 9 checks\n"))
    monkeypatch.setattr(main_job.time, "perf_counter", lambda: 0.0)
    with pytest.raises(RuntimeError, match=r"^main job: dualmech validate exited 1: FAIL: 3 of 9 checks$"):
        main_job.time_main_job(1)
