"""The Pinocchio judge's continuation along the drive: the branch followed, through joint locks.

The loop is closed position by position, forward then backward from the start, each from the last good
regular pose moved by the tangent (an Euler predictor along the drive: :func:`_predict`; a singular pose's
tangent is not its curve's). The branch is the sign of :func:`~.closure.branch`: it changes through a
singular pose, so a pose with another sign than the branch's is ``branch_jump`` and not continued from,
unless the loop passed a *joint lock* there (``docs/conventions.md``, "Loop tables"): where the drive still
moves the loop through a singular pose, the determinant changes sign on the curve followed. The judge tells
a lock by its own walk (:func:`cross_lock`): the drive walked from the last good regular pose to the row in
``LOCK_SUBSTEPS`` steps a row, each closed from the secant through the two poses before it, smooth when no
closure corrects its secant by more than ``LOCK_CORRECTION`` of the step before it (``core/thresholds.py``);
a smooth walk that ends on a regular pose of the other sign turns the branch. A row at the lock itself (a
singular pose) is closed on no branch: ``ok`` once the walk past it succeeds (the limit rule then names it),
else ``branch_jump``. Nothing of the in-house engine is used.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from dualmech.core.status import Status
from dualmech.core.thresholds import LOCK_CORRECTION, LOCK_ROWS, LOCK_SUBSTEPS, REGULAR_POSE
from dualmech.validation.judges.pinocchio_loop.closure import (
    Closure,
    branch,
    close_at,
    cut_rows,
    prescribed_motion,
    rate_matrix,
    search_start,
)
from dualmech.validation.judges.pinocchio_loop.model import LoopModel


def _predict(lm: LoopModel, q: np.ndarray, change: np.ndarray) -> np.ndarray:
    """``q`` moved along the loop's tangent by a change ``change`` of the prescribed coordinates."""
    _, jac, _ = cut_rows(lm, q)
    rows = rate_matrix(lm, jac)
    step = np.zeros(lm.model.nv)
    step[list(lm.prescribed)] = change
    step[list(lm.free)] = -np.linalg.lstsq(rows[:, list(lm.free)], rows @ step, rcond=None)[0]
    return pin.integrate(lm.model, q, step)


def regular(lm: LoopModel, q: np.ndarray) -> bool:
    """Whether ``q`` is off every lock and limit: the square rate matrix's singular values' ratio at least
    ``REGULAR_POSE``."""
    _, jac, _ = cut_rows(lm, q)
    sv = np.linalg.svd(rate_matrix(lm, jac)[:, list(lm.free)], compute_uv=False)
    return bool(sv[-1] >= REGULAR_POSE.value * sv[0])


def _distance(lm: LoopModel, a: np.ndarray, b: np.ndarray) -> float:
    """The largest change of a free coordinate from ``a`` to ``b`` (rad; a slide over the table's length)."""
    change = np.abs(pin.difference(lm.model, a, b))
    for (_, name), (_, v) in lm.coordinates.items():
        if name == "s":
            change[v] /= lm.length
    return float(change[list(lm.free)].max(initial=0.0))


def cross_lock(lm: LoopModel, q: np.ndarray, start: np.ndarray, end: np.ndarray,
               substeps: int) -> tuple[np.ndarray, float, int] | None:
    """The pose closed at the prescribed values ``end`` by a smooth walk from ``q``, closed at ``start``
    (module docstring): its pose, residual and the walk's iterations; ``None`` where a step does not close
    or corrects its secant by more than ``LOCK_CORRECTION`` of the step before it."""
    before, here, total, norm = None, q, 0, 0.0
    for k in range(1, substeps + 1):
        t = k / substeps
        guess = here if before is None else pin.integrate(lm.model, here,
                                                          pin.difference(lm.model, before, here))
        closed, word, norm, iterations = close_at(lm, guess, (1.0 - t) * start + t * end)
        total += iterations
        if word != Status.OK.value:
            return None
        if before is not None and _distance(lm, guess, closed) > \
                LOCK_CORRECTION.value * _distance(lm, before, here) + 1e-12:
            return None
        before, here = here, closed
    return here, norm, total


def close_loop(lm: LoopModel) -> Closure:
    """The loop closed at every drive position, its branch followed from the start pose through every joint
    lock (module docstring)."""
    values, _, _ = prescribed_motion(lm)
    n = values.shape[0]
    q0, at = search_start(lm, values)
    qs = np.full((n, lm.model.nq), np.nan)
    status = np.full(n, Status.NOT_CONVERGED.value, dtype=object)
    residual, iterations = np.full(n, np.nan), np.zeros(n, dtype=int)
    q, status[at], residual[at], iterations[at] = close_at(lm, q0, values[at])
    qs[at] = q
    if status[at] != Status.OK.value:
        return Closure(qs, status, residual, iterations)
    sign = branch(lm, q)
    for order in (range(at + 1, n), range(at - 1, -1, -1)):
        steady, singular = at, []  # the last good regular row: predicted from, and a walk starts there
        for i in order:
            guess = _predict(lm, qs[steady], values[i] - values[steady])
            qs[i], status[i], residual[i], iterations[i] = close_at(lm, guess, values[i])
            if status[i] != Status.OK.value or branch(lm, qs[i]) == sign:
                if status[i] == Status.OK.value and regular(lm, qs[i]):  # a singular pose's tangent is
                    steady = i                                          # not its curve's: not predicted from
                continue
            status[i] = Status.BRANCH_JUMP.value
            if not regular(lm, qs[i]):  # at the lock itself, or at an edge: closed on no branch yet
                singular.append(i)
                continue
            if abs(i - steady) > LOCK_ROWS:
                continue
            walk = cross_lock(lm, qs[steady], values[steady], values[i], LOCK_SUBSTEPS * abs(i - steady) + 1)
            if walk is None or branch(lm, walk[0]) != -sign or not regular(lm, walk[0]):
                continue
            qs[i], residual[i], iterations[i] = walk
            status[[k for k in singular if min(i, steady) < k < max(i, steady)]] = Status.OK.value
            status[i], sign, steady = Status.OK.value, -sign, i
    return Closure(qs, status, residual, iterations)
