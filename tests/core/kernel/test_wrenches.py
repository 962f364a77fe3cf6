"""The compiled Newton-Euler solve on block-bidiagonal systems against numpy's QR (the numpy solver's
``_least_squares``): the solution, the relative residual and the transmission ``|R_kk| / |a_k|``, within
KERNEL_VS_NUMPY_LOOP of their peaks.

The kernel reflects each column only over the rows and columns the joints' links reach
(:func:`dualmech.core.kernel.wrenches_nb._householder_solve`); random systems of the engine's layout (a
joint's columns on the equations of its two links, constraint columns in row order, the solved efforts
last, one of them on the first link) check that nothing the band leaves out was needed.
"""

from __future__ import annotations

import numpy as np
import pytest

from dualmech.core.kernel.wrenches_nb import FORCE, MOMENT, SLIDE, TURN, _householder_solve
from tests.tolerances import KERNEL_VS_NUMPY_LOOP


def _system(rng: np.random.Generator, rows: int, efforts: list[int],
            extra: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``a`` ``(6 (rows - 1), k)``, ``b``, ``columns`` ``(k, 3)``: per joint 1 to 5 constraint columns
    (``extra`` joints' counts raised so that the system has about as many unknowns as equations), then one
    effort column per entry of ``efforts`` (its row), each column random on its links' equations."""
    m = 6 * (rows - 1)
    counts = rng.integers(1, 6, rows)
    counts[rng.permutation(rows)[:extra]] = 5
    while counts.sum() + len(efforts) > m:
        counts[np.argmax(counts)] -= 1
    columns = [(r, int(rng.choice([FORCE, MOMENT])), int(rng.integers(3))) for r in range(rows)
               for _ in range(counts[r])]
    columns += [(r, int(rng.choice([TURN, SLIDE])), 0) for r in efforts]
    a = np.zeros((m, len(columns)))
    for c, (r, _, _) in enumerate(columns):
        for link in (r - 1, r):
            if 0 <= link < rows - 1:
                a[6 * link:6 * link + 6, c] = rng.normal(size=6)
    return a, rng.normal(size=m), np.array(columns, dtype=np.int64)


def _numpy(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, float, float]:
    """Solution, relative residual, transmission (``_least_squares`` of
    :mod:`dualmech.core.loop_reactions`)."""
    q, r = np.linalg.qr(a)
    x = np.linalg.solve(r, q.T @ b)
    return x, np.linalg.norm(a @ x - b) / np.linalg.norm(b), abs(r[-1, -1]) / np.linalg.norm(a[:, -1])


@pytest.mark.parametrize("rows, efforts", [(4, [0, 3]), (4, [2]), (7, [0]), (7, [3, 6]), (9, [8, 1])])
def test_banded_solve_is_numpys_least_squares(rows: int, efforts: list[int]) -> None:
    rng = np.random.default_rng(rows * 10 + len(efforts))
    for extra in range(rows):
        a, b, columns = _system(rng, rows, efforts, extra)
        m, k = a.shape
        x = np.zeros(k)
        residual, transmission = _householder_solve(a, b, columns, np.zeros((m, k)), np.zeros(m), x)
        x_ref, residual_ref, transmission_ref = _numpy(a, b)
        np.testing.assert_allclose(x, x_ref, rtol=0, atol=KERNEL_VS_NUMPY_LOOP * np.abs(x_ref).max())
        np.testing.assert_allclose(residual, residual_ref, rtol=0, atol=KERNEL_VS_NUMPY_LOOP)
        np.testing.assert_allclose(transmission, transmission_ref, rtol=KERNEL_VS_NUMPY_LOOP, atol=0)
