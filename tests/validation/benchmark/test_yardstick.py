"""The benchmark's closed-form yardstick computes the same outputs as the in-house kernel.

The speed ratio in ``dualmech benchmark`` is only meaningful if the yardstick does the same work to the
same answer: its closed-form S4 and rates and its own Newton-Euler elimination must agree with the kernel
(``validation/benchmark/rows.py``, ``agreement``: each group of columns relative to its peak).
"""

from __future__ import annotations

from dualmech.validation.benchmark import rows as benchmark
from dualmech.validation.benchmark.yardstick import YARDSTICK_COLUMNS
from tests.tolerances import KERNEL_VS_NUMPY_REACTIONS


def test_the_yardstick_agrees_with_the_kernel() -> None:
    cases = benchmark.random_cases(3, step_deg=5.0, seed=3)
    assert benchmark.agreement(cases) <= KERNEL_VS_NUMPY_REACTIONS


def test_a_yardstick_that_differs_is_seen(monkeypatch) -> None:
    real = benchmark.closed_form

    def faulty(cases):
        out = real(cases)
        out[0][YARDSTICK_COLUMNS.index("j2_fx")] *= 1.0 + 1e-6  # one reaction column a ppm off
        return out

    monkeypatch.setattr(benchmark, "closed_form", faulty)
    assert benchmark.agreement(benchmark.random_cases(3, step_deg=5.0, seed=3)) > KERNEL_VS_NUMPY_REACTIONS
