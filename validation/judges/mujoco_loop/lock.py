"""The rigid MuJoCo judge's own walk through a joint lock (``docs/conventions.md``, "Loop tables").

Where the drive still moves the loop through a singular pose (a joint lock), the sign of
:func:`~.closure.branch` changes on the curve followed.  :func:`cross_lock` walks the drive from the last good
regular pose to a row in ``LOCK_SUBSTEPS`` steps a row, each closed by the judge's own Newton from the secant
through the two poses before it, and is smooth when no closure corrects its secant by more than
``LOCK_CORRECTION`` of the step before it (``core/thresholds.py``); at an edge of assembly the walk fails to
close, or lands on another assembly with a correction of the order of the pose.  :func:`regular` tells a pose
off every lock and limit.  Nothing of the in-house engine is used.
"""

from __future__ import annotations

import mujoco
import numpy as np

from dualmech.core.status import Status
from dualmech.core.thresholds import LOCK_CORRECTION, REGULAR_POSE
from dualmech.validation.judges.mujoco_loop.closure import (
    MjLoop,
    close,
    cut_rows,
    gauge_rows,
    positions,
    prescribe,
)

#: A pose of the judge: its ``qpos``, cut coordinates and the drive values it was closed at.
Pose = tuple[np.ndarray, np.ndarray, dict[str, float]]


def regular(lp: MjLoop) -> bool:
    """Whether the current pose is off every lock and limit: the singular values' ratio of the cut and gauge
    rows over the free columns (the matrix of :func:`~.closure.branch`) at least ``REGULAR_POSE``."""
    positions(lp)
    sv = np.linalg.svd(np.vstack([cut_rows(lp), gauge_rows(lp)])[:, lp.free], compute_uv=False)
    return bool(sv[-1] >= REGULAR_POSE.value * sv[0])


def _difference(lp: MjLoop, a: Pose, b: Pose) -> np.ndarray:
    """The step ``(n_u,)`` in velocity space from pose ``a`` to pose ``b``."""
    dq = np.empty(lp.model.nv)
    mujoco.mj_differentiatePos(lp.model, dq, 1.0, a[0], b[0])
    return np.concatenate([dq, b[1] - a[1]])


def _distance(lp: MjLoop, a: Pose, b: Pose) -> float:
    """The largest change of a free coordinate from ``a`` to ``b`` (rad; a slide over the table's length)."""
    change = np.abs(_difference(lp, a, b))
    m = lp.model
    for j in range(m.njnt):
        if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_SLIDE:
            change[m.jnt_dofadr[j]] /= lp.size
    for i, name in enumerate(lp.cut):
        if name == "s":
            change[m.nv + i] /= lp.size
    return float(change[lp.free].max(initial=0.0))


def _secant(lp: MjLoop, before: Pose, here: Pose) -> None:
    """Set the pose ``here`` moved on by the step from ``before`` to ``here``."""
    step = _difference(lp, before, here)
    lp.data.qpos[:] = here[0]
    mujoco.mj_integratePos(lp.model, lp.data.qpos, step[:lp.model.nv], 1.0)
    lp.q_cut = here[1] + step[lp.model.nv:]


def cross_lock(lp: MjLoop, last: Pose, values: dict[str, float], substeps: int) -> tuple[int, float] | None:
    """Walk from the closed pose ``last`` to the drive ``values`` (module docstring): the walk's iterations
    and the last gap if it is smooth (then ``lp`` holds the pose closed at ``values``), else ``None``."""
    before, here, total, gap = None, last, 0, 0.0
    for k in range(1, substeps + 1):
        t = k / substeps
        at = {name: (1.0 - t) * last[2][name] + t * value for name, value in values.items()}
        if before is None:
            lp.data.qpos[:], lp.q_cut = here[0], here[1].copy()
        else:
            _secant(lp, before, here)
        guess = (lp.data.qpos.copy(), lp.q_cut.copy(), at)
        prescribe(lp, at)
        outcome, iterations, gap = close(lp)
        total += iterations
        if outcome != Status.OK:
            return None
        closed = (lp.data.qpos.copy(), lp.q_cut.copy(), at)
        if before is not None and _distance(lp, guess, closed) > \
                LOCK_CORRECTION.value * _distance(lp, before, here) + 1e-12:
            return None
        before, here = here, closed
    return total, gap
