"""The kernel's worker threads: one pool per process, as many threads as CPUs it may run on; a second
pool of as many for compiled work beside the kernel's; and the scratch that finished calls give back for
the next.

The compiled kernels release the GIL (``nogil``), so blocks of positions submitted to this pool run in
parallel; every engine on the kernel shares it.  A block's scratch (arrays the kernel writes before it reads
them) costs tens of microseconds to allocate, a tenth of a short case's fixed cost: a call takes spare sets
of its kind (:func:`take_scratch`) and gives them back when done (:func:`give_scratch`).
"""

from __future__ import annotations

import os
import threading
from concurrent.futures import ThreadPoolExecutor
from functools import lru_cache
from typing import Any, Callable, Hashable, Iterable

#: Kinds of scratch kept (the least recently given back go first) and spare sets of a kind at most.
SCRATCH_KINDS, SCRATCH_SETS = 8, 16
_SPARE: dict[Hashable, list[Any]] = {}
_SPARE_LOCK = threading.Lock()


def take_scratch(kind: Hashable, make: Callable[[], Any]) -> Any:
    """A spare scratch set of ``kind`` (given back by a finished call, never handed out twice), else
    ``make()``."""
    with _SPARE_LOCK:
        spare = _SPARE.get(kind)
        if spare:
            return spare.pop()
    return make()


def give_scratch(kind: Hashable, sets: Iterable[Any]) -> None:
    """Give back scratch ``sets`` of ``kind`` that no one uses any more, for :func:`take_scratch`."""
    with _SPARE_LOCK:
        spare = _SPARE.pop(kind, [])
        spare.extend(sets)
        _SPARE[kind] = spare[:SCRATCH_SETS]  # the most recently given back kind last
        while len(_SPARE) > SCRATCH_KINDS:
            del _SPARE[next(iter(_SPARE))]


def threads() -> int:
    """Worker threads of the kernel: the CPUs this process may run on."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


@lru_cache(maxsize=1)
def kernel_pool() -> ThreadPoolExecutor:
    """The kernel's thread pool (started at its first use)."""
    return ThreadPoolExecutor(max_workers=threads(), thread_name_prefix="dualmech-kernel")


@lru_cache(maxsize=1)
def side_pool() -> ThreadPoolExecutor:
    """Threads for compiled work on finished answers (a loop table's closure condition), apart from the
    kernel's: a table made on a writer thread while the kernel analyses the next chunk (``solve -o``)
    would otherwise wait until the kernel's queued blocks are done, one core idle meanwhile; apart, the
    two share the cores."""
    return ThreadPoolExecutor(max_workers=threads(), thread_name_prefix="dualmech-side")


def _forget_pools() -> None:
    kernel_pool.cache_clear()
    side_pool.cache_clear()


# a forked child (a process pool's worker) inherits the pool objects but not their threads: start afresh
os.register_at_fork(after_in_child=_forget_pools)
