"""The run folder: who may write there, what may be read from it, and what a run may delete.

A run folder may come from someone else (a colleague's run, a CI artefact, a download), so everything in
it is untrusted input.  This module owns its rules; every command that writes a folder (``validate``,
``report``, ``tolerance``, ``selftest --keep``, the linkage runs) and every reader of a stored run goes
through it.  ``docs/conventions.md`` ("Output files and the run folder") states them for users:

* **Only into a dualmech folder.**  An output folder must be new, empty, or one that dualmech wrote
  before (it holds a ``run.json``, ``summary.json``, ``study.json`` or ``manifest.json`` of dualmech's
  formats); anything else is refused with one line.
* **One writer at a time.**  A command holds an exclusive lock on ``.dualmech.lock`` in the folder
  (:func:`fcntl.flock`, released by the kernel when the process dies, however it dies); a second
  concurrent writer is refused.  The lock file is opened without following a link (``O_NOFOLLOW``), and
  refused unless it is a regular file with one name (never a link, FIFO or hard link to another file).
* **Paths stay inside.**  Every path taken from the folder (a manifest entry, a case id of ``run.json``)
  is a relative path of plain names (no ``..``, no absolute path, no empty or hidden-by-dots component);
  no component of a path read or written in the folder may be a symbolic link, and a file read must be a
  regular file (a FIFO, device or socket is refused without being opened for a blocking read).
* **Formats are checked before use.**  ``manifest.json``, ``run.json`` and the case files are checked
  against their schemas (:data:`MANIFEST_SCHEMA`, :data:`RUN_SCHEMA`, :data:`CASE_SCHEMA`); a violation is
  one line naming the file and the field (:class:`RunDirError`, exit code 2).
* **Written whole.**  Every file is written beside its name, fsynced and renamed
  (:mod:`dualmech.validation.durable`), then listed in ``manifest.json``.
* **Delete only what it created.**  Stale files are removed only if the manifest lists them.
"""

from __future__ import annotations

import contextlib
import json
import os
import stat
from pathlib import Path, PurePosixPath
from typing import Any, Iterable, Iterator

from dualmech.core import files
from dualmech.validation import durable
from dualmech.validation.rundir.schemas import (  # noqa: F401  (the folder's formats, re-exported)
    CASE_FORMAT,
    CASE_SCHEMA,
    MANIFEST_FORMAT,
    MANIFEST_SCHEMA,
    MATRIX_SCHEMA,
    NUMBER,
    RUN_FORMAT,
    RUN_SCHEMA,
    TABLE_SCHEMA,
    Check,
    MapOf,
    Nullable,
    RunDirError,
    check_case_file,
    conform,
    member,
)

LOCK_FILE = ".dualmech.lock"
MANIFEST_FILE = "manifest.json"
#: Files whose presence (with a dualmech format tag) marks a folder as dualmech's.
MARKERS: dict[str, str] = {"run.json": "dualmech-run/", "summary.json": "dualmech-summary/",
                           "study.json": "dualmech-tolerance/", MANIFEST_FILE: "dualmech-manifest/"}
#: Largest JSON file of a run folder read, bytes (a case file of 20,000 positions on four engines is
#: ~25 MB).
MAX_JSON_BYTES = 256 << 20

#: Folders this process holds the lock of (resolved path -> depth): a command that locks a folder and
#: calls functions that lock it again (a tolerance study and its report) keeps one lock.
_HELD: dict[str, int] = {}


# ----------------------------------------------------------------------------- paths in the folder

def inside(root: str | Path, name: str | PurePosixPath, *, folder: bool = False) -> Path:
    """``root / name`` after checking that it stays in ``root``: ``name`` a :func:`member` path, and no
    existing component below ``root`` a symbolic link; the last one (if it exists) a regular file, or a
    folder if ``folder``.  Else a one-line :class:`RunDirError`.
    """
    root = Path(root)
    rel = member(str(name), root)
    here = root
    for i, part in enumerate(rel.parts):
        here = here / part
        try:
            mode = os.lstat(here).st_mode
        except FileNotFoundError:
            break
        last = i == len(rel.parts) - 1
        want_folder = folder or not last
        if stat.S_ISLNK(mode):
            raise RunDirError(f"{here}: a symbolic link in a run folder; dualmech does not follow links "
                              "there (remove it)")
        if (want_folder and not stat.S_ISDIR(mode)) or (not want_folder and not stat.S_ISREG(mode)):
            raise RunDirError(f"{here}: {durable.file_kind(mode)}; expected "
                              f"{'a folder' if want_folder else 'a regular file'} (remove it)")
    return root / rel


def make_folder(root: str | Path, name: str | PurePosixPath) -> Path:
    """Create the folder ``root / name`` and its parents inside ``root`` (:func:`inside`'s rules)."""
    root = Path(root)
    here = root
    for part in member(str(name), root).parts:
        here = inside(root, here.relative_to(root) / part, folder=True)
        here.mkdir(exist_ok=True)
        inside(root, here.relative_to(root), folder=True)  # not replaced by a link meanwhile
    return here


def read_bytes(root: str | Path, name: str | PurePosixPath, limit: int = MAX_JSON_BYTES) -> bytes | None:
    """The bytes of the regular file ``root / name`` (:func:`inside`), ``None`` if it does not exist."""
    path = inside(root, name)
    try:
        return durable.read_regular(path, follow=False, limit=limit)
    except FileNotFoundError:
        return None
    except durable.NotAFileError as err:
        raise RunDirError(str(err)) from None


def read_json(root: str | Path, name: str | PurePosixPath, schema: Any = None) -> Any:
    """The JSON content of ``root / name`` (:func:`read_bytes`), checked against ``schema`` if given;
    ``None`` if the file does not exist; a one-line :class:`RunDirError` if it is not valid JSON."""
    data = read_bytes(root, name)
    if data is None:
        return None
    path = Path(root) / name
    try:
        value = json.loads(data)
    except ValueError as err:  # UnicodeDecodeError too
        raise RunDirError(f"{path}: not valid JSON ({str(err).splitlines()[0][:120]})") from None
    return value if schema is None else conform(value, schema, path)


@contextlib.contextmanager
def writing(root: str | Path, name: str | PurePosixPath, *, record: bool = True
            ) -> Iterator[tuple[Path, int]]:
    """Write the file ``root / name`` through :func:`dualmech.core.files.replacing` (its folders
    made inside ``root``, no link followed), and list it in the manifest (``record``)."""
    root = Path(root)
    rel = member(str(name), root)
    if len(rel.parts) > 1:
        make_folder(root, rel.parent)
    path = inside(root, rel)
    with files.replacing(path) as handle:
        yield handle
    if record:
        record_files(root, [rel])


def write_file(root: str | Path, name: str | PurePosixPath, data: bytes | str, *,
               record: bool = True) -> Path:
    """Write ``data`` (text as UTF-8) to ``root / name`` (:func:`writing`); the path written."""
    payload = data.encode("utf-8") if isinstance(data, str) else data
    with writing(root, name, record=record) as (tmp, fd):
        view = memoryview(payload)
        while view:
            view = view[os.write(fd, view):]
    return Path(root) / name


def write_json(root: str | Path, name: str | PurePosixPath, data: Any, *, pretty: bool = False,
               record: bool = True) -> Path:
    """Write ``data`` as JSON (:func:`dualmech.validation.durable.json_text`) to ``root / name``."""
    return write_file(root, name, durable.json_text(data, pretty=pretty), record=record)


def append_text(root: str | Path, name: str, text: str) -> None:
    """Append ``text`` to the log file ``root / name`` (created if absent; a link, a special file or a
    file with another name elsewhere (a hard link) is refused)."""
    path = inside(root, name)
    flags = os.O_WRONLY | os.O_APPEND | os.O_CREAT | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC
    fd = _open_own(path, flags)
    try:
        os.write(fd, text.encode("utf-8"))
    finally:
        os.close(fd)
    record_files(root, [name])


def _open_own(path: Path, flags: int) -> int:
    """``os.open(path, flags)`` of a regular file with one name, else a one-line :class:`RunDirError`."""
    try:
        fd = os.open(path, flags, 0o644)
    except OSError as err:
        why = ("a symbolic link; dualmech does not follow links in a run folder" if os.path.islink(path)
               else err.strerror)
        raise RunDirError(f"{path}: cannot be used ({why}); remove it") from None
    info = os.fstat(fd)
    if not stat.S_ISREG(info.st_mode) or info.st_nlink != 1:
        os.close(fd)
        kind = ("a hard link to another file" if stat.S_ISREG(info.st_mode)
                else durable.file_kind(info.st_mode))
        raise RunDirError(f"{path}: {kind}, not a file of this folder alone; remove it")
    return fd


def _remove(root: Path, name: str) -> None:
    """Delete the file ``root / name`` (:func:`inside`'s rules: never through a link)."""
    inside(root, name).unlink(missing_ok=True)


# ----------------------------------------------------------------------------- the folder

def _format_of(path: Path, name: str) -> str:
    try:
        data = json.loads(durable.read_regular(path / name, follow=False, limit=MAX_JSON_BYTES))
    except (OSError, ValueError):  # absent, a link, a special file, not JSON: no marker
        return ""
    return str(data.get("format", "")) if isinstance(data, dict) else ""


def is_dualmech_folder(path: Path) -> bool:
    """Whether ``path`` holds a marker file of dualmech (:data:`MARKERS`)."""
    return any(_format_of(Path(path), name).startswith(tag) for name, tag in MARKERS.items())


def check_output_folder(path: str | Path) -> Path:
    """``path`` as a :class:`Path` if dualmech may write there (module docstring), else
    :class:`RunDirError`."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise RunDirError(f"output folder: {path} is a file; expected a folder (new, empty, or a dualmech "
                          "run)")
    if path.is_dir() and any(p.name != LOCK_FILE for p in path.iterdir()) and not is_dualmech_folder(path):
        raise RunDirError(f"output folder: {path} is not empty and not a dualmech run; "
                          "choose a new or empty folder with -o")
    return path


@contextlib.contextmanager
def locked(path: str | Path) -> Iterator[Path]:
    """Hold the folder's lock for the ``with`` block (created if needed); refuse if another process holds
    it, if the folder's manifest is not one of dualmech's (:data:`MANIFEST_SCHEMA`), or if a file it lists
    is reached through a link or is not a regular file (:func:`inside`).  Within one
    process the lock may be taken again (nested): the outer holder keeps it."""
    import fcntl

    path = check_output_folder(path)
    path.mkdir(parents=True, exist_ok=True)
    key = str(path.resolve())
    if key in _HELD:
        _HELD[key] += 1
        try:
            yield path
        finally:
            _HELD[key] -= 1
        return
    flags = os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC
    fd = _open_own(inside(path, LOCK_FILE), flags)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 32, 0).decode(errors="replace").strip() or "?"
            raise RunDirError(f"output folder: {path} is in use by another dualmech run (pid {holder}); "
                              "wait for it to finish or choose another folder with -o") from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, str(os.getpid()).encode(), 0)
        for name in created_files(path):  # before anything is written: a manifest that is not dualmech's,
            inside(path, name)             # a listed file reached through a link or replaced by a FIFO
        _HELD[key] = 1
        try:
            yield path
        finally:
            del _HELD[key]
    finally:
        os.close(fd)  # releases the lock


# ----------------------------------------------------------------------------- the manifest

def created_files(path: str | Path) -> set[str]:
    """Paths (relative to ``path``, POSIX form) that dualmech recorded as written there; a manifest that
    breaks :data:`MANIFEST_SCHEMA` or lists a path outside the folder is a :class:`RunDirError`."""
    path = Path(path)
    data = read_json(path, MANIFEST_FILE, MANIFEST_SCHEMA)
    if data is None:
        return set()
    return {str(member(f, path / MANIFEST_FILE, f"files[{i}]")) for i, f in enumerate(data["files"])}


def record_files(path: str | Path, files: Iterable[str | Path]) -> None:
    """Add ``files`` (absolute, or relative to ``path``) to the folder's manifest."""
    path = Path(path)
    known = created_files(path)
    names = known | {_relative(path, f) for f in files}
    if names != known:
        write_file(path, MANIFEST_FILE, durable.json_text({"format": MANIFEST_FORMAT, "files": sorted(names)},
                                                          pretty=True), record=False)


def _relative(root: Path, file: str | Path) -> str:
    file = Path(file)
    if file.is_absolute() or file.parts[: len(root.parts)] == root.parts and root.parts:
        try:
            file = file.relative_to(root)
        except ValueError:
            file = file.resolve().relative_to(root.resolve())
    return str(member(file.as_posix(), root))


def remove_stale(path: str | Path, keep: Iterable[str | Path], under: str) -> list[str]:
    """Delete files below ``path/under`` that the manifest lists and ``keep`` does not; return what went.

    A file dualmech did not record (a user's own file in the folder) is never deleted, nor anything
    reached through a link.
    """
    path = Path(path)
    keep_names = {_relative(path, k) for k in keep}
    known = created_files(path)
    gone = sorted(n for n in known if n.startswith(f"{under}/") and n not in keep_names)
    for name in gone:
        _remove(path, name)
    if gone:
        write_file(path, MANIFEST_FILE, durable.json_text(
            {"format": MANIFEST_FORMAT, "files": sorted(known - set(gone))}, pretty=True), record=False)
    return gone
