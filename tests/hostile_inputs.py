"""Shared by the hostile-input tests (issues 11, 31): the bundled ideal case as a dict, the command line
run end to end in a subprocess, and the fuzz's hostile values and file mutations (hypothesis)."""

from __future__ import annotations

import copy
import subprocess
import sys
import tomllib
from pathlib import Path

from hypothesis import strategies as st

from dualmech.models.case import preset_path


def ideal_case() -> dict:
    """The bundled case ``ideal``, parsed from its TOML file (a fresh dict on every call)."""
    return tomllib.loads(preset_path("ideal").read_text())


def run_cli(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    """``python -m dualmech.cli *args`` in ``cwd``, output captured as text, 60 s at most."""
    return subprocess.run([sys.executable, "-m", "dualmech.cli", *args], capture_output=True,
                          text=True, cwd=cwd, timeout=60)


HOSTILE_NUMBERS = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0, -0.0, 1e300, -1e300, 1e308, -1e308, 1e160, 5e-324, 1e-300, 1e15, 1e16, 1e-15, 1e-16,
                     1e7, 1.0000001e7, 1e10, 1e6, -1e6, 360.0, 1e-7]),
    st.integers(min_value=-(10**400), max_value=10**400),
    st.integers(min_value=-1000, max_value=1000),
    st.booleans(),
)
HOSTILE_VALUES = st.one_of(
    HOSTILE_NUMBERS,
    st.text(max_size=30),
    st.lists(HOSTILE_NUMBERS, max_size=5),
    st.dictionaries(st.text(max_size=8), HOSTILE_NUMBERS, max_size=3),
    st.just("\x00/../x"),
)


def key_paths(node: object, prefix: tuple = ()) -> list[tuple]:
    """Every key path of a parsed TOML table (into tables and arrays)."""
    out = [prefix] if prefix else []
    if isinstance(node, dict):
        for k, v in node.items():
            out += key_paths(v, prefix + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            out += key_paths(v, prefix + (i,))
    return out


def mutate(data: dict, draw: st.DrawFn, count: int) -> dict:
    """``count`` edits of ``data``: replace, delete or scale a leaf, add a key, or change a table."""
    data = copy.deepcopy(data)
    for _ in range(count):
        paths = key_paths(data)
        path = draw(st.sampled_from(paths)) if paths else ()
        parent: object = data
        for k in path[:-1]:
            parent = parent[k]
        leaf = path[-1] if path else None
        old = parent[leaf] if path else None
        edit = draw(st.sampled_from(["replace", "replace", "scale", "delete", "add", "units"]))
        if edit == "replace" and path:
            parent[leaf] = draw(HOSTILE_VALUES)
        elif edit == "scale" and path and (isinstance(old, float) or type(old) is int and abs(old) < 2**53):
            parent[leaf] = old * draw(st.sampled_from([-1.0, 0.0, 1e-20, 1e-8, 1e8, 1e20, 1e150]))
        elif edit == "delete" and path:
            del parent[leaf]
        elif edit == "add" and isinstance(old, dict):
            old[draw(st.text(min_size=1, max_size=10))] = draw(HOSTILE_VALUES)
        elif edit == "units":
            data["units"] = draw(st.one_of(st.sampled_from(["m-kg-s", "mm-N-s", "SI", "inch-lbf-s "]),
                                           st.text(max_size=12)))
    return data
