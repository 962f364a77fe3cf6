"""The kernel compiles once, for one signature, and says so while it does.

A cold numba cache costs minutes of compiling (the whole per-position chain is inlined into
:func:`~dualmech.models.slider_crank.position_nb.analyze_range`); every different argument type
(an array's layout included) would cost as much again.  These tests hold the kernel to one
signature and check the compile events :mod:`dualmech.core.kernel` logs for the command line.
"""

from __future__ import annotations

import logging

import numba
import numpy as np
import pytest
from numba.core import event

from dualmech.core.kernel import compiles as kernel
from dualmech.core.kernel import dual_nb
from dualmech.models.case import load_case
from dualmech.models.slider_crank import kernel as slider_crank_kernel


def _recorded_layouts(monkeypatch: pytest.MonkeyPatch) -> list[set[str]]:
    """Replace the compiled entry point by a recorder of the layouts of its array arguments."""
    seen: list[set[str]] = []

    def record(*args) -> None:
        arrays = [a for a in args if isinstance(a, np.ndarray)]
        arrays += [a for t in args if isinstance(t, tuple) for a in t if isinstance(a, np.ndarray)]
        seen.append({numba.typeof(a).layout for a in arrays})

    slider_crank_kernel.load_kernel()  # compiled (or loaded) before the entry point is replaced
    monkeypatch.setattr(slider_crank_kernel, "analyze_range", record)
    return seen


def test_a_partial_chunk_is_passed_c_contiguous(monkeypatch: pytest.MonkeyPatch) -> None:
    """The last chunk of a case streamed in chunks fills only part of its buffer: its outputs must still
    reach the kernel as C-contiguous arrays, or numba compiles the whole kernel a second time (minutes)
    for the 'A' layout of a sliced buffer."""
    seen = _recorded_layouts(monkeypatch)
    case = load_case("thesis/ideal")  # 360 positions: chunks of 200, 160
    list(slider_crank_kernel.iter_chunks(case, 200))
    assert seen and all(layouts == {"C"} for layouts in seen), seen


def _compile_event(dispatcher, status: event.EventStatus) -> event.Event:
    data = {"dispatcher": dispatcher, "args": (), "return_type": None}
    return event.Event("numba:compile", status, data=data)


def test_compile_events_are_logged_once_per_compile(caplog: pytest.LogCaptureFixture) -> None:
    """numba's compile events of kernel functions (a cold cache) log the start (a warning: a bare Python
    session shows it), each function compiled and the end; another module's functions log nothing; a
    session with nothing compiled logs nothing."""

    @numba.njit
    def not_the_kernels(x: float) -> float:
        return x + 1.0

    outer, inner = dual_nb.copy, dual_nb.dot
    with caplog.at_level(logging.DEBUG, logger=kernel.LOG.name):
        with kernel.compile_session():
            pass
        not_the_kernels(1.0)
        assert not caplog.records
        with kernel.compile_session():
            for d, status in [(outer, event.EventStatus.START), (not_the_kernels, event.EventStatus.START),
                              (inner, event.EventStatus.START), (inner, event.EventStatus.END),
                              (not_the_kernels, event.EventStatus.END), (outer, event.EventStatus.END)]:
                event.broadcast(_compile_event(d, status))
            assert [r.compile.kind for r in caplog.records] == ["start", "function", "function"]
    events = [r.compile for r in caplog.records]
    assert [(e.kind, e.compiled) for e in events] == [("start", 0), ("function", 1), ("function", 2),
                                                       ("end", 2)]
    assert events[0].function.endswith("dual_nb.copy") and events[1].function.endswith("dual_nb.dot")
    assert caplog.records[0].levelno == logging.WARNING
    assert "once" in caplog.records[0].getMessage() and "cache" in caplog.records[0].getMessage()


#: A process that imports the generic loop kernel, reads the cache stamp of one of the kernel's own functions
#: and of a mechanism's, imports that mechanism's compiled modules (which register with the cache), and reads
#: both again: prints the two comparisons.
STAMPS = """
from dualmech.core.kernel import _KernelInTreeLocator, closure_nb
from dualmech.core.kernel import loop_engine  # the generic loop kernel alone, as `solve LOOP.toml` loads it
def stamp(f):
    return _KernelInTreeLocator(f.py_func, f.py_func.__code__.co_filename).get_source_stamp()
own = stamp(closure_nb.residual_at)
from dualmech.models.slider_crank import kernel_nb as slider_crank_nb
from dualmech.models.slider_crank import position_nb as slider_crank_position_nb
mechanism = stamp(slider_crank_position_nb.analyze_range)
print(own == stamp(closure_nb.residual_at), mechanism == stamp(slider_crank_position_nb.analyze_range))
"""


def test_a_cache_stamp_does_not_depend_on_what_the_process_imported_later() -> None:
    """Why (issue 32): the stamp hashed every registered module, so a process with the loop kernel alone and
    one with the slider crank's modules too read different stamps for the same function: each found the
    other's cache stale and recompiled the kernel (measured 2 min 54 s, in turn, between `solve 7r`-like and
    `validate` processes).  A function's stamp covers the kernel's own files and, for a mechanism's module,
    those registered up to it."""
    import subprocess
    import sys

    out = subprocess.run([sys.executable, "-c", STAMPS], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["True", "True"], out.stderr
