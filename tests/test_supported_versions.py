"""CI installs the lower bounds pyproject.toml declares: .ci/constraints-lowest.txt pins exactly those."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _name(requirement: str) -> str:
    """The normalized distribution name of a requirement string (extras and markers dropped)."""
    return re.split(r"[\[<>=!~; ]", requirement, maxsplit=1)[0].lower().replace("_", "-")


def _lower_bounds() -> dict[str, str]:
    """``{name: lower bound}`` of every direct dependency, test extra included."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    requirements = project["dependencies"] + project["optional-dependencies"]["test"]
    bounds = {}
    for req in requirements:
        match = re.search(r">=\s*([0-9][0-9A-Za-z.]*)", req)
        assert match, f"pyproject.toml: {req!r} has no lower bound (>=) for CI to test"
        bounds[_name(req)] = match.group(1)
    return bounds


def _pins() -> dict[str, str]:
    """``{name: version}`` of .ci/constraints-lowest.txt."""
    pins = {}
    for line in (ROOT / ".ci" / "constraints-lowest.txt").read_text().splitlines():
        line = line.split("#", 1)[0].strip()
        if line:
            name, version = line.split("==")
            pins[_name(name)] = version.strip()
    return pins


def _same_release(a: str, b: str) -> bool:
    """2.0 and 2.0.0 are the same release."""
    def parts(v: str) -> list[int]:
        out = [int(p) for p in v.split(".")]
        while out and out[-1] == 0:
            out.pop()
        return out
    return parts(a) == parts(b)


def test_ci_installs_every_lower_bound_exactly():
    bounds, pins = _lower_bounds(), _pins()
    for name, bound in bounds.items():
        assert name in pins, f".ci/constraints-lowest.txt: no pin for {name} (pyproject.toml says >= {bound})"
        assert _same_release(pins[name], bound), (
            f".ci/constraints-lowest.txt: {name}=={pins[name]} but pyproject.toml says >= {bound}")
