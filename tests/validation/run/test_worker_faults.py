"""Pool workers and faults (issue 31): none outlives its parent, and a dead worker ends a run with one line.

Why: SIGKILL to ``validate`` while its pool started left the two workers and multiprocessing's resource
tracker running, re-parented, 15 s and more later; a killed worker gave ``internal error:
BrokenProcessPool``.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import pytest

from dualmech.validation.matrix import load_matrix
from dualmech.validation.run import executors
from dualmech.validation.run.executors import WorkerDied
from dualmech.validation.run.runner import load_entries, run_matrix
from tests.validation.test_validate import FAKE_REGISTRY, FAKES, ROOT

#: Seconds a pool's processes may outlive their killed parent: the issue's one second, plus the time a
#: busy shared machine may take to run a spawned worker's start up to its parent check.
OUTLIVE_S = 2.0
#: A matrix of 40 cases on the in-house engine (in a thread) and MuJoCo (in the pool's workers): a run of
#: a few minutes on two workers, long enough to be interrupted or to lose a worker.
LONG_MATRIX = ('name = "m"\nbase = "thesis/ideal"\nengines = ["dualmech", "mujoco"]\nreference = "dualmech"\n'
               'set = { "motion.angles_deg" = { start = 0.0, stop = 360.0, step = 0.1 } }\n'
               '[[sweep]]\nname = "a4"\ngrid = { "geometry.slider_offset" = ['
               + ", ".join(f"{10 + i}.0" for i in range(40)) + "] }\n")
#: Seconds the program below may take to reach the moment it is killed at (imports, spawned workers, and a
#: cold compile of the kernel first if its cache is stale: ~165-175 s on the 2-core machine with a core to
#: itself, over 240 s once while a full ``-n 2`` run kept the other core busy: "no worker was started").
#: A bound on a hang, not a measured speed: these tests time what follows the moment, not the start.
START_S = 900.0


def _group(pgid: int) -> list[int]:
    """The processes of the process group ``pgid`` still running (zombies are ended), from /proc."""
    alive = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
        except OSError:  # ended meanwhile
            continue
        fields = stat[stat.rindex(")") + 2:].split()  # state, ppid, pgrp, ...
        if int(fields[2]) == pgid and fields[0] != "Z":
            alive.append(int(entry.name))
    return alive


def _pool_processes(pgid: int) -> list[int]:
    """The processes of :func:`_group` that multiprocessing started (its spawned workers and its resource
    tracker), not a short-lived tool the run calls (``platform.processor()`` runs ``uname -p``)."""
    found = []
    for pid in _group(pgid):
        try:
            if b"multiprocessing" in Path(f"/proc/{pid}/cmdline").read_bytes():
                found.append(pid)
        except OSError:  # ended meanwhile
            continue
    return found


def _program(moment: str) -> str:
    """A program that starts a pool of two workers (as a run does) and prints ``ready`` at ``moment``:
    ``start`` as soon as the workers are being spawned, ``mid`` once both run a task, ``report`` once a
    figure-like task runs in a pool made after a first one was ended."""
    return textwrap.dedent(f"""
        import sys, time
        from dualmech.validation.run import executors
        if __name__ == "__main__":
            moment = {moment!r}
            pool = executors.shared_pool(2)
            if moment == "report":
                pool.submit(time.sleep, 0).result()
                executors.end_shared_pool(2)
                pool = executors.shared_pool(2)
            futures = [pool.submit(time.sleep, 30) for _ in range(4)]
            if moment != "start":
                while sum(f.running() for f in futures) < 2 or len(pool._processes) < 2:
                    time.sleep(0.01)
                time.sleep(0.5)
            print("ready", flush=True)
            time.sleep(60)
    """)


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads the process table from /proc (Linux)")
@pytest.mark.parametrize("moment", ["start", "mid", "report"])
@pytest.mark.parametrize("how", [signal.SIGKILL, signal.SIGTERM])
def test_no_pool_process_outlives_its_killed_parent(tmp_path, moment, how):
    script = tmp_path / "program.py"
    script.write_text(_program(moment))
    proc = subprocess.Popen([sys.executable, str(script)], cwd=ROOT, stdout=subprocess.PIPE, text=True,
                            env=dict(os.environ, PYTHONPATH=str(ROOT)), start_new_session=True)
    ready = threading.Timer(START_S, proc.kill)
    ready.start()
    assert proc.stdout.readline().strip() == "ready"
    ready.cancel()
    assert not _gone_after_kill(proc, how)


def _gone_after_kill(proc: subprocess.Popen, how: int) -> list[bytes]:
    """Send ``how`` to ``proc`` (a process group's leader); the command lines of its group still running
    :data:`OUTLIVE_S` seconds after it ended (the group is then killed)."""
    try:
        os.kill(proc.pid, how)
        proc.wait(timeout=10)
        deadline = time.monotonic() + OUTLIVE_S
        while _group(proc.pid) and time.monotonic() < deadline:
            time.sleep(0.02)
        return [Path(f"/proc/{pid}/cmdline").read_bytes()[:200] for pid in _group(proc.pid)]
    finally:
        for pid in _group(proc.pid):
            os.kill(pid, signal.SIGKILL)
        proc.kill()


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads the process table from /proc (Linux)")
@pytest.mark.parametrize("after", [0.0, 0.3])
def test_no_worker_outlives_a_validate_killed_while_its_pool_starts(tmp_path, after):
    """The issue's attack on the installed command: SIGKILL once its first worker is being spawned (or
    0.3 s later).  The workers also must not spend their first second importing the command line."""
    matrix = tmp_path / "m.toml"
    matrix.write_text(LONG_MATRIX)
    command = Path(sys.executable).with_name("dualmech")
    args = [str(command), "validate", str(matrix), "-o", str(tmp_path / "run"), "--jobs", "2"]
    proc = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True)
    deadline = time.monotonic() + START_S
    while not _pool_processes(proc.pid) and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.005)
    time.sleep(after)
    assert proc.poll() is None and _pool_processes(proc.pid), "no worker was started"
    assert not _gone_after_kill(proc, signal.SIGKILL)


def test_a_killed_worker_ends_the_run_with_one_line_and_resume_finishes_it(small, tmp_path, monkeypatch):
    out, marks = tmp_path / "run", tmp_path / "marks"
    marks.mkdir()
    monkeypatch.setenv("MATRIX_FAKES_DELAY", "0.3")
    monkeypatch.setenv("MATRIX_FAKES_MARKS", str(marks))
    slow = {e: f"{FAKES}:solve_case_marked_{e}" for e in FAKE_REGISTRY}
    executors.end_shared_pool()

    def kill_a_worker() -> None:
        deadline = time.monotonic() + START_S
        while len(list(marks.iterdir())) < 3 and time.monotonic() < deadline:
            time.sleep(0.01)
        os.kill(next(iter(executors._SHARED[2]._processes)), signal.SIGKILL)

    killer = threading.Thread(target=kill_a_worker)
    killer.start()
    with pytest.raises(WorkerDied) as err:
        run_matrix(load_matrix(small), out, jobs=2, registry=slow)
    killer.join()
    message = str(err.value)
    # killed while it runs a task, or (on a busy machine) just between two: then no task is named
    named = re.fullmatch(r"a worker process died \(signal 9, SIGKILL\)(?: while running (\S+) (\S+))?; "
                         r"finished results are kept", message)
    assert named, message
    lost = {f"{named[1]}--{named[2]}"} if named[1] else set()
    matrix = load_matrix(small)
    stored = {f"{cid}--{e}" for cid, per in load_entries(out, matrix).items() for e in per}
    finished = {p.name for p in marks.iterdir()}
    assert finished - lost <= stored, sorted(finished - stored)
    assert not lost & stored

    monkeypatch.setenv("MATRIX_FAKES_DELAY", "0")
    outcome = run_matrix(matrix, out, jobs=2, registry=slow, resume=True)
    assert outcome.skipped == len(stored)
    assert outcome.ran + outcome.skipped == len(matrix.cases) * len(matrix.engines)


def test_the_command_line_says_a_worker_died_in_one_line_and_exits_4(tmp_path):
    import click
    from click.testing import CliRunner

    from dualmech.cli.errors import on_interrupt, one_line_errors

    @click.command()
    @one_line_errors
    def cmd():
        on_interrupt("finished results are kept in runs/x; re-run with --resume to finish")
        raise WorkerDied("a worker process died (signal 9, SIGKILL) while running c1 mujoco")

    res = CliRunner().invoke(cmd, [])
    assert res.exit_code == 4
    assert res.output == ("dualmech: error: a worker process died (signal 9, SIGKILL) while running c1 "
                          "mujoco; finished results are kept in runs/x; re-run with --resume to finish\n")


def test_spawned_workers_of_the_command_line_do_not_import_it(monkeypatch):
    """The console script's main module (it holds ``main``) is declared ``dualmech.cli.__main__``, which
    multiprocessing's spawn does not import in a worker; another program's main module is left alone."""
    import multiprocessing.spawn
    import types

    from dualmech import cli

    script = types.ModuleType("__main__")
    script.__file__, script.main = "/usr/bin/dualmech", cli.main
    monkeypatch.setitem(sys.modules, "__main__", script)
    cli.spawn_without_the_command_line()
    data = multiprocessing.spawn.get_preparation_data("worker")
    assert "init_main_from_path" not in data and data["init_main_from_name"] == "dualmech.cli.__main__"

    program = types.ModuleType("__main__")
    program.__file__ = "/home/user/study.py"
    monkeypatch.setitem(sys.modules, "__main__", program)
    cli.spawn_without_the_command_line()
    assert multiprocessing.spawn.get_preparation_data("worker")["init_main_from_path"] == program.__file__


def _workers(pid: int) -> list[int]:
    """The spawned pool workers among the children of ``pid`` (not the resource tracker), from /proc."""
    found = []
    for entry in Path("/proc").iterdir():
        try:
            stat = (entry / "stat").read_text() if entry.name.isdigit() else ""
            spawned = b"spawn_main" in (entry / "cmdline").read_bytes() if stat else False
        except OSError:  # ended meanwhile
            continue
        if spawned and int(stat[stat.rindex(")") + 2:].split()[1]) == pid:
            found.append(int(entry.name))
    return found


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads the process table from /proc (Linux)")
def test_validate_whose_worker_is_killed_says_so_in_one_line_and_exits_4(tmp_path):
    matrix, out = tmp_path / "m.toml", tmp_path / "run"
    matrix.write_text(LONG_MATRIX)
    command = Path(sys.executable).with_name("dualmech")
    proc = subprocess.Popen([str(command), "validate", str(matrix), "-o", str(out), "--jobs", "2"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + START_S
        while time.monotonic() < deadline and proc.poll() is None and not (
                (out / "cases").is_dir() and len(list((out / "cases").glob("*.json"))) >= 2):
            time.sleep(0.01)
        assert proc.poll() is None, proc.communicate()[1]
        os.kill(_workers(proc.pid)[0], signal.SIGKILL)
        _, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    lines = [ln for ln in err.splitlines() if ln.startswith("dualmech: ")]  # not the progress lines
    assert proc.returncode == 4 and len(lines) == 1 and "Traceback" not in err, err
    kept = f"finished results are kept in {out}; re-run with --resume to finish"
    assert re.fullmatch(r"dualmech: error: a worker process died \(signal 9, SIGKILL\)( while running \S+ "
                        rf"mujoco)?; {re.escape(kept)}", lines[0]), lines[0]


def test_a_worker_killed_while_the_report_draws_its_figures_is_one_line():
    """The report's figures are drawn in the shared pool: a killed worker there is a :class:`WorkerDied`
    too (exit 4 at the command line), not ``internal error: BrokenProcessPool``."""
    from dualmech.validation.report.figures import PendingFigures

    executors.end_shared_pool()
    figures = PendingFigures(jobs=2)
    pool = executors._SHARED[2]
    drawing = pool.submit(time.sleep, 60)  # a figure that takes long
    figures.specs, figures._rendered = [None], [drawing]
    deadline = time.monotonic() + START_S
    while not (drawing.running() and pool._processes) and time.monotonic() < deadline:
        time.sleep(0.01)
    os.kill(next(iter(pool._processes)), signal.SIGKILL)
    with pytest.raises(WorkerDied, match=r"^a worker process died \(signal 9, SIGKILL\) while drawing the "
                                         r"report's figures; finished results are kept$"):
        figures.collect()
    executors.end_shared_pool()


def test_a_killed_figure_worker_of_a_tolerance_study_is_one_line():
    """The tolerance study draws its figures in a worker of its own (``FigureDrawing``): killed, it is a
    :class:`WorkerDied` too (found by hand: killing it gave ``BrokenProcessPool``)."""
    from dualmech.validation.tolerance.report import FigureDrawing

    drawing = FigureDrawing(parallel=True)
    drawing.warm()
    try:
        drawing._pending = drawing._pool.submit(time.sleep, 60)  # figures that take long
        deadline = time.monotonic() + START_S
        while not (drawing._pending.running() and drawing._pool._processes) and time.monotonic() < deadline:
            time.sleep(0.01)
        os.kill(next(iter(drawing._pool._processes)), signal.SIGKILL)
        died = r"^a worker process died \(signal 9, SIGKILL\) while drawing the study's figures; finished "
        with pytest.raises(WorkerDied, match=died + "results are kept$"):
            drawing.collect()
    finally:
        drawing.close()
