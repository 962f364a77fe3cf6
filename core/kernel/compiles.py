"""The kernel's compiles, logged: a cold disk cache costs minutes at the first use, and says so.

numba announces a compile (its ``"numba:compile"`` event) only where its cache holds no code for the
signature, so a warm cache is silent.  The compiles of the kernel's functions (the files of
:data:`dualmech.core.kernel._SOURCES`) are logged to :data:`LOG` with a :class:`CompileEvent` in each
record's ``compile`` attribute: the start as a warning (a bare Python session shows it), each
function and the end at ``INFO``.  The command line shows them as a notice and a progress line
(:mod:`dualmech.cli.progress`).
"""

from __future__ import annotations

import contextlib
import logging
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

from numba.core import event

from dualmech.core.kernel import _SOURCES

#: The logger of the kernel's compiles (:class:`CompileEvent` in each record's ``compile`` attribute).
LOG = logging.getLogger("dualmech.kernel")
#: CPU seconds a cold compile takes (one core compiles; 175 s measured on the 2-core machine, numba 0.68):
#: the notice's estimate and the command line's progress bar (the compile reports nothing for minutes).
COMPILE_CPU_S = 175.0
#: The same in minutes, as the notice says it.
COMPILE_MINUTES = round(COMPILE_CPU_S / 60)
#: The message of the start of a compile.
NOTICE = (f"compiling the dual-number kernel once (about {COMPILE_MINUTES} min on 2 cores, longer on a "
          "busy machine); later runs load it from the cache")


@dataclass(frozen=True)
class CompileEvent:
    """One step of a compile of the kernel: ``kind`` ``"start"`` (the first function, ``compiled`` 0),
    ``"function"`` (a function compiled, the ``compiled``-th), ``"end"``; ``seconds`` since the start;
    ``expected_cpu``: the CPU seconds the whole compile takes, about (:data:`COMPILE_CPU_S`)."""

    kind: str
    function: str
    compiled: int
    seconds: float
    expected_cpu: float = COMPILE_CPU_S


class _Compiles(event.Listener):
    """numba's compile events of the kernel's functions (:data:`_SOURCES`) as :class:`CompileEvent` logs.

    A compile lasts from its first kernel function to the moment nothing of the kernel is
    being compiled and no :func:`compile_session` is open.
    """

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._depth = 0
        self._compiled = 0
        self._start: float | None = None

    def _emit(self, kind: str, function: str) -> None:
        seconds = 0.0 if self._start is None else time.perf_counter() - self._start
        level = logging.WARNING if kind == "start" else logging.INFO
        message = NOTICE if kind == "start" else f"compiled {self._compiled} functions ({function})"
        if kind == "end":
            message = f"compiled the dual-number kernel in {seconds:.0f} s ({self._compiled} functions)"
        LOG.log(level, message, extra={"compile": CompileEvent(kind, function, self._compiled, seconds)})

    def enter(self, function: str | None = None) -> None:
        """One level deeper: a session, or a kernel ``function`` whose compile starts."""
        with self._lock:
            self._depth += 1
            if function is not None and self._start is None:
                self._start = time.perf_counter()
                self._emit("start", function)

    def leave(self, function: str | None = None) -> None:
        """One level up; the end of the compile when nothing is left open."""
        with self._lock:
            self._depth -= 1
            if self._start is None:
                return
            if function is not None:
                self._compiled += 1
                self._emit("function", function)
            if self._depth == 0:
                self._emit("end", function or "")
                self._start, self._compiled = None, 0

    def on_start(self, ev: event.Event) -> None:
        name = _kernel_function(ev.data["dispatcher"])
        if name is not None:
            self.enter(name)

    def on_end(self, ev: event.Event) -> None:
        name = _kernel_function(ev.data["dispatcher"])
        if name is not None:
            self.leave(name)


def _kernel_function(dispatcher: object) -> str | None:
    """``module.name`` of a dispatcher's function if it is the kernel's (:data:`_SOURCES`), else None."""
    func = getattr(dispatcher, "py_func", None)
    if func is None or Path(func.__code__.co_filename).resolve() not in _SOURCES:
        return None
    return f"{func.__module__}.{func.__qualname__}"


_COMPILES = _Compiles()
event.register("numba:compile", _COMPILES)


@contextlib.contextmanager
def compile_session() -> Iterator[None]:
    """Within: the kernel's compiles count as one (the first use compiles several entry points in turn)."""
    _COMPILES.enter()
    try:
        yield
    finally:
        _COMPILES.leave()
