"""The callbacks through which a long job (a matrix run, a report's figures, a tolerance study, a streamed
solve) reports its progress: the command line shows them (:mod:`dualmech.cli.progress`)."""

from __future__ import annotations

from contextlib import AbstractContextManager
from typing import Callable

#: ``progress(done, total, label)``, called after each finished piece of work (a (case, engine), a figure,
#: a chunk).
ProgressCallback = Callable[[int, int, str], None]
#: ``tasks(description, unit=...)``: a context manager whose value is the :data:`ProgressCallback` of one
#: stage of work, shown while inside (the command line's :func:`dualmech.cli.progress.progress`).
ProgressTasks = Callable[..., AbstractContextManager[ProgressCallback]]
