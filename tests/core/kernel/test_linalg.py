"""The compiled transposed solve (:func:`dualmech.core.kernel.linalg_nb.solve_transposed`) against numpy's:
``a^T x = b`` from the LU factors of ``a`` that the kernel's elimination leaves, row swaps included."""

from __future__ import annotations

import numpy as np
import pytest
from numba import njit

from dualmech.core.kernel.linalg_nb import factorize, solve_transposed
from tests.tolerances import KERNEL_LINALG


@njit
def _solve(a: np.ndarray, b: np.ndarray) -> tuple[bool, np.ndarray]:
    k = a.shape[0]
    sq, piv, out = np.zeros((k, k)), np.zeros(k, dtype=np.int64), np.zeros(k)
    lu = factorize(a, sq, np.zeros((3, k, k)), piv)
    solve_transposed(sq, piv, b, out)
    return lu, out


@pytest.mark.parametrize("k", [1, 2, 6, 7, 9])
def test_the_transposed_solve_is_numpys(k: int) -> None:
    rng = np.random.default_rng(k)
    for _ in range(20):
        a = rng.normal(size=(k, k)) + 3.0 * np.eye(k)[rng.permutation(k)]  # pivots off the diagonal
        b = rng.normal(size=k)
        ref = np.linalg.solve(a.T, b)
        lu, out = _solve(a, b)
        assert lu
        np.testing.assert_allclose(out, ref, rtol=0, atol=KERNEL_LINALG * np.abs(ref).max())
