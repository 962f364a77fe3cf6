"""The machine a run names (:func:`~dualmech.validation.provenance.machine`), against the operating system's
own tools: ``hostname``, ``nproc --all``, ``lscpu``, ``uname``."""

from __future__ import annotations

import shutil
import subprocess
import sys

import pytest

from dualmech.validation import provenance


def _tool(*args: str) -> str:
    if shutil.which(args[0]) is None:
        pytest.skip(f"no {args[0]} here")
    return subprocess.run(args, capture_output=True, text=True, check=True).stdout.strip()


def test_the_machine_is_what_the_systems_tools_say() -> None:
    machine = provenance.machine()
    assert set(machine) == {"host", "platform", "processor", "cpus", "python"}
    assert machine["host"] == _tool("hostname")
    assert machine["cpus"] == int(_tool("nproc", "--all"))
    assert machine["python"] == "{}.{}.{}".format(*sys.version_info[:3])
    assert _tool("uname", "-r") in machine["platform"] and _tool("uname", "-m") in machine["platform"]


def test_the_processor_is_lscpus_model_name() -> None:
    """``lscpu`` (util-linux) reads the model name from the CPU itself (``cpuid`` on x86) where it can."""
    lines = dict(line.split(":", 1) for line in _tool("lscpu").splitlines() if ":" in line)
    model = lines.get("Model name", "").strip() or _tool("uname", "-m")
    assert provenance.processor() == model
    assert provenance.machine()["processor"] == model
