"""Shared test fixtures (the bundled thesis cases), the Hypothesis profiles, the end of the worker pools.

The closed-form kinematics oracle is ``tests/oracles.py``; test-only tolerances are in
``tests/tolerances.py``.

Hypothesis: the profile ``ci`` draws the same examples on every run (``derandomize``), so a red CI
run is reproducible and a green one is not luck; it is loaded when the environment variable ``CI``
is ``true`` (or ``HYPOTHESIS_PROFILE=ci``).  Locally the default profile explores new examples each
run and keeps failures in its example database.
"""

from __future__ import annotations

import os

import pytest
from hypothesis import HealthCheck, settings

from dualmech.models.case import Case, load_case, preset_names

settings.register_profile("ci", derandomize=True, deadline=None, print_blob=True,
                          suppress_health_check=[HealthCheck.too_slow])
settings.register_profile("dev", deadline=None)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE",
                                     "ci" if os.environ.get("CI", "").lower() == "true" else "dev"))


@pytest.fixture(scope="session")
def thesis_cases() -> list[Case]:
    return [load_case(n) for n in preset_names() if n.startswith("thesis/")]


def pytest_sessionfinish(session: pytest.Session, exitstatus: int) -> None:
    """End the worker pools the tests left for reuse, as a command does when it is done
    (:func:`~dualmech.validation.executors.end_all_pools`): left to the interpreter's teardown, a pool
    was collected after ``multiprocessing.util`` was gone ("Exception ignored in ... weakref_cb")."""
    from dualmech.validation.executors import end_all_pools

    end_all_pools()
