"""The tolerance of each (judge, quantity) of a matrix: from the file's ``[tolerances]``, else the defaults.

Tolerances are looked up, most specific first: ``[tolerances.<engine>]`` quantity, then its group
(``kinematics``, ``reactions``, ``stroke``, the status bands), then the same in ``[tolerances]``, then
:data:`DEFAULT_TOLERANCES`.  A value is a name in ``validation/tolerances.py`` or a number.
"""

from __future__ import annotations

from typing import Any

from dualmech.core.table import REACTION_COLUMNS
from dualmech.models.inputs import Range, key_text, show
from dualmech.validation import tolerances as tolerance_table
from dualmech.validation.engines import ENGINES
from dualmech.validation.matrix.data import COMPARABLE, MatrixError, ResolvedTolerance
from dualmech.validation.tolerances import Tolerance

#: Tolerance groups: every comparable column belongs to exactly one; ``stroke`` is the
#: stroke difference (max S4 - min S4) of a judge against the reference.
GROUPS: dict[str, tuple[str, ...]] = {
    "kinematics": tuple(c for c in COMPARABLE if c not in REACTION_COLUMNS),
    "reactions": REACTION_COLUMNS,
    "stroke": ("stroke",),
    # status agreement bands (validation/compare.py): not columns, but judged per engine like them
    "dead_centre_band": ("dead_centre_band",),
    "assembly_limit_band": ("assembly_limit_band",),
    # the largest widening near a universal joint's lock (validation/compare/joint_lock.py)
    "joint_lock_cap": ("joint_lock_cap",),
}
#: Pseudo-quantities of the status agreement rules (validation/compare.py), resolved per judge like columns.
STATUS_BANDS: tuple[str, ...] = ("dead_centre_band", "assembly_limit_band")
#: Pseudo-quantities that scale a judge's tolerances row by row (validation/compare/joint_lock.py).
FACTORS: tuple[str, ...] = ("joint_lock_cap",)
#: Default tolerance names (in ``validation/tolerances.py``) per engine and group;
#: ``"*"`` is every judge not listed.  The rigid-body judges are held to the
#: issues' figures (1e-10 kinematics, 1e-9 reactions); the simulation more loosely:
#: it integrates the motion under servos and holds the loop by a soft constraint.
DEFAULT_TOLERANCES: dict[str, dict[str, str]] = {
    "*": {
        "kinematics": "MATRIX_KINEMATICS",
        "reactions": "MATRIX_REACTIONS",
        "stroke": "MATRIX_KINEMATICS",
        "dead_centre_band": "DEAD_CENTRE_STATUS_BAND",
        "assembly_limit_band": "ASSEMBLY_LIMIT_STATUS_BAND",
        "joint_lock_cap": "RIGID_JOINT_LOCK_CAP",
    },
    "pinocchio": {
        "kinematics": "PINOCCHIO_KINEMATICS",
        "reactions": "PINOCCHIO_REACTIONS",
        "stroke": "PINOCCHIO_KINEMATICS",
        "dead_centre_band": "DEAD_CENTRE_STATUS_BAND",
        "assembly_limit_band": "ASSEMBLY_LIMIT_STATUS_BAND",
        "joint_lock_cap": "RIGID_JOINT_LOCK_CAP",
    },
    "mujoco": {
        "kinematics": "MUJOCO_RIGID_KINEMATICS",
        "reactions": "MUJOCO_RIGID_REACTIONS",
        "stroke": "MUJOCO_RIGID_KINEMATICS",
        "dead_centre_band": "DEAD_CENTRE_STATUS_BAND",
        "assembly_limit_band": "ASSEMBLY_LIMIT_STATUS_BAND",
        "joint_lock_cap": "RIGID_JOINT_LOCK_CAP",
    },
    "exudyn": {  # a loop table's judge only (a linkage matrix's): its Richardson-estimated error
        "kinematics": "EXUDYN_KINEMATICS",
        "reactions": "EXUDYN_REACTIONS",
        "stroke": "EXUDYN_KINEMATICS",
        "dead_centre_band": "DEAD_CENTRE_STATUS_BAND",
        "assembly_limit_band": "ASSEMBLY_LIMIT_STATUS_BAND",
        "joint_lock_cap": "RIGID_JOINT_LOCK_CAP",
    },
    "mujoco-sim": {
        "kinematics": "MATRIX_SIM_KINEMATICS",
        "reactions": "SIM_REACTIONS",
        "stroke": "SIM_STROKE",
        "dead_centre_band": "SIM_DEAD_CENTRE_STATUS_BAND",
        "assembly_limit_band": "SIM_ASSEMBLY_LIMIT_STATUS_BAND",
        "joint_lock_cap": "SIM_JOINT_LOCK_CAP",
    },
}

#: Tolerances given as numbers: relative, so from 0 to 1 (beyond 100 % says nothing).
TOLERANCE_VALUE = Range(0.0, 1.0, "a relative tolerance")


def _tolerance_value(spec: Any, where: str) -> ResolvedTolerance:
    if isinstance(spec, str):
        tol = getattr(tolerance_table, spec, None)
        if not isinstance(tol, Tolerance):
            names = sorted(n for n, v in vars(tolerance_table).items() if isinstance(v, Tolerance))
            raise MatrixError(
                f"{where}: {show(spec)} is not a tolerance in validation/tolerances.py ({', '.join(names)})"
            )
        return ResolvedTolerance(spec, float(tol.value), tol.reason)
    try:
        value = TOLERANCE_VALUE.check(where, spec)
    except ValueError as err:
        raise MatrixError(f"{err} (or a tolerance name)") from None
    return ResolvedTolerance(f"{where}", value, "set in the matrix file")


def _group_of(quantity: str) -> str:
    return next(g for g, cols in GROUPS.items() if quantity in cols)


def resolve_tolerances(
    table: Any, judges: tuple[str, ...], quantities: tuple[str, ...]
) -> dict[str, dict[str, ResolvedTolerance]]:
    """Each judge's tolerance for every quantity, the stroke and the status bands.

    Parameters
    ----------
    table : dict or None
        The matrix file's ``[tolerances]`` table: ``quantity|group = value|name`` for every judge and
        ``[tolerances.<engine>]`` sub-tables for one judge; ``None`` for none.
    judges : tuple of str
        Engine names to resolve for.
    quantities : tuple of str
        Compared columns (a subset of ``COMPARABLE``).

    Returns
    -------
    dict
        ``{judge: {quantity: ResolvedTolerance}}``; the most specific setting wins
        (judge.quantity, judge.group, quantity, group), else the judge's default of the group.

    Raises
    ------
    MatrixError
        An unknown engine, quantity or group, or a value that is neither a number nor a tolerance name.
    """
    table = {} if table is None else table
    if not isinstance(table, dict):
        raise MatrixError(f"tolerances: expected a table, got {show(table)}")
    general = {k: v for k, v in table.items() if not isinstance(v, dict)}
    per_engine = {k: v for k, v in table.items() if isinstance(v, dict)}
    _check_keys(general, per_engine)
    resolved: dict[str, dict[str, ResolvedTolerance]] = {}
    for e in judges:
        mine = per_engine.get(e, {})
        defaults = DEFAULT_TOLERANCES.get(e, DEFAULT_TOLERANCES["*"])
        resolved[e] = {}
        for q in (*quantities, "stroke", *STATUS_BANDS, *FACTORS):
            g = _group_of(q)
            for where, src, key in (
                (f"tolerances.{e}.{q}", mine, q),
                (f"tolerances.{e}.{g}", mine, g),
                (f"tolerances.{q}", general, q),
                (f"tolerances.{g}", general, g),
            ):
                if key in src:
                    resolved[e][q] = _tolerance_value(src[key], where)
                    break
            else:
                resolved[e][q] = _tolerance_value(defaults[g], f"default {g}")
    return resolved


def _check_keys(general: dict[str, Any], per_engine: dict[str, dict]) -> None:
    """Refuse an unknown engine, quantity or group in a ``[tolerances]`` table (one line)."""
    valid_keys = set(COMPARABLE) | set(GROUPS)
    for e, entries in per_engine.items():
        if e not in ENGINES:
            raise MatrixError(f"tolerances.{key_text(e)}: not an engine (valid: {', '.join(ENGINES)})")
        for k in entries:
            if k not in valid_keys:
                raise MatrixError(
                    f"tolerances.{e}.{key_text(k)}: not a quantity or group "
                    f"({', '.join(sorted(GROUPS))}, or a column)"
                )
    for k in general:
        if k not in valid_keys:
            raise MatrixError(
                f"tolerances.{key_text(k)}: not a quantity or group "
                f"({', '.join(sorted(GROUPS))}, or a column)"
            )


def group_tolerances(engine: str) -> dict[str, ResolvedTolerance]:
    """Judge ``engine``'s default ``kinematics`` and ``reactions`` tolerances (:data:`DEFAULT_TOLERANCES`): a
    kind's whose columns are its own (the RSSR, RCCC and loop tables:
    :mod:`~dualmech.validation.compare.tables`) is judged per group."""
    names = DEFAULT_TOLERANCES.get(engine, DEFAULT_TOLERANCES["*"])
    out = {}
    for group in ("kinematics", "reactions"):
        tol = getattr(tolerance_table, names[group])
        out[group] = ResolvedTolerance(names[group], float(tol.value), tol.reason)
    return out
