"""The main job's time as a user meets it: ``dualmech validate`` of the default matrix with its report, each
run a fresh process into a fresh folder (the last table of ``dualmech benchmark``,
:mod:`~dualmech.validation.benchmark.rows`).
"""

from __future__ import annotations

import resource
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass


@dataclass(frozen=True)
class MainJobTiming:
    """Wall and CPU seconds (the process and its workers) of each timed run of the main job."""

    walls: tuple[float, ...]
    cpus: tuple[float, ...]

    def lines(self) -> list[str]:
        """The Markdown table of the runs: median, fastest and slowest."""
        w, c = self.walls, self.cpus
        return ["| main job | runs | wall s, median | wall s, min-max | CPU s, median |",
                "|---|---:|---:|---:|---:|",
                f"| `dualmech validate` (thesis-1991, 4 engines, report) | {len(w)} | "
                f"{statistics.median(w):.2f} | {min(w):.2f}-{max(w):.2f} | {statistics.median(c):.2f} |"]


def time_main_job(runs: int) -> MainJobTiming:
    """``dualmech validate`` of the default matrix ``runs`` times after a warm-up run, each in a fresh process
    into a fresh folder; a run that does not PASS is a one-line ``RuntimeError`` (a failing job's time is
    no figure)."""
    walls, cpus = [], []
    with tempfile.TemporaryDirectory(prefix="dualmech-main-job-") as tmp:
        for i in range(runs + 1):
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            start = time.perf_counter()
            proc = subprocess.run([sys.executable, "-m", "dualmech.cli", "validate", "-o", f"{tmp}/run{i}"],
                                  capture_output=True, text=True, stdin=subprocess.DEVNULL)
            wall = time.perf_counter() - start
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            if proc.returncode != 0:
                last = (proc.stderr.strip() or proc.stdout.strip()).splitlines()[-1:] or [""]
                raise RuntimeError(f"main job: dualmech validate exited {proc.returncode}: {last[0]}")
            if i:
                walls.append(wall)
                cpus.append(after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime)
    return MainJobTiming(tuple(walls), tuple(cpus))
