"""The compiled kernel of the dual-number method (numba ``@njit``): one position at a time, in registers.

The numpy modules of :mod:`dualmech.core` state the method batched over positions; this
subpackage runs the same algorithm per position, compiled, with every 3x3 dual matrix in
a small scratch array that stays in the CPU's first-level cache, and blocks of positions in
parallel over all cores (a thread pool; the GIL released).  Its pieces mirror the numpy modules one for one:

========================  =====================================  ==============================
kernel module             what                                   numpy twin
========================  =====================================  ==============================
``dual_nb``               3x3 dual-matrix arithmetic, rotations  :mod:`dualmech.core.dual`
``loop_nb``               the link-joint table as flat arrays    :mod:`dualmech.core.loop`
``linalg_nb``             LU, least squares, pseudo-inverse      ``np.linalg`` (allocation-free)
``closure_nb``            Newton with the screws, DFP fallback   :mod:`dualmech.core.closure`
``rates_nb``              rates and accelerations from screws    :mod:`dualmech.core.rates`
``dynamics_nb``           dual momentum rate of a rigid body     :mod:`dualmech.core.reactions`
``universal_nb``          a universal joint's link spin          :mod:`dualmech.core.universal`
``continuation_nb``       branch sign, stations, estimates       :mod:`dualmech.core.continuation`
``wrenches_nb``           every joint's wrench, Householder QR   :mod:`dualmech.core.loop_reactions`
``wrench_chain_nb``       the system along the chain, LU         (the same least squares, exact)
``wrench_system_nb``      the system's columns and residual      :mod:`dualmech.core.loop_reactions`
``loop_engine_nb``        a block of positions of any table      (the three above in turn)
========================  =====================================  ==============================

Nothing here allocates or counts references (compiled without numba's runtime: see
:data:`~dualmech.core.kernel.dual_nb.JIT`); the scratch arrays of a block of positions come from
the caller.  Everything here is generic: the table is data
(:func:`~dualmech.core.kernel.loop_nb.flatten`), and mechanism-specific start estimates, branch
rules and reaction eliminations live with the mechanism in :mod:`dualmech.models`.
:mod:`~dualmech.core.kernel.loop_engine` runs any table on it (:mod:`~dualmech.core.kernel.pool`: the
threads).

Compiled code is cached on disk (beside the sources, or in ``NUMBA_CACHE_DIR``), keyed on the
compiled modules (``*_nb.py``: :data:`_SOURCES`); a cold cache costs minutes of compiling at the first
use, which :mod:`~dualmech.core.kernel.compiles` logs.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

from numba.core import caching

#: Source files whose compiled code the cached kernels carry: this package's compiled modules
#: (``*_nb.py``; an edit of this file or of :mod:`~dualmech.core.kernel.compiles` recompiles nothing),
#: then the modules that registered with :func:`depends_on_kernel` (in import order, so each sees its
#: dependencies).
_SOURCES: list[Path] = sorted(Path(__file__).resolve().parent.glob("*_nb.py"))
#: How many of :data:`_SOURCES` are this package's own (a function of them calls none of the others).
_OWN = len(_SOURCES)


def depends_on_kernel(path: str) -> None:
    """Register the module file ``path`` (call after its imports, before its ``@njit`` functions).

    numba's disk cache checks only the source file of the cached function itself, but a
    compiled function carries the machine code of everything it calls: after an edit of
    ``loop_nb.py`` a cached caller elsewhere would run stale code.  The functions of the
    registered modules and of this package are cached against a digest of all of these files.
    """
    _SOURCES.append(Path(path).resolve())


class _Digest:
    """numba cache locator mixin for the kernel's files: fresh only if none of the files its function's code
    may carry changed: this package's own, and for a registered module's function the modules registered up
    to it.  Never the modules registered after it: a process that imports only the generic loop kernel and
    one that imports a mechanism's too must read the same stamp, or each would find the other's cache stale
    and recompile it (minutes) in turn."""

    def get_source_stamp(self) -> str:
        own = Path(self._py_file).resolve()
        upto = _OWN if own in _SOURCES[:_OWN] else _SOURCES.index(own) + 1
        digest = hashlib.sha256()
        for path in _SOURCES[:upto]:
            digest.update(path.read_bytes())
        return digest.hexdigest()

    @classmethod
    def from_function(cls, py_func, py_file):  # noqa: ANN001, ANN206 (numba's interface)
        if Path(py_file).resolve() not in _SOURCES:
            return None
        return super().from_function(py_func, py_file)


class _KernelUserLocator(_Digest, caching.UserProvidedCacheLocator):
    """In ``NUMBA_CACHE_DIR`` when it is set (e.g. a read-only install)."""


class _KernelInTreeLocator(_Digest, caching.InTreeCacheLocator):
    """Beside the source otherwise (``__pycache__``)."""


caching.CacheImpl._locator_classes[:0] = [_KernelUserLocator, _KernelInTreeLocator]
