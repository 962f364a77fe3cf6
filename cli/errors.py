"""The command line's rules for errors: one line on stderr, never a traceback.

* Bad input (a ``ValueError`` or ``OSError`` from the library): ``dualmech: error: <line>``
  and exit code :data:`EXIT_BAD_INPUT` (2).
* Anything else unexpected: ``dualmech: internal error: <type>: <line>; traceback in <file>``
  and exit code :data:`EXIT_INTERNAL` (70, ``EX_SOFTWARE`` of BSD ``sysexits.h``); the full
  traceback goes to a log file in the command's output folder when it is known and
  exists, else to a new file in the system's temporary folder.
* Interrupted (Ctrl-C: ``KeyboardInterrupt``, or click's ``Abort``): ``dualmech: interrupted; <note>``
  and exit code :data:`~dualmech.validation.exit_codes.EXIT_INTERRUPTED` (130), never click's
  "Aborted!" (exit 1, which ``tolerance`` and ``validate`` use for a FAIL).  The note says what is kept:
  the command's own (:func:`on_interrupt`: a run folder's finished results and how to finish), else for
  a command with an output file (``-o``) that no partial file is left there (every writer is atomic:
  :mod:`dualmech.core.files`).
* The workers running a command's tasks lost (a pool's worker killed, a Dask cluster gone:
  :class:`~dualmech.validation.run.executors.WorkersLost`): ``dualmech: error: <what>; <note>`` and exit code
  :data:`~dualmech.validation.exit_codes.EXIT_WORKERS_LOST` (4).
* click's own exceptions (usage errors, ``--help``, exits) pass through untouched.

``<line>`` is the first line of the exception's message, cut to :data:`MAX_LINE_CHARS`
characters, so a message holding a multi-line array dump or a huge number stays one
readable line.
"""

from __future__ import annotations

import _thread
import contextlib
import functools
import os
import sys
import tempfile
import threading
import time
import traceback
from pathlib import Path
from typing import Callable, Iterator

import click
import numpy as np

from dualmech.validation.exit_codes import EXIT_BAD_INPUT, EXIT_INTERRUPTED, EXIT_WORKERS_LOST
from dualmech.validation.run.executors import WorkersLost

#: Exit code for an unexpected internal error (``EX_SOFTWARE``).
EXIT_INTERNAL = 70
#: Longest message text on the error line, characters.
MAX_LINE_CHARS = 300
#: Keyword arguments of a command that name its output folder (where the traceback log goes).
OUTPUT_FOLDER_ARGUMENTS = ("outdir", "rundir")
#: Where a command's note on what an interrupt keeps is held (``click.Context.meta``, :func:`on_interrupt`).
NOTE_KEY = "dualmech.on_interrupt"
#: Set in ``click.Context.meta`` once a command has printed its one line (:func:`when_closing`).
ENDED_KEY = "dualmech.ended"


def first_line(err: BaseException) -> str:
    """The first line of ``str(err)``, cut to :data:`MAX_LINE_CHARS`; never raises."""
    try:
        text = str(err)
    except Exception:  # a message that cannot even be built: say so rather than fail here
        text = "(message not printable)"
    lines = text.strip().splitlines()
    line = lines[0] if lines else ""
    more = len(lines) > 1 or len(line) > MAX_LINE_CHARS
    return line[:MAX_LINE_CHARS] + (" ..." if more else "")


def write_traceback(err: BaseException, folder: Path | None) -> str:
    """Write the traceback of ``err`` to a new log file; its path, or why it could not be written."""
    text = "".join(traceback.format_exception(err))
    stamp = time.strftime("%Y%m%dT%H%M%S")
    name = f"dualmech-internal-error-{stamp}-{os.getpid()}.log"
    candidates = ([folder / name] if folder is not None and folder.is_dir() else []) + [None]
    reason = ""
    for path in candidates:
        try:
            if path is None:
                fd, temp = tempfile.mkstemp(prefix=name[:-4] + "-", suffix=".log")
                with os.fdopen(fd, "w") as fh:
                    fh.write(text)
                return temp
            fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o644)  # never a link
            with os.fdopen(fd, "w") as fh:
                fh.write(text)
            return str(path)
        except Exception as write_err:  # read-only folder, full disk, no memory: try the next place
            reason = f"{type(write_err).__name__}: {first_line(write_err)}"
    return f"(not written: {reason})"


#: ValueErrors that are failures of the arithmetic, never of the user's input (numpy's LinAlgError
#: subclasses ValueError): they exit 70 with a traceback, not 2.
INTERNAL_VALUE_ERRORS: tuple[type[BaseException], ...] = (np.linalg.LinAlgError,)


#: Seconds after a Ctrl-C that Python ignored (:func:`interrupts_where_python_ignores_them`) that it is
#: raised again: long enough for the unraisable hook that saw it to return.
REDELIVER_S = 0.01


def one_line_errors(func: Callable) -> Callable:
    """Decorate a click command: bad input exits 2, lost workers 4, an unexpected error 70, an interrupt
    130, each with one line (the module's rules)."""

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        try:
            with interrupts_where_python_ignores_them() as ignored:
                result = func(*args, **kwargs)
            if ignored:
                raise ignored[0]
            return result
        except (click.exceptions.ClickException, click.exceptions.Exit):
            raise
        except (KeyboardInterrupt, click.exceptions.Abort):
            _stop(EXIT_INTERRUPTED, "dualmech: interrupted", _note(kwargs))
        except WorkersLost as err:
            note = _note(kwargs)
            _stop(EXIT_WORKERS_LOST, f"dualmech: error: {err.what if note else err}", note)
        except (ValueError, OSError) as err:
            if not isinstance(err, INTERNAL_VALUE_ERRORS):
                _stop(EXIT_BAD_INPUT, f"dualmech: error: {first_line(err)}", "")
            _internal(err, kwargs)
        except Exception as err:  # the last line of defence: no traceback reaches the user
            _internal(err, kwargs)

    return wrapper


@contextlib.contextmanager
def interrupts_where_python_ignores_them() -> Iterator[list[KeyboardInterrupt]]:
    """Deliver again a Ctrl-C that lands where Python ignores exceptions, so that the command stops at
    once; keep it (in the list yielded) for the command to end with, should it end first.

    A ``KeyboardInterrupt`` raised in a ``__del__`` or a weakref callback (the garbage collector runs them
    at any bytecode, e.g. while matplotlib draws) goes to :data:`sys.unraisablehook`, which prints
    "Exception ignored in ..." and a traceback; the command then ran on and exited 0 (seen in ``report``
    on CI).  Told only at the command's end, a 10-minute tolerance study ran on for its 10 minutes
    (seen on CI).  So the interrupt is raised again in the main thread (:func:`_thread.interrupt_main`)
    :data:`REDELIVER_S` later, from a timer: raised from the hook itself, it would land in the hook (Python
    checks for signals after each call) and be ignored again.  Other unraisable exceptions go to the
    previous hook as before.
    """
    ignored: list[KeyboardInterrupt] = []
    timers: list[threading.Timer] = []
    previous = sys.unraisablehook

    def keep(unraisable) -> None:
        if isinstance(unraisable.exc_value, KeyboardInterrupt):
            ignored.append(unraisable.exc_value)
            timer = threading.Timer(REDELIVER_S, _thread.interrupt_main)
            timer.daemon = True
            timer.start()
            timers.append(timer)
        else:
            previous(unraisable)

    sys.unraisablehook = keep
    try:
        yield ignored
    finally:
        sys.unraisablehook = previous
        for timer in timers:  # the command ended first: it ends with the interrupt kept
            timer.cancel()


def on_interrupt(note: str) -> None:
    """Say what the running command keeps if it is interrupted or loses its workers (one clause, e.g.
    ``"finished results are kept in runs/x; re-run with --resume to finish"``); outside a command, nothing."""
    ctx = click.get_current_context(silent=True)
    if ctx is not None:
        ctx.meta[NOTE_KEY] = note


def _note(kwargs: dict) -> str:
    """The running command's note (:func:`on_interrupt`), else one on its output file, else ``""``."""
    ctx = click.get_current_context(silent=True)
    note = ctx.meta.get(NOTE_KEY, "") if ctx is not None else ""
    if not note and kwargs.get("output"):
        note = f"no partial file is left at {kwargs['output']}"
    return note


def _stop(code: int, line: str, note: str) -> None:
    """Print ``line`` (and ``; note``) on stderr as one line, and exit ``code``."""
    click.echo(f"{line}; {note}" if note else line, err=True)
    ctx = click.get_current_context(silent=True)
    if ctx is not None:
        ctx.meta[ENDED_KEY] = True
    sys.exit(code)


def when_closing(end: Callable[[], None]) -> Callable[[], None]:
    """``end``, a step run as a command's context closes (after its output: ending its pools), with a
    Ctrl-C meanwhile told as anywhere else: ``dualmech: interrupted`` (unless the command has printed its
    one line already) and exit 130, not click's "Aborted!" and exit 1."""

    def run() -> None:
        try:
            end()
        except KeyboardInterrupt:
            ctx = click.get_current_context(silent=True)
            if ctx is None or not ctx.meta.get(ENDED_KEY):
                click.echo("dualmech: interrupted", err=True)
            sys.exit(EXIT_INTERRUPTED)

    return run


def _internal(err: BaseException, kwargs: dict) -> None:
    """One line naming an unexpected error and where its traceback went; exit 70."""
    folder = next((Path(kwargs[k]) for k in OUTPUT_FOLDER_ARGUMENTS if kwargs.get(k)), None)
    where = write_traceback(err, folder)
    _stop(EXIT_INTERNAL, f"dualmech: internal error: {type(err).__name__}: {first_line(err)}; "
          f"traceback in {where}", "")
