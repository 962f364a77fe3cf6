"""Where the tasks of a run execute: this process, a local process pool, or a Dask cluster.

Every backend yields finished task entries as they come; the caller stores each at
once.  Whatever happens to the run, nothing finished is lost and nothing is left
behind:

* **Interrupted (SIGINT).**  Pool workers ignore SIGINT (a terminal's Ctrl-C reaches
  the whole process group); the generator's ``finally`` gives running tasks
  :data:`INTERRUPT_GRACE_S` seconds to finish, hands every finished task not yet
  yielded to ``leftovers`` for the caller to store, and ends the workers.
* **Killed (SIGTERM, SIGKILL).**  Pool workers ask the kernel to end them with their
  parent (:func:`worker_init`).
* **A worker killed.**  The run ends with :class:`WorkerDied`: one line, how the worker ended and
  the task it ran (:func:`worker_died`); finished tasks are handed over as at an interrupt.
* **A lost cluster.**  The Dask backend checks the scheduler and its workers every
  :data:`DASK_POLL_S` seconds while it waits; a lost scheduler, or no worker for
  :data:`DASK_NO_WORKER_S` seconds, ends the run with :class:`ClusterLost`.
* **Done.**  A finished run keeps its pool for the report and the next run; a command ends every
  pool when it is done (:func:`end_all_pools`), waiting :data:`EXIT_GRACE_S` s at most (Ctrl-C: none).
"""

from __future__ import annotations

import atexit
import concurrent.futures as cf
import contextlib
import math
import os
import re
import shutil
import signal
import tempfile
import time
import weakref
from typing import Any, Callable, Iterator

from dualmech.validation.warning_lines import show_warnings_as_lines

#: How long (s) an interrupted run waits for its running tasks before it ends them.
INTERRUPT_GRACE_S = 2.0
#: How long (s) a finished command waits for its pools' workers to exit before it ends them by a signal.
EXIT_GRACE_S = 10.0
#: How long (s) a worker ended by SIGTERM has before SIGKILL.
KILL_AFTER_S = 2.0
#: How often (s) the Dask backend checks that its scheduler and workers are still there.
DASK_POLL_S = 2.0
#: How long (s) a Dask run waits without any worker before it gives up.
DASK_NO_WORKER_S = 30.0
#: How long (s) to wait for a Dask scheduler to answer at the start.
DASK_CONNECT_S = 30.0
#: How long (s) the results of finished Dask tasks may take to arrive (each poll's; those kept at the end).
DASK_RESULT_S = 30.0
#: A Dask scheduler address: ``tcp://host:port`` (also ``tls://``), or ``host:port``.
ADDRESS = re.compile(r"^(?:(?:tcp|tls)://)?(?:\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9.-]+):\d{1,5}$")


class WorkersLost(RuntimeError):
    """The processes running a run's tasks went away: one line, ``<what>; finished results are kept``.

    ``what`` says what happened without the second clause, for a caller that says itself where the
    results are kept and how to finish (the command line: :mod:`dualmech.cli.errors`).
    """

    def __init__(self, what: str) -> None:
        super().__init__(f"{what}; finished results are kept")
        self.what = what


class ClusterLost(WorkersLost):
    """The Dask scheduler or all its workers went away during a run."""


class WorkerDied(WorkersLost):
    """A worker process of a local pool ended while it ran a task (a signal, the OOM killer)."""


def check_address(address: str) -> str:
    """``address`` if it is a Dask scheduler address, else ValueError naming what is valid."""
    if not isinstance(address, str) or not ADDRESS.match(address.strip()) or not (
            0 < int(address.strip().rsplit(":", 1)[1]) < 65536):
        raise ValueError(f"scheduler: expected an address such as tcp://127.0.0.1:8786, got {address!r}")
    return address.strip()


def worker_init(parent: int) -> None:
    """Pool worker initializer: leave SIGINT to the run, end with it, and exit without a teardown.

    A run killed hard (SIGKILL, an OOM kill) cannot shut its pool down, and idle workers would wait on
    their queue forever.  On Linux the kernel sends SIGTERM to the worker when its parent, the run (pid
    ``parent``, given by it: read here, it was once already the re-parented one), exits
    (``PR_SET_PDEATHSIG``); a parent gone before that request is seen here, and the worker exits (else
    it waited forever, and multiprocessing's resource tracker with it).  The exit: :func:`_leave`.
    """
    show_warnings_as_lines()  # a task's warnings as the command line shows its own
    atexit.register(_leave)  # before any task: the handlers that tasks' libraries add run before it
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    with contextlib.suppress(OSError, AttributeError):  # not Linux: the check below only
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGTERM))  # 1 = PR_SET_PDEATHSIG
    if os.getppid() != parent:  # the parent died before the request took effect
        os._exit(1)


def _leave() -> None:
    """A pool worker's last exit handler: end the process without tearing its interpreter down.

    It runs once the worker has sent its last result and flushed its streams (multiprocessing's own exit
    function runs before the interpreter's exit) and every exit handler registered after
    :func:`worker_init` (a library's, imported by a task) has run.  What is left, freeing every module the
    tasks loaded (MuJoCo, Pinocchio, matplotlib, numba), saves nothing and took 0.4 s at the end of every
    command that used a pool (the main job: 0.44 -> 0.01 s from the pool's end to the command's).  The
    exit code is 0: a pool worker's is 0 whatever its tasks did (their errors are results), unless a
    signal ended it, and then this does not run.
    """
    import sys

    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    os._exit(0)


def execute(task: Callable[..., dict], calls: list[tuple], jobs: int, scheduler: str | None,
            leftovers: list[dict], here: Callable[[tuple], bool] = lambda call: False,
            label: Callable[[tuple], str] = lambda call: "a task") -> Iterator[dict]:
    """Run ``task(*call)`` for every call; yield entries as they finish.

    Tasks that finished but were not yielded when the generator is closed early
    (an interrupt) are appended to ``leftovers``.  With a pool, the calls for which ``here(call)``
    is true run in a thread of this process instead, beside the workers (tasks that are short and
    release the GIL, but whose libraries would cost each worker more to load than to run them).
    A pool's worker that dies ends the run with :class:`WorkerDied`, naming the task it ran by
    ``label(call)`` (``"<case> <engine>"``); a lost Dask cluster with :class:`ClusterLost`.
    """
    if scheduler:
        yield from _on_dask(task, calls, scheduler, leftovers)
    elif jobs <= 1:
        for call in calls:
            yield task(*call)
    else:
        yield from _on_pool(task, calls, jobs, leftovers, here, label)


def process_pool(jobs: int) -> cf.ProcessPoolExecutor:
    """A pool of ``jobs`` fresh worker processes (``spawn``), children of this process.

    Not ``fork``: a process that has run a parallel numba kernel holds threading-layer
    state (OpenMP, workqueue) that a forked child inherits and can deadlock on.  Not
    ``forkserver`` either: its server outlives a killed run.  A spawned worker starts
    from nothing, ends with this process and leaves SIGINT to it (:func:`worker_init`).
    Every pool made here is ended by :func:`end_all_pools`.
    """
    import multiprocessing

    pool = cf.ProcessPoolExecutor(max_workers=jobs, mp_context=multiprocessing.get_context("spawn"),
                                  initializer=worker_init, initargs=(os.getpid(),))
    _POOLS.add(pool)
    return pool


#: Every pool :func:`process_pool` made that is still referenced somewhere and not shut down yet.
_POOLS: weakref.WeakSet[cf.ProcessPoolExecutor] = weakref.WeakSet()
#: What the pools :func:`let_go` shut down left running (:func:`_shut`), for :func:`end_all_pools`.
_LEAVING: list[tuple[list[Any], Any]] = []
_SHARED: dict[int, cf.ProcessPoolExecutor] = {}


def shared_pool(jobs: int) -> cf.ProcessPoolExecutor:
    """This process's pool of ``jobs`` workers (:func:`process_pool`), started at its first use and kept.

    A run and its report use the same workers: they are spawned and import their libraries once.
    A pool that broke or was ended (:func:`end_shared_pool`) is replaced; the workers end with
    this process (or :func:`end_shared_pool`, :func:`end_all_pools`).
    """
    pool = _SHARED.get(jobs)
    if pool is None or getattr(pool, "_broken", False) or getattr(pool, "_shutdown_thread", False):
        pool = _SHARED[jobs] = process_pool(jobs)
    return pool


def end_shared_pool(jobs: int | None = None, *, grace: float = math.inf) -> None:
    """End the shared pool of ``jobs`` workers (default: every shared pool) by :func:`end_pool`."""
    for n in [jobs] if jobs is not None else list(_SHARED):
        pool = _SHARED.pop(n, None)
        if pool is not None:
            end_pool(pool, grace=grace)


def end_all_pools(grace: float = EXIT_GRACE_S) -> None:
    """End every pool of this process (:func:`end_pool`), and the workers of those let go
    (:func:`let_go`): what a command does when it is done.  Their workers get ``grace`` seconds
    together.

    Left to the interpreter's exit, each pool's workers would be joined without a time limit: a
    worker that does not exit (a library's thread that never ends, a full pipe) keeps the command
    from ever exiting, and with it the output still in its buffers.  Interrupted while it waits
    (Ctrl-C), it ends the workers at once and raises the interrupt.
    """
    shut = [*_LEAVING, *(_shut(pool) for pool in list(_POOLS))]
    _SHARED.clear()  # after: a pool that only _SHARED refers to would leave _POOLS with it
    _LEAVING.clear()
    try:
        _end(shut, grace)
    except KeyboardInterrupt:
        _end(shut, 0.0)
        raise


def end_pool(pool: cf.ProcessPoolExecutor, *, grace: float = math.inf) -> None:
    """End ``pool``: tasks not started are cancelled, running ones and the workers' own exit get
    ``grace`` seconds (``0``: none; ``inf``: as long as they take), and every worker still there after
    that is ended by a signal (SIGTERM, then SIGKILL after :data:`KILL_AFTER_S`)."""
    _end([_shut(pool)], grace)


def let_go(pool: cf.ProcessPoolExecutor) -> None:
    """Shut ``pool`` down without waiting (tasks not started are cancelled; its workers finish the
    running ones and exit while this process goes on); :func:`end_all_pools` waits for them."""
    _LEAVING.append(_shut(pool))


def _shut(pool: cf.ProcessPoolExecutor) -> tuple[list[Any], Any]:
    """Shut ``pool`` down without waiting, tasks not started cancelled; its worker processes and its
    manager thread (``shutdown`` forgets both)."""
    _POOLS.discard(pool)
    workers = list((getattr(pool, "_processes", None) or {}).values())
    manager = getattr(pool, "_executor_manager_thread", None)
    pool.shutdown(wait=False, cancel_futures=True)
    return workers, manager


def _end(shut: list[tuple[list[Any], Any]], grace: float) -> None:
    """Wait up to ``grace`` seconds for the workers of the pools ``shut`` (:func:`_shut`) to end, signal
    those left (SIGTERM, then SIGKILL), then let each pool's manager thread finish: it closes the pool's
    pipes (left running into the interpreter's exit, its wake-up pipe was once written after its file
    descriptor had gone: "OSError: [Errno 9] Bad file descriptor" after the main job in CI)."""
    left = _running_after([w for workers, _ in shut for w in workers], grace)
    for proc in left:
        proc.terminate()
    for proc in _running_after(left, KILL_AFTER_S):
        proc.kill()
    for _, manager in shut:
        if manager is not None:
            manager.join(KILL_AFTER_S)


def _running_after(workers: list[Any], seconds: float) -> list[Any]:
    """The processes of ``workers`` still running after waiting up to ``seconds`` (``inf``: until they
    end) for all of them to end (by their sentinels, readable once a process has ended, whichever
    thread reaps it)."""
    import multiprocessing.connection

    deadline = time.monotonic() + seconds
    left = list(workers)
    while left and (remaining := deadline - time.monotonic()) > 0:
        timeout = None if math.isinf(remaining) else remaining
        ready = multiprocessing.connection.wait([p.sentinel for p in left], timeout=timeout)
        left = [p for p in left if p.sentinel not in ready]
    return left


def _succeeded(fut: Any) -> bool:
    return fut.done() and not fut.cancelled() and fut.exception() is None


def _finished(futures: list[Any], handed: set[Any]) -> list[dict]:
    return [f.result() for f in futures if f not in handed and _succeeded(f)]


def _on_pool(
    task: Callable[..., dict], calls: list[tuple], jobs: int, leftovers: list[dict],
    here: Callable[[tuple], bool], label: Callable[[tuple], str]
) -> Iterator[dict]:
    pool = shared_pool(jobs)
    local = cf.ThreadPoolExecutor(max_workers=1, thread_name_prefix="dualmech-task")
    marks = tempfile.mkdtemp(prefix="dualmech-tasks-")  # which worker started which call (_marked)
    futures = [local.submit(task, *call) if here(call) else pool.submit(_marked, marks, i, task, call)
               for i, call in enumerate(calls)]
    handed: set[Any] = set()
    try:
        try:
            for fut in cf.as_completed(futures):
                yield fut.result()
                # only once the caller has come back for more: an entry is stored twice, never lost
                handed.add(fut)
        except cf.process.BrokenProcessPool as err:
            labels = [label(call) for call in calls]
            raise worker_died(pool, err, lambda pid: _running_calls(marks, futures, labels, pid)) from None
    finally:
        if len(handed) < len(futures):  # interrupted: end the workers (a finished run keeps them)
            for fut in futures:
                fut.cancel()
            cf.wait([f for f in futures if not f.cancelled()], timeout=INTERRUPT_GRACE_S)
            leftovers.extend(_finished(futures, handed))
            end_shared_pool(jobs, grace=0.0)  # do not wait any longer
        local.shutdown(wait=False, cancel_futures=True)
        shutil.rmtree(marks, ignore_errors=True)


def _marked(marks: str, index: int, task: Callable[..., dict], call: tuple) -> dict:
    """A pool task: leave the empty file ``<index>.<pid>`` in the folder ``marks`` (this worker runs call
    ``index``), then ``task(*call)``."""
    os.close(os.open(os.path.join(marks, f"{index}.{os.getpid()}"), os.O_WRONLY | os.O_CREAT, 0o600))
    return task(*call)


def worker_died(pool: cf.ProcessPoolExecutor, err: BaseException, doing: Callable[[int], str]) -> WorkerDied:
    """:class:`WorkerDied` for the broken ``pool`` (``err``: its ``BrokenProcessPool``): how its worker ended
    and ``doing(pid)``, what it was doing (``" while running ..."`` or ``""``).  The pool ends the other
    workers by SIGTERM: the first to die is the one whose end was not that SIGTERM, if there is one."""
    workers = list((getattr(pool, "_processes", None) or {}).values())
    deadline = time.monotonic() + KILL_AFTER_S  # the pool is ending the others: let their exit codes show
    while any(p.exitcode is None for p in workers) and time.monotonic() < deadline:
        time.sleep(0.01)
    ended = [p for p in workers if p.exitcode not in (None, 0)]
    if not ended:  # no worker died: a result that could not be received, ...
        return WorkerDied(f"the worker processes failed ({type(err).__name__}: {str(err)[:200]})")
    dead = next((p for p in ended if p.exitcode != -signal.SIGTERM), ended[0])
    code = dead.exitcode
    how = f"signal {-code}, {signal.Signals(-code).name}" if code < 0 else f"exit code {code}"
    return WorkerDied(f"a worker process died ({how}){doing(dead.pid)}")


def _running_calls(marks: str, futures: list[Any], labels: list[str], pid: int) -> str:
    """``" while running <labels>"`` of the calls the worker ``pid`` started (the files of :func:`_marked`)
    and did not finish (``futures[i]``, ``labels[i]``: call ``i``'s); ``""`` if none."""
    ran = [labels[int(i)] for i, _, worker in (name.partition(".") for name in os.listdir(marks))
           if worker == str(pid) and not _succeeded(futures[int(i)])]
    return f" while running {', '.join(ran)}" if ran else ""


def _on_dask(task: Callable[..., dict], calls: list[tuple], scheduler: str,
             leftovers: list[dict]) -> Iterator[dict]:
    try:
        from distributed import Client, wait
    except ImportError:
        raise ValueError("scheduler: Dask distributed is not installed (pip install "
                         "'dask[distributed]')") from None
    address = check_address(scheduler)
    try:
        client = Client(address, timeout=f"{DASK_CONNECT_S:g}s")
    except (OSError, TimeoutError) as err:
        raise ValueError(f"scheduler: cannot reach {address!r} ({type(err).__name__})") from None
    futures = [client.submit(task, *call, pure=False) for call in calls]
    handed: set[Any] = set()
    try:
        pending = set(futures)
        alone_since = None
        while pending:
            try:
                done, pending = wait(pending, timeout=DASK_POLL_S, return_when="FIRST_COMPLETED")
            except TimeoutError:  # nothing finished within the poll interval
                done = set()
            except Exception as err:  # futures cancelled by a lost scheduler, a killed worker, ...
                raise ClusterLost(f"Dask: the cluster at {address} failed ({type(err).__name__})") from None
            try:  # run_task never raises: an error here is the cluster's
                entries = [(fut, fut.result(timeout=DASK_RESULT_S)) for fut in done]
            except Exception as err:  # a finished result its lost worker can no longer send, ...
                raise ClusterLost(f"Dask: the cluster at {address} failed ({type(err).__name__}, fetching a "
                                  "result)") from None
            for fut, entry in entries:
                yield entry
                handed.add(fut)
            alone_since = _check_cluster(client, alone_since)
    finally:
        leftovers.extend(_fetched(futures, handed, DASK_RESULT_S))
        with contextlib.suppress(Exception):  # best-effort clean-up of a cluster that may be gone
            client.cancel(futures)
            client.close(timeout=5)


def _fetched(futures: list[Any], handed: set[Any], seconds: float) -> list[dict]:
    """The results of the Dask ``futures`` that finished and were not handed out, fetched within
    ``seconds`` in all: a result whose worker is gone may never arrive (seen with distributed
    2024.1: ``result()`` of a finished future waited forever after the cluster lost its workers)."""
    deadline = time.monotonic() + seconds
    out = []
    for f in futures:
        if f in handed or f.status != "finished":
            continue
        with contextlib.suppress(Exception):  # not fetched in time, or lost with its worker
            out.append(f.result(timeout=max(deadline - time.monotonic(), 0.1)))
    return out


def _check_cluster(client: Any, alone_since: float | None) -> float | None:
    """Raise :class:`ClusterLost` if the scheduler is gone or no worker has been there for too long."""
    try:
        n_workers = len(client.nthreads()) if client.status == "running" else -1
    except Exception:  # any failure to talk to the scheduler means it is gone
        n_workers = -1
    if n_workers < 0:
        raise ClusterLost(f"Dask: lost the scheduler {client.scheduler.address}")
    if n_workers > 0:
        return None
    now = time.monotonic()
    if alone_since is not None and now - alone_since > DASK_NO_WORKER_S:
        raise ClusterLost(f"Dask: no worker for {DASK_NO_WORKER_S:g} s")
    return alone_since if alone_since is not None else now
