"""Files read only when they are plain files, and JSON written whole or not at all.

Every file dualmech writes is written whole or not at all, beside its final name, fsynced and renamed:
:mod:`dualmech.core.files` (the primitive, at the bottom floor, so that ``core``'s tables use it too);
:func:`write_json_atomic` writes JSON through it.

Reading, :func:`read_regular` opens without following a final link if asked, and never blocks on a FIFO
(``O_NONBLOCK``); anything but a regular file is refused with one line.  The rules of a run folder
(paths inside it, links refused, the lock, the manifest) are :mod:`dualmech.validation.rundir`'s.
"""

from __future__ import annotations

import json
import os
import stat
from pathlib import Path
from typing import Any

import numpy as np

from dualmech.core.files import write_text_durable

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
    """Write ``data`` as JSON (:func:`json_text`) to ``path``, atomically
    (:func:`~dualmech.core.files.write_text_durable`)."""
    write_text_durable(Path(path), json_text(data, pretty=pretty))


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
