"""Files written whole or not at all: text and JSON that readers see old or new, never half, and that
survive a crash of the machine once written (fsync): a run's case files, ``run.json``, summaries and
baselines."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np


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
    """Write ``text`` to ``path`` atomically (a temporary file, fsync, :func:`os.replace`)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        with tmp.open("w") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


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
