"""The one progress display of the command line (:mod:`dualmech.cli.progress`), in both of its modes.

Into a file or a pipe: plain lines, one per update at a modest rate (the first update, each tenth, a
heartbeat after a silence, the end), with no terminal control codes and no cut cells.  On a terminal: a live
rich display.  The kernel's compile (its log records) is shown as a notice, ticks and a closing line.
"""

from __future__ import annotations

import io
import logging
import re
import time

import pytest

from dualmech.cli import progress as pm


class _Clock:
    """A clock the test advances."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def test_plain_lines_at_each_tenth_and_the_end() -> None:
    out, clock = io.StringIO(), _Clock()
    with pm.progress("tolerance: Monte Carlo", unit="chunks", stream=out, terminal=False, clock=clock) as bar:
        for k in range(1, 201):
            clock.now += 0.1
            bar(k, 200, f"chunk {k}")
    lines = out.getvalue().splitlines()
    assert lines[0] == ("tolerance: Monte Carlo: 1 of 200 chunks (0 %), 0:00 elapsed, about 0:20 left "
                        "[chunk 1]")
    assert len(lines) == 1 + 9 + 1  # the first update, 10 % .. 90 %, done
    assert lines[1] == ("tolerance: Monte Carlo: 20 of 200 chunks (10 %), 0:02 elapsed, about 0:18 left "
                        "[chunk 20]")
    assert lines[-1] == "tolerance: Monte Carlo: done, 200 of 200 chunks in 0:20"
    assert "\x1b" not in out.getvalue() and "\r" not in out.getvalue() and "…" not in out.getvalue()


def test_plain_heartbeat_without_a_total() -> None:
    """A task whose total is not known (or that stalls) says something every HEARTBEAT seconds."""
    out, clock = io.StringIO(), _Clock()
    with pm.progress("simulate x", unit="s", stream=out, terminal=False, clock=clock) as bar:
        for k in range(100):
            clock.now += 1.0
            bar(0.01 * k, None, "")
    lines = out.getvalue().splitlines()
    assert len(lines) == 1 + 100 // int(pm.HEARTBEAT) + 1
    assert lines[:2] == ["simulate x: 0 s, 0:01 elapsed", "simulate x: 0.3 s, 0:31 elapsed"]


def test_float_progress_and_a_stopped_task() -> None:
    out, clock = io.StringIO(), _Clock()
    with pytest.raises(KeyboardInterrupt):
        with pm.progress("simulate x", unit="s", stream=out, terminal=False, clock=clock) as bar:
            clock.now = 3.0
            bar(0.25, 2.0, "")
            raise KeyboardInterrupt
    assert out.getvalue().splitlines() == ["simulate x: 0.25 of 2 s (12 %), 0:03 elapsed, about 0:21 left",
                                           "simulate x: stopped at 0.25 of 2 s"]


def test_a_task_stopped_before_its_first_update_prints_nothing() -> None:
    """Bad input is found before any work: its error stays the one line on stderr."""
    out = io.StringIO()
    with pytest.raises(ValueError):
        with pm.progress("simulate x", unit="s", stream=out, terminal=False):
            raise ValueError("duration: ...")
    assert out.getvalue() == ""


def test_terminal_is_a_live_display() -> None:
    out = io.StringIO()
    with pm.progress("validate", unit="results", stream=out, terminal=True) as bar:
        for k in range(1, 5):
            bar(k, 4, f"case {k}")
    text = out.getvalue()
    assert "\x1b[" in text  # redrawn in place
    assert "validate" in text and "4 of 4 results" in text


def test_tasks_share_one_display() -> None:
    """A second task (the kernel's compile during a run) joins the display of the first."""
    out = io.StringIO()
    with pm.progress("run", stream=out, terminal=False) as outer:
        with pm.progress("inner", stream=io.StringIO(), terminal=True) as inner:
            inner(1, 2, "")
        outer(1, 1, "")
    lines = out.getvalue().splitlines()
    assert lines == ["inner: 1 of 2 (50 %), 0:00 elapsed, about 0:00 left", "inner: done, 1 of 2 in 0:00",
                     "run: done, 1 of 1 in 0:00"]
    assert pm._BOARD is None


def _compile_record(kind: str, message: str, compiled: int = 0) -> logging.LogRecord:
    from dualmech.core.kernel.compiles import CompileEvent

    record = logging.LogRecord("dualmech.kernel", logging.INFO, __file__, 0, message, None, None)
    record.compile = CompileEvent(kind, "dualmech.core.kernel.loop_nb.evaluate", compiled, 1.0)
    return record


def test_the_kernel_compile_is_a_notice_and_a_closing_line(capsys: pytest.CaptureFixture) -> None:
    view = pm._CompileView()
    view.emit(_compile_record("start", "compiling the dual-number kernel once (about 3 min ...)"))
    view.emit(_compile_record("function", "compiled 1 functions", 1))
    view.emit(_compile_record("end", "compiled the dual-number kernel in 1 s (1 functions)", 1))
    lines = capsys.readouterr().err.splitlines()
    assert lines[0] == "dualmech: compiling the dual-number kernel once (about 3 min ...)"
    assert lines[-1] == "dualmech: compiled the dual-number kernel in 1 s (1 functions)"
    assert all(not re.search(r"\x1b|\r", line) for line in lines)


def test_show_kernel_compiles_installs_one_handler() -> None:
    pm.show_kernel_compiles()
    pm.show_kernel_compiles()
    log = logging.getLogger("dualmech.kernel")
    assert log.handlers.count(pm._VIEW) == 1 and log.isEnabledFor(logging.INFO)


def test_the_compile_ticks_in_cpu_seconds(monkeypatch: pytest.MonkeyPatch,
                                          capsys: pytest.CaptureFixture) -> None:
    """The compile names no function for minutes: its task counts CPU seconds of the expected total, on a
    ticker (here every 10 ms, and CPU time made to pass 20 s a tick)."""
    ticks: list[float] = []

    def process_time() -> float:
        ticks.append(20.0 * len(ticks))
        return ticks[-1]

    monkeypatch.setattr(pm, "TICK", 0.01)
    monkeypatch.setattr(pm.time, "process_time", process_time)
    view = pm._CompileView()
    view.emit(_compile_record("start", "compiling ..."))
    deadline = time.monotonic() + 30.0
    while len(ticks) < 12 and time.monotonic() < deadline:  # past the expected 175 s
        time.sleep(0.01)
    view.emit(_compile_record("end", "compiled ...", 31))
    lines = capsys.readouterr().err.splitlines()
    head = "compiling the dual-number kernel: "
    done = [int(line[len(head):].split()[0]) for line in lines if line.startswith(head)]
    assert lines[1].startswith(f"{head}20 of 175 CPU s (11 %), ")  # a line at each tenth
    assert done == sorted(done) and len(done) <= 10 and done[-1] >= 160
    assert max(done) <= 173  # capped at 99 % of the expected until the end
    assert lines[-1] == "dualmech: compiled ..."
