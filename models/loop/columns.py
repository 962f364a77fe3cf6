"""The result table of a loop table: its columns, which a status word gives, the table every engine returns.

Every engine of a ``[mechanism] kind = "loop"`` case (the in-house :mod:`~dualmech.models.loop.table`, the
generated judges of :mod:`dualmech.validation.judges`) returns the same
:class:`~dualmech.models.tables.LinkageTable` of :func:`column_names` (``docs/conventions.md``,
"Loop tables"), so the linkages' gate compares them column by column with :func:`loop_spec`:

* the **key**: the driven coordinate in the file's units, ``theta<d>_deg`` (degrees) for an angle drive,
  else the slide ``s<d>`` itself (the rows' drive value; not compared);
* the **pose**: every scalar joint coordinate ``theta<i>``, ``s<i>``, ``eta<i>`` (rad, length); the
  report plots the last one that is not prescribed (the output) against the key;
* the **rates**: each one's ``_dot`` and ``_ddot`` (per s, per s²);
* ``closure_condition``: how far the pose is from an assembly limit
  (:func:`~dualmech.models.loop.condition.closure_condition` of the engine's own pose; 0 at the limit), given
  with the pose; where it is below :data:`~dualmech.core.thresholds.LOOP_LIMIT_CONDITION` an ``ok`` or
  ``dead_centre`` row becomes ``assembly_limit`` (pose given, rates and reactions not), or ``joint_lock``
  where the drive still moves the loop there (:func:`~dualmech.models.loop.condition.drive_condition` below
  :data:`~dualmech.core.thresholds.LOOP_LOCK_CONDITION`; it gives no value: at the lock a passive joint's
  coordinate is not determined, and near it every coordinate carries the closure's rounding over ``c``): one
  rule for every engine, made here;
* the **reactions**: the given and solved efforts ``effort_<coordinate><i>`` (torque about / force along
  joint ``i``'s axis on link ``i`` from link ``i-1``) and every joint's wrench ``joint<i>_f{x,y,z}``,
  ``joint<i>_m{x,y,z}`` (world axes, moment about the joint's point);
* then ``residual`` (closure, over the table's length) and ``dynamics_residual`` (not compared).

This module knows names only: it imports no engine, so the judges build their tables with it and stay
independent of the in-house engine.
"""

from __future__ import annotations

import numpy as np

from dualmech.core.status import ASSEMBLED, Status, is_status, settle
from dualmech.core.thresholds import LOOP_LIMIT_CONDITION, LOOP_LOCK_CONDITION
from dualmech.models.loop.condition import closure_condition, drive_condition
from dualmech.models.loop.description import LoopMechanism
from dualmech.models.tables import LinkageTable, TableSpec

#: The scalar coordinates of each joint type, in the order of its ``start`` values (an S joint has none).
COORDINATES: dict[str, tuple[str, ...]] = {"R": ("theta",), "P": ("s",), "C": ("theta", "s"),
                                           "U": ("theta", "eta"), "S": ()}
#: The closure condition's column (module docstring), compared with the pose.
CONDITION = "closure_condition"
#: The engine-fact columns after the compared ones (closure and dynamics residuals).
RESIDUALS: tuple[str, ...] = ("residual", "dynamics_residual")


def coordinate_names(mechanism: LoopMechanism) -> list[str]:
    """Every scalar joint coordinate of ``mechanism`` in loop order, e.g. ``["theta1", "theta3", "s3"]``."""
    return [f"{c}{i + 1}" for i, joint in enumerate(mechanism.joints) for c in COORDINATES[joint.type]]


def effort_names(mechanism: LoopMechanism) -> list[str]:
    """The efforts a table gives, given ones first, then the solved: a C drive's axial force (a reaction of
    its prescribed slide), then the one transmission effort (the drive's or a load's)."""
    d = mechanism.drive
    drive = f"{d.coordinate}{d.joint + 1}"
    given = [drive] if d.effort is not None else []
    given += [f"{load.coordinate}{load.joint + 1}" for load in mechanism.loads if load.value is not None]
    solved = [f"s{d.joint + 1}"] if mechanism.joints[d.joint].type == "C" else []
    solved += [drive] if d.effort is None else [f"{load.coordinate}{load.joint + 1}" for load in
                                                mechanism.loads if load.value is None]
    return given + solved


def key_column(mechanism: LoopMechanism) -> str:
    """The rows' key: ``theta<d>_deg`` for a drive by an angle, the slide ``s<d>`` for a drive by a slide."""
    d = mechanism.drive
    return f"theta{d.joint + 1}_deg" if d.coordinate == "theta" else f"s{d.joint + 1}"


def key_values(mechanism: LoopMechanism) -> np.ndarray:
    """The key column's values ``(n,)`` (:func:`key_column`): the drive's positions, an angle's in degrees."""
    d = mechanism.drive
    return np.degrees(d.positions) if d.coordinate == "theta" else np.asarray(d.positions, dtype=float)


def column_names(mechanism: LoopMechanism) -> list[str]:
    """The compared columns of ``mechanism``'s table in order (module docstring), without the key and the
    residuals: coordinates with their rates, efforts, joint wrenches."""
    names = [f"{c}{suffix}" for c in coordinate_names(mechanism) for suffix in ("", "_dot", "_ddot")]
    names += [f"effort_{e}" for e in effort_names(mechanism)]
    names += [f"joint{i + 1}_{kind}{axis}" for i in range(len(mechanism.joints)) for kind in "fm"
              for axis in "xyz"]
    return names


def wrench_columns(force: np.ndarray, moment: np.ndarray) -> dict[str, np.ndarray]:
    """``joint<i>_f{x,y,z}``, ``joint<i>_m{x,y,z}`` of every joint's force and moment, each
    ``(n, J, 3)`` (world axes), as ``(n,)`` columns."""
    return {f"joint{j + 1}_{kind}{axis}": vector[:, j, a] for j in range(force.shape[1])
            for kind, vector in (("f", force), ("m", moment)) for a, axis in enumerate("xyz")}


def loop_spec(mechanism: LoopMechanism) -> TableSpec:
    """The :class:`~dualmech.models.tables.TableSpec` of ``mechanism``'s table (module docstring)."""
    coordinates = coordinate_names(mechanism)
    compared = column_names(mechanism)
    key = key_column(mechanism)
    rates = tuple(f"{c}{suffix}" for c in coordinates for suffix in ("_dot", "_ddot"))
    reactions = tuple(c for c in compared if c.startswith(("effort_", "joint"))) + ("dynamics_residual",)
    columns = tuple(dict.fromkeys([key, *compared, CONDITION, *RESIDUALS]))
    prescribed = {f"{c}{j + 1}" for j, c in mechanism.prescribed}
    output = [c for c in coordinates if c not in prescribed][-1]
    return TableSpec(columns, (*coordinates, CONDITION), rates, reactions, key=key, output=output,
                     posed=ASSEMBLED - {Status.JOINT_LOCK})


def limit_words(mechanism: LoopMechanism, columns: dict[str, np.ndarray], status: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
    """The closure condition ``(n,)`` of the pose ``columns`` (NaN where the row's word gives no pose) and
    ``status`` with every ``ok`` or ``dead_centre`` row whose condition is below
    :data:`~dualmech.core.thresholds.LOOP_LIMIT_CONDITION` set to ``assembly_limit`` (a new array), unless
    the mechanism has its own rule (``mechanism.limits`` false: the words stay)."""
    status = np.array(status, dtype=object)
    posed = is_status(status, *ASSEMBLED)
    pose = {c: np.where(posed, np.asarray(columns[c], dtype=float), np.nan)
            for c in coordinate_names(mechanism)}
    with np.errstate(invalid="ignore"):
        condition = closure_condition(mechanism, pose)
        limit = is_status(status, Status.OK, Status.DEAD_CENTRE) & (condition < LOOP_LIMIT_CONDITION.value) \
            & mechanism.limits
        locked = np.zeros_like(limit)
        if limit.any():
            locked[limit] = drive_condition(mechanism, {c: v[limit] for c, v in pose.items()}) \
                < LOOP_LOCK_CONDITION.value
    status[limit] = np.where(locked[limit], Status.JOINT_LOCK.value, Status.ASSEMBLY_LIMIT.value)
    return condition, status


def loop_table(engine: str, mechanism: LoopMechanism, columns: dict[str, np.ndarray], status: np.ndarray,
               meta: dict, *, not_given: tuple[str, ...] = ()) -> LinkageTable:
    """The :class:`~dualmech.models.tables.LinkageTable` of one engine's answer, settled.

    Parameters
    ----------
    engine : str
        The engine's registry name (``dualmech``, ``pinocchio``, ``mujoco``).
    mechanism : LoopMechanism
    columns : dict of str -> numpy.ndarray, shape (n,)
        At least :func:`column_names` and :data:`RESIDUALS` (the key is made here from the drive).
    status : numpy.ndarray of str, shape (n,)
        The engine's words; an ``ok`` or ``dead_centre`` row at an assembly limit becomes
        ``assembly_limit`` (:func:`limit_words`), a row giving a non-finite value its word claims
        ``not_finite``, and every value a row's word does not give becomes NaN
        (:func:`~dualmech.core.status.settle`).
    meta : dict
        Engine facts (e.g. ``iterations``, ``messages``).
    not_given : tuple of str
        Columns the engine does not compute at all (NaN at every row, no row's word claims them: the
        simulation has no least-squares ``dynamics_residual``; a closure alone gives no rates or reactions).
    """
    spec = loop_spec(mechanism)
    condition, status = limit_words(mechanism, columns, status)
    columns = {**columns, spec.key: key_values(mechanism), CONDITION: condition}
    cols = {c: np.array(columns[c], dtype=float) for c in spec.columns}
    reactions = tuple(c for c in spec.reactions if c not in not_given)
    rates = tuple(c for c in spec.rates if c not in not_given)
    settled = settle(cols, status, reactions, pose=spec.pose, rates=rates)
    unposed = ~is_status(settled, *spec.posed)
    for name in spec.pose:  # a loop table's joint_lock gives no value (module docstring)
        cols[name][unposed] = np.nan
    return LinkageTable(engine, mechanism.name, cols, settled, meta)
