r"""The tolerance plan of every kind whose result table has a TableSpec: the RSSR, the RCCC and loop tables.

**Keys** are the case table's own (``docs/conventions.md``, "Tolerance analysis"): every number it states,
addressed as the matrix format addresses them, rows of an array of tables by their 1-based index
(``"geometry.coupler"``, ``"joint[2].a"``, ``"body[1].mass"``, ``"load[1].value"``, ``"drive.speed"``);
not the words, the integers that name a row or a branch (:data:`FIXED`), the arrays (a start pose, an
inertia tensor, gravity) nor the drive's positions (:data:`POSITIONS`: every design is solved at the same
ones).  A sampled design is the case table with those keys set, read by the kind's own reader, so its
ranges are the reader's (a refused design stops the study with one line naming it).

**Outputs** per design, from the kind's :class:`~dualmech.models.tables.TableSpec`:

* ``range_<c>`` -- ``max c - min c`` over the assembled positions of the output coordinate ``c``
  (:attr:`~dualmech.models.tables.TableSpec.shown`: the RSSR's and RCCC's output angle in degrees,
  a loop table's last solved coordinate), an angle taken continuous along the positions (unwrapped by its
  period) so that a range across +-180 deg is not a full turn;
* ``peak_<load>`` -- for every load of :attr:`~dualmech.models.tables.TableSpec.loads` (each
  joint's force and moment, every scalar effort), the largest magnitude over the ``ok`` positions:
  ``peak_j1_force`` (``|(j1_fx, j1_fy, j1_fz)|``), ``peak_joint2_moment``, ``peak_drive_torque``,
  ``peak_effort_s4``; the given efforts among them are constant (the summary says so);
* the counts and the design's status of :mod:`~dualmech.models.tolerance.outputs`.

**Sensitivities.**  The table kinds' solvers are not carried through in complex arithmetic (a loop
record's joints refuse a complex number, ``core/loop.py`` reads a table's constants by ``float``, the
continuation compares real closure errors and branch signs, the compiled kernel is float64), so
their derivatives are central differences of the solver, Richardson-extrapolated
(:func:`~dualmech.models.tolerance.differences.central_differences`), at :data:`STEP` of the key's scale:

.. math:: D = \frac{q^2 D(h/2) - D(h)}{q^2 - 1}, \quad q = 2, \qquad
          |D - y'| \lesssim \frac{h^4}{\ell^4}\,|y| + \frac{\nu}{h},

with :math:`\nu \approx` a few ulps of the output its rounding, :math:`\ell` its scale of variation.  At
``h = 1e-3`` of the scale (itself at most the key's sd) the truncation term is negligible for any key whose
sd is small against its value, and the rounding :math:`\nu/h` a thousand times smaller than at the check's
step of 1e-6 (measured against the slider crank's exact complex-step derivatives of the same design solved
as a loop table: 5e-10 to 2e-8 relative).  Each output is taken at the fixed row(s) of its maximum in the
nominal design, as the slider crank's.  The study's sensitivity check then differences the solver again
at 1e-6 of the scale, with its own truncation and rounding bound, so a derivative is accepted only where
two steps three decades apart agree.
"""

from __future__ import annotations

import copy
import re
from dataclasses import replace
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from dualmech.core.status import STATUSES, Status
from dualmech.models.inputs import CaseError
from dualmech.models.kinds import KIND_HOMES, kind_of, resolve
from dualmech.models.linkages import table_spec
from dualmech.models.tables import TableSpec
from dualmech.models.tolerance.designs import design_name
from dualmech.models.tolerance.differences import central_differences
from dualmech.models.tolerance.outputs import (
    IS_ASSEMBLED,
    design_counts,
    position_counts,
    status_codes,
)
from dualmech.models.tolerance.plan import TableCase, TolerancePlan, in_house
from dualmech.models.tolerance.sensitivity import Sensitivities
from dualmech.models.tolerance.spec import Spec, check_varied
from dualmech.models.units import UNIT_SYSTEMS

#: Numbers of a case table that name a row, a branch or a coordinate, not a size: never varied.
FIXED = frozenset({"joint", "branch"})
#: Tables of a case table that set the drive positions every design is solved at: never varied.
POSITIONS = frozenset({"positions", "angles_deg"})
#: Step of the derivatives, relative to the key's scale (module docstring).
STEP = 1e-3
_STEP = re.compile(r"^(\w+)(?:\[(\d+)\])?$")
_OK = STATUSES.index(Status.OK)


def case_keys(data: dict, prefix: str = "") -> tuple[str, ...]:
    """Every key of case table ``data`` a SPEC may vary, in table order (module docstring)."""
    out: list[str] = []
    for key, value in data.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict) and key not in POSITIONS:
            out += case_keys(value, f"{name}.")
        elif isinstance(value, list) and value and all(isinstance(row, dict) for row in value):
            for i, row in enumerate(value, 1):
                out += case_keys(row, f"{name}[{i}].")
        elif isinstance(value, (int, float)) and not isinstance(value, bool) and key not in FIXED:
            out.append(name)
    return tuple(out)


def _keys(case: TableCase) -> tuple[str, ...]:
    return case_keys(case.raw)


def _node(data: dict, key: str) -> tuple[dict, str]:
    """The table holding ``key`` (one of :func:`case_keys`) in ``data``, and its last name."""
    *parents, leaf = key.split(".")
    node: Any = data
    for step in parents:
        name, row = _STEP.match(step).groups()
        node = node[name] if row is None else node[name][int(row) - 1]
    return node, leaf


def nominal_values(case: TableCase, spec: Spec) -> np.ndarray:
    """The case table's value of every varied key, ``(k,)``; a :class:`SpecError` naming the valid keys for
    one the table does not state."""
    check_varied(spec, _keys(case))
    return np.array([float(node[leaf]) for node, leaf in (_node(case.raw, k) for k in spec.keys)])


def design_table(case: TableCase, spec: Spec, values: np.ndarray, name: str) -> dict:
    """The case table with every varied key set to ``values`` ``(k,)`` and named ``name``."""
    data = copy.deepcopy(case.raw)
    for key, value in zip(spec.keys, values):
        node, leaf = _node(data, key)
        node[leaf] = float(value)
    data["name"] = name
    return data


def design(case: TableCase, spec: Spec, values: np.ndarray, name: str) -> Any:
    """The checked record of the design ``values``, by the kind's reader; a one-line CaseError naming the
    design where the reader refuses it."""
    try:
        return resolve(KIND_HOMES[kind_of(case.raw)].reader)(design_table(case, spec, values, name))
    except CaseError as err:
        raise CaseError(f"{name} (sampled from the SPEC): {err}") from None


def _spec(record: Any) -> TableSpec:
    return table_spec(kind_of(record), record)


def peak_name(label: str) -> str:
    """The output of a load of :attr:`~dualmech.models.tables.TableSpec.loads`: ``"j1 |f|"`` ->
    ``"peak_j1_force"``, ``"|drive_torque|"`` -> ``"peak_drive_torque"``."""
    joint, _, vector = label.partition(" ")
    if vector:
        return f"peak_{joint}_{'force' if vector == '|f|' else 'moment'}"
    return f"peak_{label.strip('|')}"


def _range_name(spec: TableSpec) -> str:
    return f"range_{spec.shown}"


def outputs(record: Any) -> tuple[str, ...]:
    """The outputs of a design of ``record``'s kind, in order (module docstring)."""
    spec = _spec(record)
    return (_range_name(spec), *(peak_name(label) for label, _, _ in spec.loads))


def units(case: TableCase) -> dict[str, str]:
    """Each output's unit under the case's unit label (``""`` where unstated; an angle range in the
    column's own unit, ``deg`` or ``rad``)."""
    spec = _spec(case.record)
    system = UNIT_SYSTEMS.get(case.units, UNIT_SYSTEMS["consistent"])
    shown = spec.shown
    group = spec.unit_group(shown)
    unit = "deg" if shown.endswith("_deg") else "rad" if group == "angle" else system.of(group)
    return {_range_name(spec): unit, **{peak_name(label): system.of(g) for label, _, g in spec.loads}}


def groups(record: Any) -> dict[str, tuple[str, ...]]:
    """The loads' unit groups: ``{"force": (...), "moment": (...)}``."""
    out: dict[str, tuple[str, ...]] = {"force": (), "moment": ()}
    for label, _, group in _spec(record).loads:
        out[group] += (peak_name(label),)
    return out


def _continuous(y: np.ndarray, valid: np.ndarray, period: float) -> np.ndarray:
    """``y`` ``(m, p)`` unwrapped along the positions by ``period`` over the ``valid`` rows (the others take
    the last valid value before them, so that a gap does not break the unwrapping)."""
    p = y.shape[1]
    last = np.maximum.accumulate(np.where(valid, np.arange(p), 0), axis=1)
    filled = np.nan_to_num(np.take_along_axis(y, last, axis=1))
    return np.unwrap(filled, period=period, axis=1)


def candidates(columns: Mapping[str, np.ndarray], codes: np.ndarray,
               spec: TableSpec) -> dict[str, tuple[np.ndarray, ...]]:
    """Per output, the values it is the extreme of, ``(m, p)`` each, masked: the range -> (the output
    coordinate where assembled else -inf, the same else +inf); every peak -> (its magnitude where ``ok`` and
    finite, else -inf,)."""
    shown = columns[spec.shown]
    assembled = IS_ASSEMBLED[codes] & np.isfinite(shown)
    period = spec.period(spec.shown)
    y = shown if period is None else _continuous(shown, assembled, period)
    ok = codes == _OK
    out = {_range_name(spec): (np.where(assembled, y, -np.inf), np.where(assembled, y, np.inf))}
    for label, cols, _ in spec.loads:
        magnitude = np.sqrt(sum(np.square(columns[c]) for c in cols))
        out[peak_name(label)] = (np.where(ok & np.isfinite(magnitude), magnitude, -np.inf),)
    return out


def _stacked(tables: Sequence[Any], spec: TableSpec) -> tuple[dict[str, np.ndarray], np.ndarray]:
    columns = {c: np.stack([t[c] for t in tables]) for c in spec.columns}
    return columns, status_codes(np.stack([np.asarray(t.status, dtype=str) for t in tables]))


def table_outputs(tables: Sequence[Any], record: Any) -> dict[str, np.ndarray]:
    """Every output, count and the status of the designs whose result tables (over the same drive
    positions) are ``tables``, ``(m,)`` each (module docstring)."""
    spec = _spec(record)
    columns, codes = _stacked(tables, spec)
    out = {}
    for name, values in candidates(columns, codes, spec).items():
        hi = values[0].max(axis=1)
        value = hi - values[1].min(axis=1) if len(values) > 1 else hi
        out[name] = np.where(np.isfinite(value), value, np.nan)
    return {**out, **design_counts(position_counts(codes))}


def _solved(solve: Callable[[Any], Any], record: Any) -> Any | None:
    """``record``'s table, or ``None`` where the solver refuses it in one line (a loop table whose start pose
    does not close the loop: no position assembles on the branch it would follow)."""
    try:
        return solve(record)
    except ValueError:
        return None


def _unassembled(like: Any) -> Any:
    """A table like ``like`` in which no position assembles: every value NaN, every status ``no_assembly``."""
    columns = {c: np.full(len(like), np.nan) for c in like.columns}
    return replace(like, columns=columns, status=np.full(len(like), Status.NO_ASSEMBLY.value, dtype=object))


def analyse(case: TableCase, spec: Spec, x: np.ndarray, first: int) -> dict[str, np.ndarray]:
    """Every output of the sampled designs ``x`` ``(m, k)``: each built by the kind's reader and solved by
    its in-house solver (every drive position of a design at once); a design the solver refuses
    (:func:`_solved`) is counted as assembling at no position."""
    solve = in_house(case.record)
    tables = [_solved(solve, design(case, spec, row, design_name(first + i))) for i, row in enumerate(x)]
    if any(t is None for t in tables):
        none = _unassembled(solve(case.record))
        tables = [none if t is None else t for t in tables]
    return table_outputs(tables, case.record)


def peak_rows(table: Any, record: Any) -> dict[str, tuple[int, ...]]:
    """The row(s) of ``table`` behind every output: the range's maximum and minimum, each peak's maximum;
    ``()`` where the output has none."""
    spec = _spec(record)
    columns, codes = _stacked([table], spec)
    out = {}
    for name, values in candidates(columns, codes, spec).items():
        rows = (int(np.argmax(values[0][0])),) + ((int(np.argmin(values[1][0])),) if len(values) > 1 else ())
        out[name] = rows if all(np.isfinite(v[0, r]) for v, r in zip(values, rows)) else ()
    return out


def points(case: TableCase, spec: Spec, sens: Sensitivities, x: np.ndarray) -> dict[str, np.ndarray]:
    """Every output of the designs ``x`` ``(m, k)`` at the drive positions of its derivative
    (``sens.positions_deg``, values of the table's key), ``(m,)`` each: each design solved over every
    position (its branch followed from the same start), the output read at those rows."""
    solve = in_house(case.record)
    tables = [solve(design(case, spec, row, "difference")) for row in x]
    tspec = _spec(case.record)
    columns, codes = _stacked(tables, tspec)
    key = tables[0][tspec.key]
    out = {}
    for name, values in candidates(columns, codes, tspec).items():
        rows = [int(np.flatnonzero(key == p)[0]) for p in sens.positions_deg[name]]
        if not rows:
            out[name] = np.full(x.shape[0], np.nan)
            continue
        picked = [np.where(np.isfinite(v[:, r]), v[:, r], np.nan) for v, r in zip(values, rows)]
        out[name] = picked[0] - picked[1] if len(picked) > 1 else picked[0]
    return out


def sensitivities(case: TableCase, spec: Spec, table: Any) -> Sensitivities:
    """``d output / d key`` of every output at the nominal design (its table ``table``), by Richardson's
    central differences of the solver at :data:`STEP` (module docstring)."""
    rows = peak_rows(table, case.record)
    key = table[_spec(case.record).key]
    solved = table_outputs([table], case.record)
    nominal = {n: float(solved[n][0]) for n in outputs(case.record)}
    at = Sensitivities({}, nominal, {n: [float(key[r]) for r in where] for n, where in rows.items()})
    diffs = central_differences(case, spec, at, PLAN, STEP)
    values = {n: dict(zip(spec.keys, map(float, d))) for n, d in diffs.value.items()}
    return Sensitivities(values, nominal, at.positions_deg)


def masses(case: TableCase) -> str:
    """``"body masses: 0.4, 0.9, 1.5 kg"``: the moving bodies' masses in loop order (no unit when the units
    are unstated)."""
    unit = UNIT_SYSTEMS.get(case.units, UNIT_SYSTEMS["consistent"]).mass
    return f"body masses: {', '.join(f'{b.mass:.6g}' for b in case.record.bodies)} {unit}".rstrip()


def _mode(record: Any) -> str:
    """The load mode in ``summary.json``: the RSSR's (``torque``: drive torque given, or ``output``), else
    the kind (``rccc``, ``loop``: their given and solved efforts are among the outputs)."""
    return getattr(record, "mode", kind_of(record))


PLAN = TolerancePlan(
    keys=_keys,
    nominal_values=nominal_values,
    design=design,
    outputs=outputs,
    units=units,
    groups=groups,
    mode=_mode,
    table_outputs=table_outputs,
    analyse=analyse,
    sensitivities=sensitivities,
    points=points,
    masses=masses,
    method=f"central differences of the solver, Richardson, step {STEP:g} of the key's scale",
)

