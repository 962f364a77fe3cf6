"""Files written whole or not at all, and read only when they are plain files.

Every file dualmech writes (a run's case files, ``run.json``, summaries, reports, figures, baselines,
the tables of ``solve -o`` and ``simulate -o``, the MJCF of ``mjcf -o``, a tolerance study's chunks and
samples) is written *beside* its final name, to a new temporary file (created with ``O_EXCL`` and
``O_NOFOLLOW``: never through a planted link), flushed to the disk (``fsync``), and only then renamed
onto the final name (:func:`os.replace`, atomic; the folder is then fsynced too, so the rename survives a
crash of the machine).  A write that fails (a full disk) or is interrupted (Ctrl-C) removes its temporary
file and leaves the old file, if any, untouched: readers see the old file or the new one, never half.

Reading, :func:`read_regular` opens without following a final link if asked, and never blocks on a FIFO
(``O_NONBLOCK``); anything but a regular file is refused with one line.  The rules of a run folder
(paths inside it, links refused, the lock, the manifest) are :mod:`dualmech.validation.rundir`'s.
"""

from __future__ import annotations

import contextlib
import json
import os
import secrets
import stat
from pathlib import Path
from typing import Any, Callable, Iterator

import numpy as np

#: Largest file :func:`read_regular` reads by default, bytes (a run's case file of 2000 positions is
#: ~1 MB; a stored table of 10^5 positions ~50 MB): beyond it a file is refused, not read into memory.
MAX_READ_BYTES = 1 << 30


def json_text(data: Any, *, pretty: bool = False) -> str:
    """``data`` as JSON text (NaN as ``NaN``; numpy arrays and numbers, sets and tuples as JSON's own).

    ``pretty``: sorted keys, one value per line and a final newline, so that a change shows as a readable
    diff (for files people review: baselines, summaries).
    """
    # json.dumps, not json.dump: dump always encodes in pure Python, dumps in C (without indent)
    layout = {"indent": 1, "sort_keys": True} if pretty else {}
    text = json.dumps(data, allow_nan=True, default=jsonable, **layout)
    return text + ("\n" if pretty else "")


def write_json_atomic(path: Path, data: Any, *, pretty: bool = False) -> None:
    """Write ``data`` as JSON (:func:`json_text`) to ``path`` (:func:`write_text_durable`)."""
    write_text_durable(Path(path), json_text(data, pretty=pretty))


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


class NotAFileError(ValueError):
    """A path that should be a regular file is a link, a FIFO, a device, a socket or a folder."""


def read_regular(path: str | Path, *, follow: bool = True, limit: int = MAX_READ_BYTES) -> bytes:
    """The bytes of the regular file ``path``; :class:`NotAFileError` (one line) for anything else.

    Never blocks: a FIFO is opened with ``O_NONBLOCK`` and refused.  ``follow=False`` refuses a link at
    ``path`` itself (``O_NOFOLLOW``; the folders above it are the caller's to check).  A file larger than
    ``limit`` bytes is refused.  ``FileNotFoundError`` passes through.
    """
    flags = os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC | (0 if follow else os.O_NOFOLLOW)
    try:
        fd = os.open(path, flags)
    except OSError as err:
        if not follow and os.path.islink(path):
            raise NotAFileError(f"{path}: a symbolic link; dualmech does not follow links in a run "
                                "folder") from None
        if isinstance(err, FileNotFoundError):
            raise
        raise NotAFileError(f"{path}: cannot be read ({err.strerror})") from None
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            raise NotAFileError(f"{path}: {file_kind(info.st_mode)}, not a regular file; refused")
        if info.st_size > limit:
            raise NotAFileError(f"{path}: {info.st_size} bytes, more than the {limit} read at most")
        chunks, total = [], 0
        while chunk := os.read(fd, 1 << 20):
            chunks.append(chunk)
            total += len(chunk)
            if total > limit:
                raise NotAFileError(f"{path}: grew beyond the {limit} bytes read at most")
        return b"".join(chunks)
    finally:
        os.close(fd)


def file_kind(mode: int) -> str:
    """What a file of ``st_mode`` ``mode`` is, in words (``"a FIFO"``, ``"a folder"`` ...)."""
    kinds = ((stat.S_ISLNK, "a symbolic link"), (stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO"),
             (stat.S_ISSOCK, "a socket"), (stat.S_ISCHR, "a character device"),
             (stat.S_ISBLK, "a block device"), (stat.S_ISREG, "a regular file"))
    return next((word for test, word in kinds if test(mode)), "a special file")


def jsonable(obj: Any) -> Any:
    """What JSON cannot encode as JSON can: numpy arrays as lists, numpy numbers as Python's, sets and
    tuples as lists, anything else as its text (``json.dumps``'s ``default``)."""
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, (set, tuple)):
        return list(obj)
    return str(obj)
