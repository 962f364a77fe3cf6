"""The benchmark's time inside an engine (:func:`dualmech.validation.benchmark.rows.library_time`), the main
job's
timing and the performance page.

No timing of the suite itself: a sleep stands for a library function whose time is known, a fake clock and
fake processes for the main job.
"""

from __future__ import annotations

import time
import types

from dualmech.validation.benchmark import rows as benchmark
from dualmech.validation.benchmark.rows import library_time


def test_library_time_counts_the_library_functions_alone_and_restores_them() -> None:
    """Time in the module's functions of the given type is counted, time outside them is not, its classes
    stay classes, and every function is itself again afterwards."""
    lib = types.ModuleType("lib")
    lib.wait, lib.size, lib.Table = time.sleep, len, dict
    start = time.perf_counter()
    with library_time(lib, time.sleep) as spent:
        lib.wait(0.05)
        assert lib.size([1, 2]) == 2 and lib.Table is dict
        outside = time.perf_counter()
        time.sleep(0.05)  # not through the library
        outside = time.perf_counter() - outside
    assert 0.05 <= spent[0] <= time.perf_counter() - start - outside
    assert (lib.wait, lib.size) == (time.sleep, len)


def test_the_performance_page_names_the_command_that_wrote_it() -> None:
    page = benchmark.performance_page("| a | b |", "dualmech benchmark -o docs/performance.md")
    assert page.startswith("# Performance\n")
    assert "one run of `dualmech benchmark -o docs/performance.md` on 20" in page
    assert page.endswith("| a | b |\n")
