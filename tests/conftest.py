"""Shared test fixtures (the bundled thesis cases), the Hypothesis profiles, the end of the worker pools.

The closed-form kinematics oracle is ``tests/oracles.py``; test-only tolerances are in
``tests/tolerances.py``.

The compiled kernel is loaded (or, with a cold numba cache, compiled, which takes minutes) once the
tests are collected, before the first test, with the command line's notice and progress on stderr
(:func:`pytest_collection_finish`): a first test that seems to hang for minutes is then explained.

Hypothesis: the profile ``ci`` draws the same examples on every run (``derandomize``), so a red CI
run is reproducible and a green one is not luck; it is loaded when the environment variable ``CI``
is ``true`` (or ``HYPOTHESIS_PROFILE=ci``).  Locally the default profile explores new examples each
run and keeps failures in its example database.
"""

from __future__ import annotations

import os

import pytest
from hypothesis import HealthCheck, Phase, settings

from dualmech.models.case import Case, load_case, preset_names

settings.register_profile("ci", derandomize=True, deadline=None, print_blob=True,
                          suppress_health_check=[HealthCheck.too_slow])
settings.register_profile("dev", deadline=None)
# `dualmech selftest`'s gate (validation/selftest/gate.py): the ci profile's examples, a failure reported as
# found (no shrinking: the gate needs the verdict, not the smallest example, and shrinking took most of a
# killed fault's time)
settings.register_profile("selftest", parent=settings.get_profile("ci"),
                          phases=[Phase.explicit, Phase.reuse, Phase.generate])
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE",
                                     "ci" if os.environ.get("CI", "").lower() == "true" else "dev"))


@pytest.fixture(scope="session")
def thesis_cases() -> list[Case]:
    return [load_case(n) for n in preset_names() if n.startswith("thesis/")]


def pytest_sessionfinish(session: pytest.Session, exitstatus: int) -> None:
    """End the worker pools the tests left for reuse, as a command does when it is done
    (:func:`~dualmech.validation.run.executors.end_all_pools`): left to the interpreter's teardown, a pool
    was collected after ``multiprocessing.util`` was gone ("Exception ignored in ... weakref_cb")."""
    from dualmech.validation.run.executors import end_all_pools

    end_all_pools()


@pytest.hookimpl(tryfirst=True)
def pytest_sessionstart(session: pytest.Session) -> None:
    """With pytest-xdist's workers (``-n``), load both compiled kernels here, in the controller, before
    the workers start (xdist starts them in its own ``pytest_sessionstart``, run last): a cold numba cache
    is then compiled once and every worker loads it, where each worker compiled both kernels itself at
    the same time (two compiles of ~3 CPU-minutes each, per worker)."""
    config = session.config
    if not getattr(config.option, "numprocesses", None) or hasattr(config, "workerinput"):
        return
    from dualmech.cli.progress import show_kernel_compiles
    from dualmech.models.slider_crank.kernel import load_kernel
    from dualmech.verbs import solve

    show_kernel_compiles()
    with config.pluginmanager.getplugin("capturemanager").global_and_fixture_disabled():
        load_kernel()
        solve("rscr")  # a loop table: the generic loop kernel's entry points


def pytest_collection_finish(session: pytest.Session) -> None:
    """Load the compiled kernel before the first test; a cold numba cache compiles it, with a notice and
    progress on stderr (:func:`dualmech.cli.progress.show_kernel_compiles`; pytest's capture is off
    between collection and the first test)."""
    if session.config.option.collectonly or not session.items:
        return
    from dualmech.cli.progress import show_kernel_compiles
    from dualmech.models.slider_crank.kernel import load_kernel

    show_kernel_compiles()
    load_kernel()
