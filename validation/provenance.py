"""Where a result came from: library versions, the machine, and fingerprints of code and inputs.

Every stored case result, ``run.json``, ``summary.json``, the JUnit file and the
report name the versions of dualmech, ``pin``, ``mujoco`` and numpy that produced
them (:func:`versions`).  A stored result carries a fingerprint of everything it
depends on (:func:`result_fingerprint`): the case's content, the engine and its
entry point, the versions of the engine's own libraries and the source of the
dualmech code, so ``validate --resume`` recomputes whatever any of them changed.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import json
import os
import platform
from importlib import metadata
from pathlib import Path
from typing import Any

#: Distributions whose versions a run records (engines and the libraries the report uses).
LIBRARIES: tuple[str, ...] = (
    "dualmech", "numpy", "scipy", "pin", "mujoco", "exudyn", "matplotlib", "jinja2", "rich", "click", "dask",
    "distributed",
)
#: The versions every result names (the issue's minimum: the suite and the judges' libraries).
KEY_LIBRARIES: tuple[str, ...] = ("dualmech", "pin", "mujoco", "numpy")
#: Libraries whose version can change an engine's numbers (besides numpy and the dualmech source).
ENGINE_LIBRARIES: dict[str, tuple[str, ...]] = {
    "dualmech": ("numpy", "scipy"),
    "pinocchio": ("numpy", "pin"),
    "mujoco": ("numpy", "mujoco"),
    "mujoco-sim": ("numpy", "mujoco"),
    "exudyn": ("numpy", "exudyn"),
}
#: The package folders whose source makes up "the dualmech code" (relative to the repository).
SOURCE_PACKAGES: tuple[str, ...] = ("core", "models", "validation")


@functools.lru_cache(maxsize=None)
def version_of(name: str) -> str:
    """Installed version of distribution ``name``, or ``"absent"`` (read once per process: reading a
    distribution's metadata parses its whole ``METADATA`` file, ~6 ms, and every task asks)."""
    try:
        return metadata.version(name)
    except metadata.PackageNotFoundError:
        return "absent"


def versions(names: tuple[str, ...] = LIBRARIES) -> dict[str, str]:
    """Installed versions of ``names`` (``"absent"`` if not installed)."""
    return {name: version_of(name) for name in names}


def key_versions(run: dict) -> dict[str, str]:
    """The :data:`KEY_LIBRARIES` versions a stored ``run.json`` recorded (``"unknown"`` where absent)."""
    return {name: run.get("versions", {}).get(name, "unknown") for name in KEY_LIBRARIES}


def machine() -> dict:
    """The computer a run happened on: ``host`` (its network name), ``platform`` (operating system,
    release, architecture), ``processor`` (:func:`processor`), ``cpus`` (logical processors, all of them,
    not only those this process may use) and ``python`` (its version)."""
    return {
        "host": platform.node(),
        "platform": platform.platform(),
        "processor": processor(),
        "cpus": os.cpu_count(),
        "python": platform.python_version(),
    }


def processor() -> str:
    """The processor's model name (Linux: ``/proc/cpuinfo``'s ``model name``, e.g. ``AMD EPYC``), else the
    machine's architecture (``x86_64``, ``aarch64``).

    Not :func:`platform.processor`: on Linux it runs ``uname -p`` (a process of its own, in every run),
    which says ``unknown`` on most systems."""
    with contextlib.suppress(OSError):
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as fh:
            for line in fh:
                key, _, value = line.partition(":")
                if key.strip() == "model name" and value.strip():
                    return value.strip()
    return platform.machine()


def _source_root() -> Path:
    import dualmech.core

    return Path(dualmech.core.__file__).resolve().parent.parent


@functools.lru_cache(maxsize=1)
def code_fingerprint() -> str:
    """SHA-256 (16 hex digits) of every ``.py`` and ``.toml`` file of the dualmech packages, path and
    content."""
    root = _source_root()
    digest = hashlib.sha256()
    for package in SOURCE_PACKAGES:
        for path in sorted((root / package).rglob("*")):
            if path.suffix in (".py", ".toml") and "__pycache__" not in path.parts:
                digest.update(str(path.relative_to(root)).encode())
                digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def _hash(data: Any) -> str:
    return hashlib.sha256(json.dumps(data, sort_keys=True, default=str).encode()).hexdigest()[:16]


def case_fingerprint(raw: dict) -> str:
    """Stable hash of a case definition (its content, independent of key order)."""
    return _hash(raw)


def result_fingerprint(raw: dict, engine: str, spec: str) -> dict[str, str]:
    """Everything one engine's stored result of one case depends on, as a JSON-ready dict.

    Two results are interchangeable only when their fingerprints are equal.
    """
    libraries = ENGINE_LIBRARIES.get(engine, ("numpy",))
    return {
        "case": case_fingerprint(raw),
        "engine": engine,
        "spec": spec,
        "libraries": ", ".join(f"{n} {version_of(n)}" for n in libraries),
        "code": code_fingerprint(),
    }
