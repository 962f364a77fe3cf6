"""The kernel's worker threads: one pool per process, as many threads as CPUs it may run on.

The compiled kernels release the GIL (``nogil``), so blocks of positions submitted to this pool run in
parallel; every engine on the kernel shares it.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from functools import lru_cache


def threads() -> int:
    """Worker threads of the kernel: the CPUs this process may run on."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


@lru_cache(maxsize=1)
def kernel_pool() -> ThreadPoolExecutor:
    """The kernel's thread pool (started at its first use)."""
    return ThreadPoolExecutor(max_workers=threads(), thread_name_prefix="dualmech-kernel")


# a forked child (a process pool's worker) inherits the pool object but not its threads: start afresh
os.register_at_fork(after_in_child=kernel_pool.cache_clear)
