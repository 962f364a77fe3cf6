"""The Exudyn judge's continuation along the drive: every row's word and closed pose, through joint locks.

From the start pose the loop is closed position by position, forward then backward, each from the previous
closed pose through :data:`~.closure.SUBSTEPS` intermediate positions.  The rows past a gap are walked to
from its edge as well, so they stay ``no_assembly``: the judge does not re-close the loop on an assembly its
continuation cannot reach (a direct Newton step from the edge closed the bundled ``7r`` on another of its
assemblies there).  A row, or an intermediate position, that closes with another sign of the square
Jacobian's determinant than the branch's (:func:`~.closure.branch_sign`) is ``branch_jump`` and not
followed, unless the loop passed a *joint lock* there (``docs/conventions.md``, "Loop tables"): where the
drive still moves the loop through a singular pose, the sign changes on the curve followed.  The judge tells
a lock by its own walk (:func:`cross_lock`): from the last good regular pose to the row in
``LOCK_SUBSTEPS`` steps a row, each closed from the secant through the two poses before it, smooth when no
closure corrects its secant by more than ``LOCK_CORRECTION`` of the step before it (``core/thresholds.py``);
a smooth walk that ends on a regular pose of the other sign turns the branch (the ``rrcrc`` passes one at
228.2 degrees, where its determinant's sign used to end its branch).  A row at the lock itself (a singular
pose) is ``ok`` once a walk past it succeeds, else ``branch_jump``.  Nothing of the in-house engine is used.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from dualmech.core.status import Status
from dualmech.core.thresholds import LOCK_CORRECTION, LOCK_ROWS, LOCK_SUBSTEPS, REGULAR_POSE
from dualmech.models.loop.description import LoopMechanism
from dualmech.validation.judges.exudyn_loop.closure import (
    SUBSTEPS,
    Pose,
    branch_sign,
    close_at,
    search_start,
    square_jacobian,
)


def regular(mechanism: LoopMechanism, pose: Pose) -> bool:
    """Whether ``pose`` is off every lock and limit: :func:`~.closure.square_jacobian`'s singular values'
    ratio at least ``REGULAR_POSE``."""
    square = square_jacobian(mechanism, pose)
    if square is None:
        return False
    sv = np.linalg.svd(square, compute_uv=False)
    return bool(sv[-1] >= REGULAR_POSE.value * sv[0])


def _distance(mechanism: LoopMechanism, a: Pose, b: Pose) -> float:
    """The largest change of a coordinate from ``a`` to ``b`` (rad; a slide over the table's length; an S
    joint's turn)."""
    moves = [abs(b.values[key] - v) / (mechanism.length if key[1] == "s" else 1.0)
             for key, v in a.values.items()]
    turns = [np.linalg.norm(Rotation.from_matrix(b.rotations[k] @ r.T).as_rotvec())
             for k, r in a.rotations.items()]
    return float(max(moves + turns, default=0.0))


def _secant(before: Pose, here: Pose) -> Pose:
    """``here`` moved on by the step from ``before`` to ``here``."""
    return Pose({key: 2.0 * v - before.values[key] for key, v in here.values.items()},
                {k: r @ before.rotations[k].T @ r for k, r in here.rotations.items()})


def cross_lock(mechanism: LoopMechanism, pose: Pose, start: float, end: float, substeps: int
               ) -> tuple[Pose, float] | None:
    """The pose closed at drive position ``end`` by a smooth walk from ``pose``, closed at ``start`` (module
    docstring), and its residual; ``None`` where a step does not close or corrects its secant by more than
    ``LOCK_CORRECTION`` of the step before it."""
    before, here, res = None, pose, 0.0
    for k in range(1, substeps + 1):
        guess = here if before is None else _secant(before, here)
        closed, word, res = close_at(mechanism, guess, start + (end - start) * k / substeps)
        if word != Status.OK.value:
            return None
        if before is not None and _distance(mechanism, guess, closed) > \
                LOCK_CORRECTION.value * _distance(mechanism, before, here) + 1e-12:
            return None
        before, here = here, closed
    return here, res


def _walk(mechanism: LoopMechanism, last: Pose, start: float, end: float, branch: int
          ) -> tuple[Pose, str, float]:
    """The row at drive position ``end`` closed from ``last`` (closed at ``start``) through
    :data:`~.closure.SUBSTEPS` intermediate positions: its pose, word and residual (``branch_jump`` where the
    row, or an intermediate position off a singular pose, closes with another sign than ``branch``)."""
    pose, word, res = last, Status.OK.value, np.nan
    for x in np.linspace(start, end, SUBSTEPS + 1)[1:]:
        pose, word, res = close_at(mechanism, pose, x)
        turned = word == Status.OK.value and branch_sign(mechanism, pose) != branch
        if turned and (x == end or regular(mechanism, pose)):
            word = Status.BRANCH_JUMP.value
        if word != Status.OK.value:
            break
    return pose, word, res


def continuation(mechanism: LoopMechanism) -> tuple[list[Pose | None], np.ndarray, np.ndarray, list[int]]:
    """Every row's closed pose (``None`` where it does not close), status word and scaled residual, from the
    start pose forward then backward, through joint locks (module docstring), and for each lock passed the
    row after it in the rows' order (a run of closed rows that passes a lock is judged in two,
    :mod:`.engine`)."""
    positions = mechanism.drive.positions
    n = positions.size
    start, at = search_start(mechanism)
    poses: list[Pose | None] = [None] * n
    status = np.full(n, Status.NOT_CONVERGED.value, dtype=object)
    res = np.full(n, np.nan)
    poses[at], status[at], res[at] = close_at(mechanism, start, positions[at])
    turns: list[int] = []
    if status[at] != Status.OK.value:
        poses[at] = None
        return poses, status, res, turns
    first = branch_sign(mechanism, poses[at])
    for order in (range(at + 1, n), range(at - 1, -1, -1)):
        last, steady, branch, singular = at, at, first, []
        for i in order:
            pose, word, res[i] = _walk(mechanism, poses[last], positions[last], positions[i], branch)
            status[i] = word
            if word == Status.OK.value:
                poses[i], last = pose, i
                steady = i if regular(mechanism, pose) else steady
                continue
            if word != Status.BRANCH_JUMP.value:
                continue
            if not regular(mechanism, pose):  # at the lock itself, or an edge: on no branch yet
                poses[i] = pose
                singular.append(i)
                continue
            rows = abs(i - steady)
            crossed = cross_lock(mechanism, poses[steady], positions[steady], positions[i],
                                 LOCK_SUBSTEPS * rows + 1) if rows <= LOCK_ROWS else None
            if crossed is None or branch_sign(mechanism, crossed[0]) != -branch \
                    or not regular(mechanism, crossed[0]):
                continue
            poses[i], res[i], status[i] = crossed[0], crossed[1], Status.OK.value
            status[[k for k in singular if min(i, steady) < k < max(i, steady)]] = Status.OK.value
            turns.append(max(i, steady))  # the lock lies before this row in the rows' order
            branch, last, steady = -branch, i, i
    return poses, status, res, turns
