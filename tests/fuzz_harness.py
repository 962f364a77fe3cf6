"""The fuzz's sandbox and its property (issue 31, ``test_fuzz_commands.py``): a working folder beside an
``outside`` folder that must not change, each command run in this process with a deadline, and the checks
of its exit code, its stderr lines and its tables."""

from __future__ import annotations

import contextlib
import csv
import hashlib
import json
import math
import os
import signal
from pathlib import Path
from typing import Any, Iterator

import numpy as np
from click.testing import CliRunner

from dualmech.cli import main

#: Exit codes a command may give (docs/validation.md, "Exit codes"; 70 is an internal error: a defect).
DOCUMENTED_EXITS = {0, 1, 2, 3, 4, 130}
#: Longest time one input may take, s (the slowest, a validate with its report, takes ~4 s here).
SECONDS_PER_INPUT = 60
#: The positions of every case the fuzz runs a costly command on.
COARSE_ANGLES = {"start": 0.0, "stop": 360.0, "step": 30.0}

def _tree(folder: Path) -> dict[str, tuple[int, str]]:
    """Every entry below ``folder`` (links not followed): relative path -> (size, sha256 or link target)."""
    out = {}
    for path in sorted(folder.rglob("*")):
        if path.is_symlink():
            out[str(path.relative_to(folder))] = (0, "link:" + os.readlink(path))
        elif path.is_file():
            out[str(path.relative_to(folder))] = (path.stat().st_size,
                                                  hashlib.sha256(path.read_bytes()).hexdigest())
        else:
            out[str(path.relative_to(folder)) + "/"] = (0, "dir")
    return out


class Sandbox:
    """A working folder ``work`` (the commands' cwd) beside ``outside`` (a victim file and folder)."""

    def __init__(self, root: Path) -> None:
        self.root, self.work, self.outside = root, root / "work", root / "outside"
        self.outside.mkdir(exist_ok=True)
        (self.outside / "victim.txt").write_text("a user's file\n")
        (self.outside / "folder").mkdir(exist_ok=True)
        self.before = _tree(self.outside)

    @contextlib.contextmanager
    def fresh(self) -> Iterator[Path]:
        """A clean ``work`` folder as cwd for one input; afterwards, outside and the root are unchanged."""
        import shutil

        shutil.rmtree(self.work, ignore_errors=True)
        self.work.mkdir()
        old = Path.cwd()
        os.chdir(self.work)
        try:
            yield self.work
        finally:
            os.chdir(old)
        assert _tree(self.outside) == self.before, "something outside the working folder changed"
        assert sorted(p.name for p in self.root.iterdir()) == ["outside", "work"], "a file beside work"


@contextlib.contextmanager
def deadline(seconds: int) -> Iterator[None]:
    def expire(*_: Any) -> None:
        raise TimeoutError(f"no answer within {seconds} s: a hang")

    old = signal.signal(signal.SIGALRM, expire)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


def run(*args: str) -> tuple[int, str, str]:
    """``dualmech *args`` in this process: (exit code, stdout, stderr), checked against the property."""
    with deadline(SECONDS_PER_INPUT):
        result = CliRunner().invoke(main, list(args), catch_exceptions=True)
    if result.exception is not None and not isinstance(result.exception, SystemExit):
        raise AssertionError(f"dualmech {args!r} raised {result.exception!r}") from result.exception
    code, err = result.exit_code, result.stderr
    assert code in DOCUMENTED_EXITS, f"exit {code} from dualmech {args!r}: {err[-400:]!r}"
    lines = [line for line in err.splitlines() if line.strip()]
    raw = ("Traceback", "Warning:", "  File ")
    assert not any(mark in line for line in lines for mark in raw), err
    if code == 2:
        ours = [line for line in lines if line.startswith("dualmech: error:")]
        assert len(ours) == 1 and lines[-1] == ours[0], f"not one error line: {err[-600:]!r}"
        assert len(ours[0]) < 800, ours[0]
    return code, result.stdout, err


def toml_value(value: Any) -> str:
    """TOML text of a value the fuzz makes (NaN and infinities as TOML's own, keys quoted)."""
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        return ("inf" if value > 0 else "-inf") if math.isinf(value) else repr(value)
    if isinstance(value, int):
        return str(value) if abs(value) < 10**4000 else "1" + "0" * 4300
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{json.dumps(str(k))} = {toml_value(v)}" for k, v in value.items()) + " }"
    return json.dumps(str(value))


def toml_text(data: dict) -> str:
    """A TOML document of ``data``: its scalars first, then one ``[table]`` per dict."""
    head = [f"{json.dumps(str(k))} = {toml_value(v)}" for k, v in data.items() if not isinstance(v, dict)]
    tables = [f"[{json.dumps(str(k))}]\n" + "\n".join(f"{json.dumps(str(kk))} = {toml_value(vv)}"
                                                      for kk, vv in v.items())
              for k, v in data.items() if isinstance(v, dict)]
    return "\n".join(head + tables) + "\n"


def coarse(data: dict) -> dict:
    """``data`` with its crank angles at :data:`COARSE_ANGLES` when they are still a table."""
    motion = data.get("motion")
    if isinstance(motion, dict) and isinstance(motion.get("angles_deg", {}), dict):
        motion["angles_deg"] = dict(COARSE_ANGLES)
    return data


def assert_ok_rows_finite(path: Path) -> None:
    """No non-finite number in a row whose status is ``ok`` of the CSV table at ``path``."""
    with path.open() as fh:
        rows = list(csv.reader(fh))
    header, body = rows[0], rows[1:]
    status = header.index("status")
    for row in body:
        if row[status] == "ok":
            values = np.array([float(v) for i, v in enumerate(row) if i != status])
            assert np.all(np.isfinite(values)), f"non-finite value in an ok row: {row}"
