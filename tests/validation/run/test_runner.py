"""The matrix runner's process hygiene (its results are tested in test_validate.py)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from dualmech.validation.matrix import load_matrix
from dualmech.validation.provenance import case_fingerprint
from dualmech.validation.run.runner import CASE_FORMAT, CaseFileText, run_matrix
from tests.validation.test_validate import FAKE_REGISTRY, FAKES, ROOT
from tests.validation.worker_exits import exit_code


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
        "from dualmech.validation.matrix import load_matrix; from dualmech.validation.run.runner import "
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


# ----------------------------------------------------------------------------- case files


def test_case_file_text_is_the_json_of_the_whole_case(small):
    """Why: each case file was encoded whole (and in pure Python) every time one of its engines finished;
    each entry is now encoded once, the file's text assembled from them: it must stay the JSON of the case."""
    mc = load_matrix(small).cases[0]
    engines = ("dualmech", "pinocchio", "mujoco")
    kept = {"pinocchio": {"engine": "pinocchio", "seconds": 0.5, "table": {"S4": [1.0, float("nan")]}}}
    text = CaseFileText(mc.id, mc.raw, engines, kept)
    text.add({"engine": "mujoco", "seconds": 1.25, "error": "ValueError: x", "table": None})
    final = text.add({"engine": "dualmech", "seconds": 2.0, "table": {"S4": [0.1, 1e300, -0.0]}})
    whole = {"format": CASE_FORMAT, "id": mc.id, "fingerprint": case_fingerprint(mc.raw), "raw": mc.raw,
             "engines": {e: text.entries[e] for e in engines}}
    assert final == json.dumps(whole)
    assert list(json.loads(final)["engines"]) == list(engines)  # the matrix's order, not the finishing one


def test_case_file_text_in_finishing_order_is_seen(small, monkeypatch):
    """The fault the test above must see: engines written in the order they finished."""
    import dualmech.validation.run.runner as runner

    mc = load_matrix(small).cases[0]
    real = runner.CaseFileText.add

    def finishing_order(self, entry):
        real(self, entry)
        body = ", ".join(f"{json.dumps(k)}: {self._texts[k]}" for k in self.entries)
        return f'{self._head}, "engines": {{{body}}}}}'

    monkeypatch.setattr(runner.CaseFileText, "add", finishing_order)
    text = CaseFileText(mc.id, mc.raw, ("dualmech", "pinocchio"), {})
    text.add({"engine": "pinocchio", "table": None})
    final = text.add({"engine": "dualmech", "table": None})
    assert list(json.loads(final)["engines"]) != ["dualmech", "pinocchio"]


def test_a_ctrl_c_while_a_case_file_is_encoded_leaves_it_whole(small, monkeypatch):
    """Why: a Ctrl-C that landed while an entry was being encoded (``json_text``) left the entry taken but not
    its text, and storing the next one failed with ``KeyError`` (an internal error, exit 70, instead of the
    interrupt's 130: seen once in the README's test run).  Now the case file goes on without it."""
    import dualmech.validation.run.runner as runner

    mc = load_matrix(small).cases[0]
    text = CaseFileText(mc.id, mc.raw, ("dualmech", "pinocchio"), {})
    real = runner.json_text

    def interrupted(data, **kwargs):
        monkeypatch.setattr(runner, "json_text", real)
        raise KeyboardInterrupt

    monkeypatch.setattr(runner, "json_text", interrupted)
    with pytest.raises(KeyboardInterrupt):
        text.add({"engine": "dualmech", "table": None})
    final = text.add({"engine": "pinocchio", "table": None})
    assert list(json.loads(final)["engines"]) == ["pinocchio"]


def test_the_entry_being_stored_at_a_ctrl_c_is_stored(small, tmp_path, monkeypatch):
    """A finished engine's result is kept when the Ctrl-C lands while its case file is being written: the
    runner stores it again as it ends (``A long run that is interrupted loses no finished results``)."""
    from dualmech.validation import rundir

    real, calls = rundir.write_file, []

    def interrupted(root, name, data, **kwargs):
        if str(name).startswith("cases/"):
            calls.append(name)
            if len(calls) == 1:  # the first case file's first write
                raise KeyboardInterrupt
        return real(root, name, data, **kwargs)

    monkeypatch.setattr(rundir, "write_file", interrupted)
    out = tmp_path / "run"
    with pytest.raises(KeyboardInterrupt):
        run_matrix(load_matrix(small), out, jobs=1, registry=FAKE_REGISTRY)
    assert json.loads((out / str(calls[0])).read_text())["engines"]


# ----------------------------------------------------------------------------- one pool per process


def _pool_pids(jobs: int) -> set[int]:
    from dualmech.validation.run import executors

    pool = executors._SHARED.get(jobs)
    return set((getattr(pool, "_processes", None) or {}).keys()) if pool is not None else set()


def test_a_finished_run_leaves_its_workers_to_the_next_work(small, tmp_path):
    """Why: the run's pool was ended and the report spawned another (workers importing their libraries
    again, ~1 s each); a finished run keeps its workers for the report and the next run."""
    from dualmech.validation.run import executors

    matrix = load_matrix(small)
    executors.end_shared_pool()
    try:
        run_matrix(matrix, tmp_path / "a", jobs=2, registry=FAKE_REGISTRY)
        first = _pool_pids(2)
        assert len(first) == 2
        run_matrix(matrix, tmp_path / "b", jobs=2, registry=FAKE_REGISTRY)
        assert _pool_pids(2) == first
        assert executors.shared_pool(2).submit(os.getpid).result() in first
    finally:
        executors.end_shared_pool()
    assert not _pool_pids(2)


def test_a_run_that_ends_its_pool_is_seen(small, tmp_path, monkeypatch):
    """The fault the test above must see: the pool ended after each run (as before)."""
    from dualmech.validation.run import executors

    matrix = load_matrix(small)
    real = executors._on_pool

    def ending(*args, **kwargs):
        yield from real(*args, **kwargs)
        executors.end_shared_pool()

    monkeypatch.setattr(executors, "_on_pool", ending)
    executors.end_shared_pool()
    try:
        run_matrix(matrix, tmp_path / "a", jobs=2, registry=FAKE_REGISTRY)
        assert not _pool_pids(2)
    finally:
        executors.end_shared_pool()


def test_an_interrupted_run_ends_its_busy_workers_at_once():
    """``end_shared_pool(grace=0)`` (what an interrupted run calls) ends a worker still busy with its
    task by a signal, not after the task (``shutdown`` forgets the pool's processes: they are taken
    first; taken after, none was ended and the 60 s task below ran on)."""
    from dualmech.validation.run import executors

    executors.end_shared_pool()
    pool = executors.shared_pool(1)
    pool.submit(time.sleep, 60)
    workers = list(pool._processes.values())
    assert workers
    executors.end_shared_pool(1, grace=0.0)
    for proc in workers:
        code = exit_code(proc, timeout=20)
        assert code is not None and code < 0, code
