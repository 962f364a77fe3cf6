"""Waiting for a pool's worker process to end, as the tests that end workers by a signal need it."""

from __future__ import annotations

import time
from typing import Any


def exit_code(proc: Any, timeout: float) -> int | None:
    """The worker's exit code once it has ended (``None`` if it is still alive after ``timeout`` s).

    ``Process.join`` alone is not enough for a pool's worker: the pool's manager thread reaps the same
    process, and a ``join`` that loses that race returns at once with no exit code (``waitpid`` fails
    with ECHILD) while the process is already gone; the exit code appears when the manager has
    recorded it.  Seen once in a quiet full run: ``is_alive()`` true right after ``join``, the repr a
    moment later ``stopped exitcode=-SIGTERM``.
    """
    deadline = time.monotonic() + timeout
    while proc.exitcode is None and time.monotonic() < deadline:
        proc.join(timeout=0.05)
    return proc.exitcode
