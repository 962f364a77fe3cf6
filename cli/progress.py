"""Progress of long work, on stderr, for every command: this module alone decides how it is shown.

The library reports progress through callbacks, ``progress(done, total, label)`` (``total`` ``None``
while unknown; :data:`ProgressCallback`), and logs the kernel's one-time compile
(:mod:`dualmech.core.kernel.compiles`); the commands show both with :func:`progress` and
:func:`show_kernel_compiles`.

* On a terminal: a live bar per task (done of total, elapsed, time left, the last item), redrawn at
  most every :data:`REDRAW` seconds.
* Into a file or a pipe (a log, CI): plain lines, one per update at a modest rate: at its first
  update, at each :data:`STEP` of its total, after :data:`HEARTBEAT` seconds without a line, and when
  it ends (a task stopped by bad input before its first update prints nothing: the error is the one
  line).  Never the terminal's redrawn bars, which a log keeps cut to its width.

Every task of a process shares one display (:class:`_Board`), so the kernel's compile shows beside
the run that needed it.
"""

from __future__ import annotations

import contextlib
import logging
import math
import sys
import threading
import time
from dataclasses import dataclass, field
from typing import IO, Callable, Iterator

#: ``progress(done, total, label)``: ``done`` of ``total`` (``None``: not known), the item last done.
ProgressCallback = Callable[[float, "float | None", str], None]
#: Plain lines: one at each this fraction of the total ...
STEP = 0.1
#: ... or after this many seconds without one.
HEARTBEAT = 30.0
#: On a terminal: seconds between two redraws at least.
REDRAW = 0.1
#: Seconds between two ticks of a task whose updates may stop for minutes (the kernel's compile).
TICK = 1.0


def _clock_text(seconds: float) -> str:
    """``m:ss`` (``h:mm:ss`` from an hour)."""
    s = int(round(seconds))
    h, rest = divmod(s, 3600)
    return f"{h}:{rest // 60:02d}:{rest % 60:02d}" if h else f"{rest // 60}:{rest % 60:02d}"


def _number(x: float) -> str:
    return f"{int(x):,}" if float(x).is_integer() else f"{x:.3g}"


@dataclass
class _Task:
    """One line of progress and what it has shown."""

    description: str
    unit: str
    start: float
    done: float = 0.0
    total: float | None = None
    label: str = ""
    shown_step: int = 0
    shown_at: float = 0.0
    rich_id: int | None = field(default=None)
    shown: bool = False

    def count(self) -> str:
        """``12 of 40 chunks`` (``12 chunks`` while the total is not known)."""
        unit = f" {self.unit}" if self.unit else ""
        if self.total is None:
            return f"{_number(self.done)}{unit}"
        return f"{_number(self.done)} of {_number(self.total)}{unit}"

    def line(self, now: float) -> str:
        """The plain line of the task now: count, share, elapsed, time left, last item."""
        elapsed = now - self.start
        parts = [self.count()]
        if self.total:
            share = min(self.done / self.total, 1.0)
            parts[0] += f" ({100 * share:.0f} %)"
        parts.append(f"{_clock_text(elapsed)} elapsed")
        if self.total and 0 < self.done < self.total:
            parts.append(f"about {_clock_text(elapsed * (self.total - self.done) / self.done)} left")
        label = f" [{self.label}]" if self.label else ""
        return f"{self.description}: {', '.join(parts)}{label}"


class _Board:
    """The display of this process's tasks: a live rich display on a terminal, plain lines otherwise."""

    def __init__(self, stream: IO[str], terminal: bool, clock: Callable[[], float]) -> None:
        self.stream, self.terminal, self.clock = stream, terminal, clock
        self.lock = threading.RLock()
        self.users = 0
        self.live = None
        self.drawn_at = -math.inf
        if terminal:
            from rich.console import Console
            from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

            console = Console(file=stream, force_terminal=True)
            columns = (TextColumn("{task.description}"), BarColumn(), TextColumn("{task.fields[count]}"),
                       TimeElapsedColumn(), TimeRemainingColumn(), TextColumn("{task.fields[label]}"))
            self.live = Progress(*columns, console=console, auto_refresh=False, transient=False)
            self.live.start()

    def note(self, message: str) -> None:
        """One line above the tasks."""
        with self.lock:
            if self.live is not None:
                self.live.console.print(message, markup=False, highlight=False)
            else:
                self._write(message)

    def _write(self, line: str) -> None:
        self.stream.write(line + "\n")
        self.stream.flush()

    def add(self, description: str, unit: str, first_line: str | None = None) -> _Task:
        """A new task, shown from its first update (plain) or at once (a terminal); ``first_line``: a line
        shown now (above the tasks on a terminal)."""
        with self.lock:
            task = _Task(description, unit, self.clock())
            task.shown_at = task.start
            if self.live is not None:
                if first_line:
                    self.note(first_line)
                task.rich_id = self.live.add_task(description, total=None, count="", label="")
                self._draw(force=True)
            elif first_line:
                self._write(first_line)
                task.shown = True
            return task

    def update(self, task: _Task, done: float, total: float | None, label: str) -> None:
        with self.lock:
            task.done, task.total, task.label = float(done), None if total is None else float(total), label
            now = self.clock()
            if self.live is not None:
                self.live.update(task.rich_id, completed=task.done, total=task.total, count=task.count(),
                                 label=label)
                self._draw(force=task.total is not None and task.done >= task.total)
                return
            step = int(task.done / task.total / STEP + 1e-9) if task.total else 0
            if not task.shown or step > task.shown_step or now - task.shown_at >= HEARTBEAT:
                if not (task.total and task.done >= task.total):  # the end has its own line
                    self._write(task.line(now))
                task.shown, task.shown_step, task.shown_at = True, max(step, task.shown_step), now

    def finish(self, task: _Task, message: str | None) -> None:
        with self.lock:
            if self.live is not None:
                self.live.update(task.rich_id, count=task.count(), label="")
                if task.total is None:  # the bar ends full rather than pulsing
                    self.live.update(task.rich_id, total=max(task.done, 1.0), completed=max(task.done, 1.0))
                self._draw(force=True)
                if message:
                    self.note(message)
            elif task.shown:  # a task that reported nothing (bad input found first) leaves no line
                self._write(message or f"{task.description}: done, {task.count()} in "
                                       f"{_clock_text(self.clock() - task.start)}")

    def _draw(self, force: bool = False) -> None:
        now = self.clock()
        if force or now - self.drawn_at >= REDRAW:
            self.live.refresh()
            self.drawn_at = now

    def close(self) -> None:
        if self.live is not None:
            self.live.stop()


_BOARD: _Board | None = None
_BOARD_LOCK = threading.Lock()


@contextlib.contextmanager
def _board(stream: IO[str] | None, terminal: bool | None,
           clock: Callable[[], float] = time.monotonic) -> Iterator[_Board]:
    """The process's display, made at the first task (on ``stream``, default the current ``sys.stderr``;
    ``terminal``: default whether it is one) and ended after the last."""
    global _BOARD
    with _BOARD_LOCK:
        if _BOARD is None:
            out = sys.stderr if stream is None else stream
            live = bool(getattr(out, "isatty", lambda: False)()) if terminal is None else terminal
            _BOARD = _Board(out, live, clock)
        board = _BOARD
        board.users += 1
    try:
        yield board
    finally:
        with _BOARD_LOCK:
            board.users -= 1
            if board.users == 0:
                board.close()
                _BOARD = None


@contextlib.contextmanager
def progress(description: str, *, unit: str = "", stream: IO[str] | None = None,
             terminal: bool | None = None, clock: Callable[[], float] = time.monotonic,
             end: str | None = None) -> Iterator[ProgressCallback]:
    """Show one task's progress while inside; yields its :data:`ProgressCallback`.

    Parameters
    ----------
    description : str
        What is being done (``"tolerance: Monte Carlo"``).
    unit : str
        What is counted (``"chunks"``, ``"s"`` of simulated time); empty: items.
    stream, terminal, clock
        Where and how (default: ``sys.stderr``, a live display if it is a terminal; the time source).
        Ignored when another task is already shown: every task shares that display.
    end : str, optional
        The line shown when the task ends (plain: default ``"<description>: done, <count> in <time>"``).
    """
    with _board(stream, terminal, clock) as board:
        task = board.add(description, unit)
        ok = False
        try:
            yield lambda done, total, label="": board.update(task, done, total, label)
            ok = True
        finally:
            board.finish(task, end if ok else f"{description}: stopped at {task.count()}")


def note(message: str) -> None:
    """One line on stderr, above the tasks shown (if any): an item's result among the progress."""
    with _board(None, None) as board:
        board.note(message)


class _CompileView(logging.Handler):
    """The kernel's compile (:class:`~dualmech.core.kernel.compiles.CompileEvent` records) as a notice, a
    task and a closing line.  The compile names no function for minutes, so the task counts this process's
    CPU seconds against the compile's expected total (one core compiles; capped at 99 % until it ends), on
    a ticker every :data:`TICK` seconds; its label is the function compiled last."""

    def __init__(self) -> None:
        super().__init__(logging.INFO)
        #: while a compile is shown: its display's hold, the display, the task, the ticker's stop and thread
        self._shown: tuple[contextlib.ExitStack, _Board, _Task, threading.Event, threading.Thread] | None
        self._shown = None

    def emit(self, record: logging.LogRecord) -> None:
        ev = getattr(record, "compile", None)
        if ev is None:
            return
        if ev.kind == "start" and self._shown is None:
            stack = contextlib.ExitStack()
            board = stack.enter_context(_board(None, None))
            task = board.add("compiling the dual-number kernel", "CPU s",
                             first_line=f"dualmech: {record.getMessage()}")
            stop = threading.Event()
            ticker = threading.Thread(target=self._tick, args=(board, task, stop, ev.expected_cpu),
                                      daemon=True, name="dualmech-compile-progress")
            ticker.start()
            self._shown = (stack, board, task, stop, ticker)
        elif ev.kind == "function" and self._shown is not None:
            _, board, task, _, _ = self._shown
            board.update(task, task.done, task.total, ".".join(ev.function.split(".")[-2:]))
        elif ev.kind == "end" and self._shown is not None:
            (stack, board, task, stop, ticker), self._shown = self._shown, None
            stop.set()
            ticker.join()
            board.finish(task, f"dualmech: {record.getMessage()}")
            stack.close()

    @staticmethod
    def _tick(board: _Board, task: _Task, stop: threading.Event, expected: float) -> None:
        start = time.process_time()
        while not stop.wait(TICK):
            board.update(task, round(min(time.process_time() - start, 0.99 * expected)), expected, task.label)


_VIEW = _CompileView()


def show_kernel_compiles() -> None:
    """Show the kernel's compiles (a cold numba cache) on stderr from now on: a one-line notice, progress
    while it lasts, a line when done.  Cheap (no numba import); once per process however often called."""
    log = logging.getLogger("dualmech.kernel")  # dualmech.core.kernel.compiles.LOG, not imported here
    if _VIEW not in log.handlers:
        log.addHandler(_VIEW)
        log.setLevel(logging.INFO)
