"""The matrix runner's process hygiene (its results are tested in test_validate.py)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from dualmech.validation.matrix import load_matrix
from dualmech.validation.runner import run_matrix

from .test_validate import FAKE_REGISTRY, FAKES, ROOT


def _children(pid: int) -> set[int]:
    out: set[int] = set()
    for task in Path(f"/proc/{pid}/task").glob("*"):
        try:
            text = (task / "children").read_text().split()
        except OSError:  # the thread or process has gone meanwhile
            continue
        out |= {int(p) for p in text}
    return out


def _descendants(pid: int) -> set[int]:
    """Every process below ``pid`` (pool workers hang below a forkserver)."""
    out, todo = set(), [pid]
    while todo:
        kids = _children(todo.pop()) - out
        out |= kids
        todo += kids
    return out


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0]
    except OSError:
        return False
    return state != "Z"  # a zombie has exited


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG and /proc are Linux-only")
@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM])
def test_workers_die_with_a_killed_run(small, tmp_path, sig):
    """Kill the run halfway: its pool workers must not linger, waiting on their queue forever."""
    slow = dict(FAKE_REGISTRY, dualmech=f"{FAKES}:solve_case_slow")
    out = tmp_path / "run"
    script = (
        "from dualmech.validation.matrix import load_matrix; from dualmech.validation.runner import "
        "run_matrix; "
        f"run_matrix(load_matrix({str(small)!r}), {str(out)!r}, jobs=2, registry={slow!r})"
    )
    env = dict(os.environ, MATRIX_FAKES_DELAY="0.3", PYTHONPATH=str(ROOT))
    proc = subprocess.Popen([sys.executable, "-c", script], cwd=ROOT, env=env)
    try:
        deadline = time.time() + 60
        while time.time() < deadline and not list((out / "cases").glob("*.json")):
            time.sleep(0.05)
        workers = _descendants(proc.pid)
        assert len(workers) >= 2, workers  # two workers (and multiprocessing's resource tracker)
    finally:
        proc.send_signal(sig)
        proc.wait()
    deadline = time.time() + 10
    while time.time() < deadline and any(_alive(w) for w in workers):
        time.sleep(0.05)
    lingering = [w for w in workers if _alive(w)]
    for w in lingering:  # do not leave them behind even when the test fails
        os.kill(w, signal.SIGKILL)
    assert not lingering


def test_empty_scheduler_address_is_refused(small, tmp_path):
    with pytest.raises(ValueError, match="scheduler"):
        run_matrix(load_matrix(small), tmp_path / "run", scheduler=" ", registry=FAKE_REGISTRY)
