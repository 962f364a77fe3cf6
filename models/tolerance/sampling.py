"""Seeded samples of the varied keys, chunk by chunk, identical however the chunks are run.

Design ``i`` belongs to chunk ``i // CHUNK_DESIGNS``; chunk ``c`` draws from its own stream
``numpy.random.default_rng(SeedSequence(seed, spawn_key=(c,)))`` (what
``SeedSequence(seed).spawn`` gives its ``c``-th child), so a chunk's samples depend only on
``(seed, c)`` and the SPEC: the same for ``--jobs 1``, ``--jobs 2`` and a Dask cluster, and for a
study resumed after an interruption.  Within a chunk, keys are drawn in SPEC order, one
uniform ``(m,)`` block per key, mapped by the inverse CDF (so a truncated normal needs no
rejection and stays reproducible).
"""

from __future__ import annotations

import numpy as np
from scipy.special import ndtr, ndtri

from dualmech.models.tolerance.spec import Spec, Tolerance

#: Designs per chunk: the unit of parallel work, of resumption and of streaming to disk.  360
#: positions x 256 designs ~ 92k positions, nine of the solver's 10k-position batches.
CHUNK_DESIGNS = 256
#: Stream reserved for choosing the designs the judges re-solve (no chunk index reaches it).
JUDGE_STREAM = 2**32 - 1


def chunk_rng(seed: int, index: int) -> np.random.Generator:
    """The generator of chunk ``index`` (module docstring)."""
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(index,)))


def chunk_bounds(n: int, index: int) -> tuple[int, int]:
    """First and one-past-last design of chunk ``index`` of an ``n``-design study."""
    return index * CHUNK_DESIGNS, min(n, (index + 1) * CHUNK_DESIGNS)


def n_chunks(n: int) -> int:
    """How many chunks an ``n``-design study has."""
    return -(-n // CHUNK_DESIGNS)


def _offsets(t: Tolerance, u: np.ndarray) -> np.ndarray:
    """Offsets of one key from uniforms ``u`` in (0, 1) by the inverse CDF."""
    if t.dist == "uniform":
        return t.low + (t.high - t.low) * u
    if t.dist == "normal":
        return t.sd * ndtri(u)
    lo, hi = ndtr(t.low / t.sd), ndtr(t.high / t.sd)
    return np.clip(t.sd * ndtri(lo + (hi - lo) * u), t.low, t.high)


def sample_chunk(spec: Spec, nominal: np.ndarray, n: int, seed: int, index: int) -> np.ndarray:
    """Sampled values of every varied key for the designs of chunk ``index``, ``(m, k)``, key units.

    ``nominal`` ``(k,)`` are the case's values (:func:`~dualmech.models.tolerance.spec.nominal_values`).
    """
    lo, hi = chunk_bounds(n, index)
    rng = chunk_rng(seed, index)
    # (0, 1) open: random() is in [0, 1); 1 - random() is in (0, 1] -> clip the lone 0 edge away
    cols = [_offsets(t, np.clip(rng.random(hi - lo), np.finfo(float).tiny, 1.0 - 2**-53))
            for t in spec.tolerances]
    return nominal[None, :] + np.stack(cols, axis=1)


def judge_picks(k: int, seed: int, candidates: np.ndarray) -> np.ndarray:
    """``min(k, len(candidates))`` design indices drawn without replacement, sorted (seeded)."""
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(JUDGE_STREAM,)))
    if k <= 0 or candidates.size == 0:
        return np.zeros(0, dtype=int)
    return np.sort(rng.choice(candidates, size=min(k, candidates.size), replace=False))
