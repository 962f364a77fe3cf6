"""Expanding a matrix's sweeps into concrete cases: one per (load mode, sweep point), each id once.

A case's id is its load mode and the keys it changes from the base case (``torque_a4=10_S1=3.5``),
with the short symbols of ``[labels]``; a case that several sweeps produce is run once and belongs
to all.  A load mode sets one of ``loads.drive_torque`` / ``loads.slider_force`` and removes the
other from the base case.
"""

from __future__ import annotations

import itertools
import math
import re
from typing import Any, NamedTuple

from dualmech.models.case import Case, case_from_dict
from dualmech.models.inputs import key_text, show
from dualmech.validation.matrix.data import (
    MAX_MATRIX_CASES,
    MAX_VALIDATE_POSITIONS,
    MatrixCase,
    MatrixError,
    Sweep,
    check_file_name,
)

#: Short symbols for the thesis's link-joint constants (ids and legends).
DEFAULT_LABELS: dict[str, str] = {
    "geometry.crank_length": "a1",
    "geometry.rod_length": "a2",
    "geometry.slider_offset": "a4",
    "geometry.slider_twist_deg": "alpha4",
    "geometry.crank_axial_shift": "S1",
    "loads.drive_torque": "T",
    "loads.slider_force": "F",
}
LOAD_KEYS = ("loads.drive_torque", "loads.slider_force")

ID_SAFE = re.compile(r"[^A-Za-z0-9.=+_-]")


def flatten(table: Any, where: str, *, leaf_lists: bool = False) -> dict[str, Any]:
    """``{"a": {"b": 1}, "c.d": 2}`` -> ``{"a.b": 1, "c.d": 2}`` (TOML dotted or quoted keys).

    With ``leaf_lists`` the leaves are lists of values (a grid axis), and nesting stops there.
    """
    if not isinstance(table, dict):
        raise MatrixError(f"{where}: expected a table of dotted case keys, got {show(table)}")
    flat: dict[str, Any] = {}

    def walk(node: dict, prefix: str) -> None:
        for key, value in node.items():
            dotted = f"{prefix}.{key}" if prefix else key
            if isinstance(value, dict) and not (leaf_lists is False and _is_case_table(dotted)):
                walk(value, dotted)
            else:
                if dotted in flat:
                    raise MatrixError(f"{where}.{key_text(dotted)}: given twice")
                flat[dotted] = value

    walk(table, "")
    if leaf_lists:
        for key, value in flat.items():
            if not isinstance(value, list) or not value:
                raise MatrixError(
                    f"{where}.{key_text(key)}: expected a non-empty array of values, got {show(value)}"
                )
    return flat


def _is_case_table(dotted: str) -> bool:
    """Case keys whose value is itself a table (set as a whole, not flattened further)."""
    return dotted in {"motion.angles_deg"} or (
        dotted.startswith("bodies.")
        and dotted.count(".") == 1
        and dotted.split(".")[1] in {"crank", "rod", "slider"}
    )


def _format_value(v: Any) -> str:
    if isinstance(v, bool):
        return str(v).lower()
    if isinstance(v, float) or (isinstance(v, int) and v.bit_length() <= 1000):  # larger: no float
        return f"{v:g}"
    if isinstance(v, str):  # a word (a joint type): as written, without quotes
        return ID_SAFE.sub("_", v)[:24]
    return ID_SAFE.sub("_", show(v))[:24]


def _check_positions(case_id: str, case: Case) -> None:
    """Refuse a case with more crank positions than :data:`MAX_VALIDATE_POSITIONS` (one line)."""
    n = int(case.motion.angles_deg.size)
    if n > MAX_VALIDATE_POSITIONS:
        raise MatrixError(
            f"case {case_id}: motion.angles_deg gives {n:,} crank positions; a validation run "
            f"compares whole tables, at most {MAX_VALIDATE_POSITIONS:,} per case (use a coarser step, "
            "or `dualmech solve`, which streams any length)"
        )


def _expected(expect: str | None) -> str:
    return "to assemble" if expect is None else f"{expect!r}"


def _canonical(updates: dict[str, Any], base_raw: dict, order: list[str]) -> dict[str, Any]:
    """Updates that change the base case, in a stable key order."""
    out = {}
    for key in sorted(updates, key=order.index):
        node: Any = base_raw
        for part in key.split("."):
            node = node.get(part, _MISSING) if isinstance(node, dict) else _MISSING
        if node is _MISSING or node != updates[key]:
            out[key] = updates[key]
    return out


_MISSING = object()


def with_mode(base: Case, mode_updates: dict[str, Any]) -> Case:
    """The base case switched to a load mode: the other load key is removed first.

    A case takes exactly one of the two loads, so this step cannot go through
    :meth:`Case.with_values`, which only sets keys; the remaining keys of the mode do.
    Without a load key (a matrix without ``[load_modes]``) the base case keeps its load.
    """
    load_key = next((k for k in LOAD_KEYS if k in mode_updates), None)
    if load_key is None:
        return base.with_values({**mode_updates, "name": base.name})
    raw = {k: (dict(v) if isinstance(v, dict) else v) for k, v in base.raw.items()}
    loads = {k: v for k, v in raw.get("loads", {}).items() if f"loads.{k}" not in LOAD_KEYS}
    loads[load_key.split(".")[1]] = mode_updates[load_key]
    raw["loads"] = loads
    rest = {k: v for k, v in mode_updates.items() if k != load_key}
    return case_from_dict(raw).with_values({**rest, "name": base.name})


def sweep_points(sweep: dict, where: str, room: int) -> tuple[list[dict[str, Any]], tuple[str, ...]]:
    """The update dicts of one sweep (fixed values merged in) and the keys it varies.

    ``room`` is how many more cases the matrix may hold; a larger sweep is refused
    before its points are built.
    """
    fixed = flatten(sweep.get("fixed", {}), f"{where}.fixed")
    has_grid, has_cases = "grid" in sweep, "cases" in sweep
    if has_grid == has_cases:
        raise MatrixError(f"{where}: give exactly one of grid (a Cartesian product) or cases (a list)")
    too_many = (
        f"{where}: more than {MAX_MATRIX_CASES:,} cases in the matrix (this sweep "
        "{} points); split it into several matrices"
    )
    if has_grid:
        grid = flatten(sweep["grid"], f"{where}.grid", leaf_lists=True)
        keys = tuple(grid)
        size = math.prod(len(v) for v in grid.values())
        if size > room:
            raise MatrixError(too_many.format(f"{size:,}"))
        points = [dict(zip(keys, combo)) for combo in itertools.product(*grid.values())]
    else:
        if not isinstance(sweep["cases"], list) or not sweep["cases"]:
            raise MatrixError(
                f"{where}.cases: expected a non-empty array of tables, got {show(sweep['cases'])}"
            )
        if len(sweep["cases"]) > room:
            raise MatrixError(too_many.format(f"{len(sweep['cases']):,}"))
        points = [flatten(p, f"{where}.cases[{i}]") for i, p in enumerate(sweep["cases"])]
        keys = tuple(dict.fromkeys(k for p in points for k in p))
    for p in points:
        clash = set(p) & set(fixed)
        if clash:
            raise MatrixError(f"{where}: {key_text(sorted(clash)[0])} is both fixed and swept")
    return [{**fixed, **p} for p in points], keys


class SweepSpec(NamedTuple):
    """One ``[[sweep]]`` table as parsed: its points are dotted-key updates of the base case."""

    name: str
    label: str
    keys: tuple[str, ...]  # the dotted keys it varies
    points: list[dict[str, Any]]
    include_base: bool
    expect: str | None


def expand_cases(
    base: Case,
    modes: dict[str, dict[str, Any]],
    specs: list[SweepSpec],
    labels: dict[str, str],
    base_label: str,
) -> tuple[tuple[MatrixCase, ...], tuple[Sweep, ...]]:
    """Every (load mode, sweep point) as a case, each id once, and the sweeps listing their case ids.

    Parameters
    ----------
    base : Case
        The base case (the matrix's ``set`` applied).
    modes : dict
        Load mode name -> its dotted-key updates (:func:`with_mode`).
    specs : list of SweepSpec
        The sweeps, in file order.
    labels : dict
        Short symbol per dotted key (case ids and legends).
    base_label : str
        How the base case is named in ids and legends.
    """
    appearance = list(dict.fromkeys(k for s in specs for p in s.points for k in p))
    known = list(DEFAULT_LABELS)
    order = sorted(
        appearance, key=lambda k: (known.index(k) if k in known else len(known), appearance.index(k))
    )
    book = _CaseBook(labels, base_label, order)
    ids_of: dict[str, dict[str, tuple[str, ...]]] = {s.name: {} for s in specs}
    for mode, mode_updates in modes.items():
        try:
            mode_base = with_mode(base, mode_updates)
        except ValueError as err:
            raise MatrixError(f"load_modes.{mode}: {err}") from None
        for spec in specs:
            added_base = [{}] if spec.include_base else []
            ids = [
                book.add(mode, mode_base, point, spec, in_sweep=k >= len(added_base))
                for k, point in enumerate(added_base + spec.points)
            ]
            ids_of[spec.name][mode] = tuple(dict.fromkeys(ids))
    sweeps = tuple(Sweep(s.name, s.label, s.keys, ids_of[s.name]) for s in specs)
    return book.matrix_cases(), sweeps


class _CaseBook:
    """The cases of a matrix as the sweeps produce them: each id once, with the sweeps it belongs to."""

    def __init__(self, labels: dict[str, str], base_label: str, order: list[str]) -> None:
        self.labels, self.base_label, self.order = labels, base_label, order
        self.cases: dict[str, dict] = {}

    def add(self, mode: str, mode_base: Case, point: dict[str, Any], spec: SweepSpec, in_sweep: bool) -> str:
        """Enter one point of sweep ``spec`` in load mode ``mode``; its case id.

        ``in_sweep``: a point of the sweep itself (its expectation applies), not the base case beside it.
        """
        values = _canonical(point, mode_base.raw, self.order)
        is_base = not values
        case_id = "_".join(
            [mode, self.base_label]
            if is_base
            else [mode] + [f"{self.labels.get(k, k)}={_format_value(v)}" for k, v in values.items()]
        )
        case_id = check_file_name(f"sweep {spec.name} ({mode}): case id", ID_SAFE.sub("_", case_id))
        if case_id not in self.cases:
            try:
                case = mode_base.with_values({**values, "name": case_id})
            except ValueError as err:
                raise MatrixError(f"sweep {spec.name} ({mode}): {err}") from None
            _check_positions(case_id, case)
            self.cases[case_id] = {
                "raw": case.raw,
                "mode": mode,
                "values": values,
                "sweeps": [],
                "labels": {},
                "is_base": is_base,
                "declared": {},
            }
        elif self.cases[case_id]["values"] != values:
            raise MatrixError(
                f"sweep {spec.name}: two different cases share the id {case_id!r}; set [labels]"
            )
        entry = self.cases[case_id]
        if in_sweep:
            entry["declared"][spec.name] = spec.expect
            if len(set(entry["declared"].values())) > 1:
                first, first_expect = next(iter(entry["declared"].items()))
                raise MatrixError(
                    f"sweep {spec.name}: case {case_id} is expected {_expected(spec.expect)} "
                    f"here but {_expected(first_expect)} by sweep {first}"
                )
        if spec.name not in entry["sweeps"]:
            entry["sweeps"].append(spec.name)
        shown = {k: v for k, v in values.items() if k in spec.keys} or values
        entry["labels"][spec.name] = (
            self.base_label
            if is_base
            else ", ".join(f"{self.labels.get(k, k)}={_format_value(v)}" for k, v in shown.items())
        )
        return case_id

    def matrix_cases(self) -> tuple[MatrixCase, ...]:
        """The cases in the order they were first produced."""
        return tuple(
            MatrixCase(
                cid,
                e["raw"],
                e["mode"],
                e["values"],
                tuple(e["sweeps"]),
                e["labels"],
                e["is_base"],
                next(iter(e["declared"].values()), None),
            )
            for cid, e in self.cases.items()
        )
