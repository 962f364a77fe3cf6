"""The end of a command's worker pools (``validation/run/executors.py``): bounded, whatever the workers do.

Why: CI timed out (90 min) after the main job had printed part of its table: the command had done its
work and never exited.  A pool kept for reuse was left to the interpreter's exit, which joins its
workers without a time limit, so one worker that does not exit keeps the command (and the output still
in its buffers) forever.  Here a worker is made not to exit (a thread that never ends, joined at the
worker's exit as any library's non-daemon thread would be).
"""

from __future__ import annotations

import os
import select
import subprocess
import sys
import textwrap
import threading
import time
from typing import Any

import pytest
from click.testing import CliRunner

from dualmech.validation.run import executors
from tests.validation.test_validate import ROOT
from tests.validation.worker_exits import exit_code

#: Seconds a process with a worker that never exits is given to exit (it needs about 1 s).
PROCESS_EXIT_S = 15.0
#: Seconds a program that has ended its pools and said so is given to exit: its interpreter's teardown, about
#: 0.1 s (a pool left to the teardown joins a worker that never exits).
EXIT_AFTER_DONE_S = 5.0


def never_ending_thread() -> int:
    """A pool task: leave a non-daemon thread behind, so that the worker's exit waits forever."""
    threading.Thread(target=time.sleep, args=(3600,), daemon=False).start()
    return 1


def _program(end: str, keep: bool = True) -> str:
    """A program whose worker never exits by itself, ending its pools by ``end``; ``keep``: it holds a
    reference to the pool (else only the executors module does, as in a command)."""
    pool = "pool" if keep else "executors.shared_pool(1)"
    return textwrap.dedent(f"""
        from dualmech.validation.run import executors
        from tests.validation.run.test_executors import never_ending_thread
        if __name__ == "__main__":
            pool = executors.shared_pool(1)
            assert {pool}.submit(never_ending_thread).result() == 1
            {"" if keep else "del pool"}
            {end}
            print("done", flush=True)
    """)


def _run(program: str, tmp_path) -> tuple[int | None, str, str]:
    """Run ``program`` until it prints its first line (its work and its end of the pools done), at most
    :data:`PROCESS_EXIT_S`, and then at most :data:`EXIT_AFTER_DONE_S` more; its exit code (None: it had not
    exited, and is killed), stdout and stderr."""
    script = tmp_path / "program.py"
    script.write_text(program)
    pipes = {"stdout": subprocess.PIPE, "stderr": subprocess.PIPE}
    with subprocess.Popen([sys.executable, str(script)], cwd=ROOT, text=True, **pipes,
                          env={"PYTHONPATH": str(ROOT), "PATH": ""}) as proc:
        said = select.select([proc.stdout], [], [], PROCESS_EXIT_S)[0]
        first = proc.stdout.readline() if said else ""
        try:
            code = proc.wait(timeout=EXIT_AFTER_DONE_S)
        except subprocess.TimeoutExpired:
            code = None
            proc.kill()
        out, err = proc.communicate()
    return code, first + out, err


def test_a_process_that_ends_its_pools_exits_though_a_worker_would_not(tmp_path):
    start = time.monotonic()
    code, out, err = _run(_program("executors.end_all_pools(grace=0.5)"), tmp_path)
    assert code == 0 and out == "done\n", err
    assert time.monotonic() - start < PROCESS_EXIT_S


def test_a_shared_pool_that_nothing_else_refers_to_is_ended_too(tmp_path):
    """As in a command, where only the executors module holds the pool: ``end_all_pools`` once emptied
    the shared pools before it listed the pools to end, the pool was collected and left to the
    interpreter's exit (seen: this program hung; the main job waited 0.4 s for its workers' teardown)."""
    code, out, err = _run(_program("executors.end_all_pools(grace=0.5)", keep=False), tmp_path)
    assert code == 0 and out == "done\n", err


def test_a_pool_left_to_the_interpreters_exit_hangs_it(tmp_path):
    """The fault the tests above must see (what the commands did before): the pool left to the exit; the
    program says it is done and does not exit."""
    code, out, err = _run(_program("pass"), tmp_path)
    assert code is None and out == "done\n", err


def test_end_all_pools_ends_a_worker_that_does_not_exit_by_a_signal():
    executors.end_shared_pool()
    pool = executors.shared_pool(1)
    assert pool.submit(never_ending_thread).result() == 1
    workers = list(pool._processes.values())
    start = time.monotonic()
    executors.end_all_pools(grace=0.5)
    for proc in workers:
        code = exit_code(proc, timeout=PROCESS_EXIT_S)
        assert code is not None and code < 0, code
    assert time.monotonic() - start < 0.5 + executors.KILL_AFTER_S + 5.0
    assert not executors._SHARED


def slow_exit(seconds: float) -> int:
    """A pool task: make the worker's exit take ``seconds`` (an exit handler), as a library's teardown can."""
    import atexit

    atexit.register(time.sleep, seconds)
    return os.getpid()


def _two_workers_one_slow() -> tuple[Any, int]:
    """A shared pool of two started workers, one of whose exit takes 1 s longer; (pool, its pid)."""
    executors.end_shared_pool()
    pool = executors.shared_pool(2)
    first = pool.submit(time.sleep, 0.5)  # both workers busy at once: both started
    slow = pool.submit(slow_exit, 1.0).result()
    first.result()
    assert len(pool._processes) == 2 and slow in pool._processes
    return pool, slow


def test_end_all_pools_waits_for_every_worker_that_exits_by_itself():
    """Workers that exit within the grace are not signalled, also when one exits well after the other
    (a wait that ends at the first exit, and then signals the rest, is seen below)."""
    pool, _ = _two_workers_one_slow()
    workers = list(pool._processes.values())
    manager = pool._executor_manager_thread
    executors.end_all_pools(grace=executors.EXIT_GRACE_S)
    assert [exit_code(p, timeout=PROCESS_EXIT_S) for p in workers] == [0, 0]
    assert not manager.is_alive()  # its pipes closed: nothing left for the interpreter's exit


class SlowTeardown:
    """An object whose deletion takes :data:`TEARDOWN_S` seconds, as a loaded library's teardown can."""

    def __del__(self) -> None:
        time.sleep(TEARDOWN_S)


#: Seconds the teardown of :class:`SlowTeardown` takes.
TEARDOWN_S = 3.0
#: What a pool task leaves in its worker: collected at the interpreter's teardown, not before.
_LEFT_IN_WORKER: list[Any] = []


def leave_slow_teardown(marker: str) -> int:
    """A pool task: leave a :class:`SlowTeardown` in the worker's modules and an exit handler that writes
    ``marker``."""
    import atexit
    from pathlib import Path

    _LEFT_IN_WORKER.append(SlowTeardown())
    atexit.register(Path(marker).write_text, "ran")
    return os.getpid()


def test_a_worker_exits_without_its_teardown_after_its_exit_handlers(tmp_path):
    """The end of a pool does not wait for its workers' teardown (:func:`executors._leave`), and the exit
    handlers that tasks registered still run, before it.  Seen failing: without ``_leave`` the end took
    the 3 s teardown; with ``os._exit`` at the worker's first exit handler, the task's did not run."""
    executors.end_shared_pool()
    pool = executors.shared_pool(1)
    marker = tmp_path / "handler-ran"
    pool.submit(leave_slow_teardown, str(marker)).result()
    workers = list(pool._processes.values())
    start = time.monotonic()
    executors.end_all_pools(grace=executors.EXIT_GRACE_S)
    assert time.monotonic() - start < TEARDOWN_S / 2
    assert [exit_code(p, timeout=PROCESS_EXIT_S) for p in workers] == [0]
    assert marker.read_text() == "ran"


def test_a_grace_that_ends_at_the_first_exit_is_seen(monkeypatch):
    """The fault the test above must see: the slow worker signalled once the other has exited."""
    import multiprocessing.connection

    wait = multiprocessing.connection.wait  # one wait: it returns at the first sentinel ready

    pool, slow = _two_workers_one_slow()
    workers = dict(pool._processes)
    monkeypatch.setattr(executors, "_running_after", lambda left, seconds: [
        p for p in left if p.sentinel not in wait([q.sentinel for q in left], seconds)])
    executors.end_all_pools(grace=executors.EXIT_GRACE_S)
    assert exit_code(workers[slow], timeout=PROCESS_EXIT_S) < 0


def test_every_command_ends_its_pools(monkeypatch):
    """The ``dualmech`` group ends every pool when a command is done (here a command that uses none)."""
    from dualmech.cli import main

    executors.end_shared_pool()
    pool = executors.shared_pool(1)
    assert pool.submit(int, 1).result() == 1
    workers = list(pool._processes.values())
    assert workers
    result = CliRunner().invoke(main, ["cases"])
    assert result.exit_code == 0, result.output
    assert not executors._SHARED and pool not in executors._POOLS
    assert [exit_code(p, timeout=PROCESS_EXIT_S) for p in workers] == [0]


def test_a_pool_let_go_is_ended_with_the_others():
    """``let_go`` (the tolerance study's figure worker, once its figures are in) does not wait; the
    command's end still bounds the wait for its worker (one left out of ``end_all_pools`` is seen)."""
    pool = executors.process_pool(1)
    assert pool.submit(never_ending_thread).result() == 1
    workers = list(pool._processes.values())
    executors.let_go(pool)
    assert exit_code(workers[0], timeout=0.5) is None  # still exiting: not waited for
    executors.end_all_pools(grace=0.5)
    code = exit_code(workers[0], timeout=PROCESS_EXIT_S)
    assert code is not None and code < 0, code


def test_ending_a_pool_without_a_grace_waits_for_its_workers():
    """``end_pool(pool)`` (grace inf) returns once the workers have ended, however long their exit takes
    (two shutdowns in a row, as before, returned at once: the first forgets the manager thread)."""
    pool = executors.process_pool(1)
    pool.submit(slow_exit, 1.0).result()
    workers = list(pool._processes.values())
    executors.end_pool(pool)
    assert [exit_code(p, timeout=0.05) for p in workers] == [0]  # at once: the exit code is there


def whose(tag: str) -> dict:
    """A task that says which process and thread ran it."""
    return {"tag": tag, "pid": os.getpid(), "thread": threading.current_thread().name}


def test_calls_chosen_to_run_here_run_in_a_thread_of_this_process_the_others_in_the_workers():
    """``execute(here=...)``: the in-house engine's tasks run beside the pool, in this process
    (engines.IN_PROCESS_ENGINES), every other task in a worker; every entry is yielded once."""
    calls = [(tag,) for tag in ("pool-1", "here-1", "pool-2", "here-2")]
    try:
        here = lambda call: call[0].startswith("here")  # noqa: E731
        entries = list(executors.execute(whose, calls, 2, None, [], here=here))
    finally:
        executors.end_shared_pool(2)
    assert sorted(e["tag"] for e in entries) == sorted(c[0] for c in calls)
    for e in entries:
        here = e["tag"].startswith("here")
        assert (e["pid"] == os.getpid()) == here, e
        assert e["thread"].startswith("dualmech-task") == here, e


def test_the_run_solves_small_cases_with_the_inhouse_engine_and_pinocchio_here_and_the_rest_in_workers():
    """Only an engine registered under its own function runs here (a test's fake of the same name still
    runs in a worker, where it may crash or hang as it is meant to), on cases small enough that an
    interrupt need not wait for it; a case table that does not parse goes to a worker, which stores why.
    Faults seen: everything here (no bound), the engine chosen by its name only."""
    from dualmech.models.case import load_case
    from dualmech.models.kinds import SLIDER_CRANK
    from dualmech.validation.engines import ENGINES, IN_PROCESS_ENGINES, runs_here

    raw = load_case("thesis/ideal").raw

    def with_positions(n: int) -> dict:
        angles = {"start": 0.0, "stop": 360.0, "step": 360.0 / n}  # n positions
        return dict(raw, motion=dict(raw["motion"], angles_deg=angles))

    assert set(IN_PROCESS_ENGINES) == {"dualmech", "pinocchio"}
    for engine, (spec, most) in IN_PROCESS_ENGINES.items():
        assert spec == ENGINES[engine][SLIDER_CRANK]
        assert runs_here(engine, spec, raw) and runs_here(engine, spec, with_positions(most))
        assert not runs_here(engine, spec, with_positions(most + 1))
        assert not runs_here(engine, spec, dict(raw, geometry={}))
        assert not runs_here(engine, "tests.validation.fake_engines:crash", raw)
    assert IN_PROCESS_ENGINES["dualmech"][1] == 100_000 and IN_PROCESS_ENGINES["pinocchio"][1] == 2_000
    others = [e for e in ENGINES if e not in IN_PROCESS_ENGINES and SLIDER_CRANK in ENGINES[e]]
    assert not any(runs_here(e, ENGINES[e][SLIDER_CRANK], raw) for e in others)


def test_end_all_pools_interrupted_while_it_waits_ends_the_workers_at_once():
    """A Ctrl-C during the (up to 10 s) wait for the workers: they are ended now, and the interrupt goes on
    (before, the pools were already forgotten and the workers left to the interpreter's exit)."""
    import signal

    executors.end_shared_pool()
    pool = executors.shared_pool(1)
    assert pool.submit(never_ending_thread).result() == 1
    workers = list(pool._processes.values())
    timer = threading.Timer(0.5, os.kill, (os.getpid(), signal.SIGINT))
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    start = time.monotonic()
    try:
        timer.start()
        with pytest.raises(KeyboardInterrupt):
            executors.end_all_pools(grace=60.0)
    finally:
        timer.cancel()
        signal.signal(signal.SIGINT, previous)
    assert [exit_code(p, timeout=PROCESS_EXIT_S) for p in workers] == [-signal.SIGTERM]
    assert time.monotonic() - start < 0.5 + executors.KILL_AFTER_S + 5.0
