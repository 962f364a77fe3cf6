"""The output folder of a run or report: who may write there, and what a run may delete.

Three rules keep a run inside its folder and away from other people's files:

* **Only into a dualmech folder.**  An output folder must be new, empty, or one
  that dualmech wrote before (it holds a ``run.json``, ``summary.json`` or
  ``manifest.json`` of dualmech's formats); anything else is refused with one line.
* **One run at a time.**  A run or report holds an exclusive lock on
  ``.dualmech.lock`` in the folder (:func:`fcntl.flock`, released by the kernel
  when the process dies, however it dies); a second concurrent run is refused.
* **Delete only what it created.**  Every file dualmech writes is listed in
  ``manifest.json``; stale files are removed only if they are listed there.
"""

from __future__ import annotations

import contextlib
import json
import os
from pathlib import Path
from typing import Iterable, Iterator

LOCK_FILE = ".dualmech.lock"
MANIFEST_FILE = "manifest.json"
MANIFEST_FORMAT = "dualmech-manifest/1"
#: Files whose presence (with a dualmech format tag) marks a folder as dualmech's.
MARKERS: dict[str, str] = {"run.json": "dualmech-run/", "summary.json": "dualmech-summary/",
                           MANIFEST_FILE: "dualmech-manifest/"}


class RunDirError(ValueError):
    """An output folder that cannot be used; the message is one line."""


def _format_of(path: Path) -> str:
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return ""
    return str(data.get("format", "")) if isinstance(data, dict) else ""


def is_dualmech_folder(path: Path) -> bool:
    """Whether ``path`` holds a marker file of dualmech (:data:`MARKERS`)."""
    return any(_format_of(Path(path) / name).startswith(tag) for name, tag in MARKERS.items())


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
    it."""
    import fcntl

    path = check_output_folder(path)
    path.mkdir(parents=True, exist_ok=True)
    fd = os.open(path / LOCK_FILE, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 32, 0).decode(errors="replace").strip() or "?"
            raise RunDirError(f"output folder: {path} is in use by another dualmech run (pid {holder}); "
                              "wait for it to finish or choose another folder with -o") from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, str(os.getpid()).encode(), 0)
        yield path
    finally:
        os.close(fd)  # releases the lock


def created_files(path: str | Path) -> set[str]:
    """Paths (relative to ``path``, POSIX form) that dualmech recorded as written there."""
    data = _read_manifest(Path(path))
    return set(data.get("files", []))


def _read_manifest(path: Path) -> dict:
    try:
        data = json.loads((path / MANIFEST_FILE).read_text())
    except (OSError, ValueError):
        return {}
    return data if isinstance(data, dict) and data.get("format") == MANIFEST_FORMAT else {}


def record_files(path: str | Path, files: Iterable[str | Path]) -> None:
    """Add ``files`` (absolute, or relative to ``path``) to the folder's manifest."""
    path = Path(path)
    names = created_files(path) | {_relative(path, f) for f in files}
    tmp = path / f".{MANIFEST_FILE}.{os.getpid()}.tmp"
    tmp.write_text(json.dumps({"format": MANIFEST_FORMAT, "files": sorted(names)}, indent=1) + "\n")
    os.replace(tmp, path / MANIFEST_FILE)


def _relative(root: Path, file: str | Path) -> str:
    file = Path(file)
    return (file.resolve().relative_to(root.resolve()) if file.is_absolute() else file).as_posix()


def remove_stale(path: str | Path, keep: Iterable[str | Path], under: str) -> list[str]:
    """Delete files below ``path/under`` that the manifest lists and ``keep`` does not; return what went.

    A file dualmech did not record (a user's own file in the folder) is never deleted.
    """
    path = Path(path)
    keep_names = {_relative(path, k) for k in keep}
    gone = []
    for name in sorted(created_files(path)):
        if name.startswith(f"{under}/") and name not in keep_names:
            (path / name).unlink(missing_ok=True)
            gone.append(name)
    if gone:
        data = _read_manifest(path)
        data["files"] = sorted(set(data["files"]) - set(gone))
        (path / MANIFEST_FILE).write_text(json.dumps(data, indent=1) + "\n")
    return gone
