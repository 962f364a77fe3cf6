"""Shared by the hostile-input tests (issue 11): the bundled ideal case as a dict, and the command line
run end to end in a subprocess."""

from __future__ import annotations

import subprocess
import sys
import tomllib
from pathlib import Path

from dualmech.models.case import preset_path


def ideal_case() -> dict:
    """The bundled case ``ideal``, parsed from its TOML file (a fresh dict on every call)."""
    return tomllib.loads(preset_path("ideal").read_text())


def run_cli(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    """``python -m dualmech.cli *args`` in ``cwd``, output captured as text, 60 s at most."""
    return subprocess.run([sys.executable, "-m", "dualmech.cli", *args], capture_output=True,
                          text=True, cwd=cwd, timeout=60)
