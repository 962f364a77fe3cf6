"""Files written whole or not at all: written beside, flushed to the disk, renamed.

Every file dualmech writes (a run's case files, ``run.json``, summaries, reports, figures, baselines,
the tables of ``solve -o``, ``simulate -o`` and :meth:`~dualmech.core.table.ResultTable.to_csv`, the
MJCF of ``mjcf -o``, a tolerance study's chunks and samples) is written *beside* its final name, to a new
temporary file (created with ``O_EXCL`` and ``O_NOFOLLOW``: never through a planted link), flushed to the
disk (``fsync``), and only then renamed onto the final name (:func:`os.replace`, atomic; the folder is
then fsynced too, so the rename survives a crash of the machine).  A write that fails (a full disk) or is
interrupted (Ctrl-C) removes its temporary file and leaves the old file, if any, untouched: readers see
the old file or the new one, never half.

The primitive lives here, at the bottom floor, so that the result tables of ``core`` write through it as
every other writer does; reading files safely, JSON, and the rules of a run folder are
:mod:`dualmech.validation.durable`'s and :mod:`dualmech.validation.rundir`'s.
"""

from __future__ import annotations

import contextlib
import os
import secrets
from pathlib import Path
from typing import Callable, Iterator


def write_text_durable(path: Path, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically and durably (:func:`replacing`)."""
    write_bytes_durable(path, text.encode("utf-8"))


def write_bytes_durable(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically and durably (:func:`replacing`)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with replacing(path) as (tmp, fd):
        view = memoryview(data)
        while view:
            view = view[os.write(fd, view):]


def write_with(path: str | Path, write: Callable[[Path], object]) -> None:
    """Write ``path`` atomically and durably with ``write(temporary_path)``, a writer that takes a file name
    (a table's ``to_csv``, NumPy, pyarrow): :func:`replacing`."""
    with replacing(path) as (tmp, _):
        write(tmp)


def _new_beside(path: Path) -> tuple[Path, int]:
    """A new, empty file beside ``path`` (hidden, random name; never an existing file or link): its path
    and a descriptor open for writing.  Its mode is 0666 less the umask, as an ordinary new file's."""
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC
    for _ in range(100):
        tmp = path.with_name(f".{path.name}.{secrets.token_hex(4)}.tmp")
        try:
            return tmp, os.open(tmp, flags, 0o666)
        except FileExistsError:
            continue
    raise FileExistsError(f"{path}: no free temporary name beside it")  # 100 random names all taken


@contextlib.contextmanager
def replacing(path: str | Path) -> Iterator[tuple[Path, int]]:
    """Write a new version of ``path`` in the ``with`` block: yields a new temporary file beside it
    (its path, and a descriptor open for writing that the block may use or ignore).

    When the block ends normally the file is fsynced, renamed onto ``path`` and the folder fsynced; when it
    raises (an error, a full disk, Ctrl-C) the temporary file is removed and ``path`` stays as it was.  A
    writer that takes a file name (NumPy, pyarrow) writes to the yielded path.  A symbolic link at ``path``
    is written through (its target replaced); inside a run folder :mod:`~dualmech.validation.rundir`
    refuses links before this is reached.
    """
    path = Path(path)
    if path.is_symlink():  # a link named as the output (a user's): its target is replaced, as `>` would
        path = Path(os.path.realpath(path))
    tmp, fd = _new_beside(path)
    try:
        try:
            yield tmp, fd
        finally:
            os.close(fd)
        fsync_path(tmp)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    fsync_folder(path.parent)


def fsync_path(path: Path) -> None:
    """Flush a written file's data to the disk (opened anew, without following a link)."""
    fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_CLOEXEC)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def fsync_folder(folder: Path) -> None:
    """Flush a folder's entries (a rename into it) to the disk; a file system that cannot is skipped."""
    try:
        fd = os.open(folder, os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:  # e.g. EINVAL: folders of this file system cannot be fsynced
        pass
    finally:
        os.close(fd)
