"""The linkages' gate: every judge against the in-house reference, row by row and column by column.

The rules of the slider crank's gate (:mod:`dualmech.validation.compare`), on a linkage's own columns
(:class:`~dualmech.models.tables.TableSpec`), one :class:`~dualmech.validation.compare.Check` each:

* ``engine`` -- the judge ran (else a failing check with the first line of its error);
* ``status`` -- the judge's word equals the reference's at every row, and the judge neither says an
  engine failure (``not_converged``, ``not_finite``) nor gives a non-finite value where its word says the
  value is given.  ``branch_jump`` is a verdict here (:data:`LINKAGE_VERDICTS`), not a failure, and
  the same as ``no_assembly`` (:data:`BRANCH_GONE`).  No
  band: every linkage engine sets its words with the same
  :func:`~dualmech.models.linkages.rssr.status_words` from its own transmissions (measured: equal at
  every row of the bundled and random cases).  The reference gets its own ``status`` check (no engine
  failure, assembled somewhere);
* every compared column ``q`` -- on the rows where both engines give it,

  .. math:: r_i = |J_i - R_i| / s_g, \\qquad \\text{pass} \\iff n > 0,\\ \\max_i r_i \\le \\text{tol}

  with ``s_g`` the reference's largest ``|R|`` over those rows of every compared column of ``q``'s unit
  group (:meth:`~dualmech.models.tables.TableSpec.unit_group`: forces, moments, the output angle,
  its rates, ...), so no verdict depends on the unit system; angles differ modulo their period
  (:meth:`~dualmech.models.tables.TableSpec.period`: 360 in degrees, 2 pi for a loop table's in rad);
  a row where only one engine gives the value fails the column (``inf``).

Rows are matched on the spec's key (:attr:`~dualmech.models.tables.TableSpec.key`: the crank angle
in degrees, or a loop table's driven coordinate), which every message names.

Tolerances are the slider crank's defaults per judge and group (``kinematics``, ``reactions``) of
:data:`~dualmech.validation.matrix.tolerances.DEFAULT_TOLERANCES`: Pinocchio ``PINOCCHIO_*``, MuJoCo
``MUJOCO_RIGID_*``, the simulation ``MATRIX_SIM_KINEMATICS`` and ``SIM_REACTIONS``.  The linkages have no
condition factor (dead centres are flagged by their words), but a row's tolerance grows with its closure
condition ``c`` (a loop table's, the RSSR's, the RCCC's ``closure_condition``) by the law of
:func:`~dualmech.validation.compare.conditioning.closure_allowance`: ``tol + delta / c^k``, ``k`` the
column's order (:func:`closure_order`), where rounding amplified by the closure's conditioning beside an
assembly limit or a joint lock leaves a correct judge over ``tol`` (a slider crank table swept at 1 deg
through a joint lock: accelerations 3.7e-8 of the peak apart, allowed ``1e-4`` at most, at the band).
"""

from __future__ import annotations

import numpy as np

from dualmech.core.status import ASSEMBLED, RATES_GIVEN, Status, is_status
from dualmech.models.kinds import case_from_data, kind_of
from dualmech.models.linkages import table_spec
from dualmech.models.loop.columns import CONDITION
from dualmech.models.tables import LinkageTable, TableSpec
from dualmech.validation.compare.checks import first_line
from dualmech.validation.compare.conditioning import CLOSURE, closure_allowance, within
from dualmech.validation.compare.differences import column_notes, worst_row
from dualmech.validation.compare.pairs import case_pairs, column_group, looser
from dualmech.validation.compare.results import ENGINE, STATUS, VERDICTS, Check
from dualmech.validation.matrix.data import Matrix, MatrixCase, ResolvedTolerance
from dualmech.validation.matrix.tolerances import group_tolerances

#: The words of a row an engine answered: the slider crank's :data:`VERDICTS`, and ``branch_jump``, where a
#: loop table's followed branch has ended and the loop closes only on another assembly (a random RRRSR, seed
#: 5894, past its fold).  The judges' words must still equal the reference's at every row, so a reference
#: that jumps where its branch goes on fails its status check against every judge that goes on (a user's
#: RRCRC through its joint lock at 228.2 deg: ``tests/validation/test_user_tables.py``).
LINKAGE_VERDICTS: frozenset[str] = VERDICTS | {Status.BRANCH_JUMP}
#: Two words the status check takes as one: past the end of a loop table's followed branch, an engine that
#: closes the loop on another assembly says ``branch_jump``, one whose steps find no pose near its branch
#: says ``no_assembly``; both say that the followed branch is not there, and neither gives a value (a random
#: RRRSR, seed 5894: the in-house engine's ``branch_jump`` and the MuJoCo judge's ``no_assembly`` on the row
#: past the fold).
BRANCH_GONE: frozenset[str] = frozenset({Status.BRANCH_JUMP, Status.NO_ASSEMBLY})

#: The tolerance of status and engine checks: exact.
EXACT = ResolvedTolerance("exact", 0.0, "statuses must agree row by row, and the engine must run")


def compared_columns(spec: TableSpec, judge: LinkageTable) -> tuple[str, ...]:
    """The columns compared for ``judge``: kinematics, forces and moments of ``spec``, or the judge's own
    ``meta["gives"]`` (the simulation gives a few)."""
    every = spec.kinematics + spec.forces + spec.moments
    gives = judge.meta.get("gives")
    return every if gives is None else tuple(c for c in every if c in gives)


def unit_scales(reference: LinkageTable, judge: LinkageTable, spec: TableSpec,
                columns: tuple[str, ...]) -> dict[str, float]:
    """``s_g`` per unit group of ``columns``: the reference's largest ``|R|`` over the rows where both tables
    give the column; for a group that is zero throughout, the scale of its rates
    (:func:`zero_group_scale`)."""
    scales: dict[str, float] = {}
    for c in columns:
        both = np.isfinite(reference[c]) & np.isfinite(judge[c])
        group = spec.unit_group(c)
        scales[group] = max(scales.get(group, 0.0), float(np.max(np.abs(reference[c][both]), initial=0.0)))
    return {g: s or zero_group_scale(g, reference, spec) for g, s in scales.items()}


def _peak(reference: LinkageTable, spec: TableSpec, group: str) -> float:
    """The reference's largest finite ``|R|`` over every compared column of unit group ``group``."""
    columns = [c for c in spec.kinematics if spec.unit_group(c) == group]
    return max((float(np.max(np.abs(reference[c][np.isfinite(reference[c])]), initial=0.0)) for c in columns),
               default=0.0)


def zero_group_scale(group: str, reference: LinkageTable, spec: TableSpec) -> float:
    """The scale of a unit group that is zero throughout, from the rates of its kind: an angle's acceleration
    (a drive at constant speed) on ``w²``, a slide's on ``v²/L``, with ``w``, ``v``, ``L`` the reference's
    peaks of the angle rates, slide rates and slides; 1 (an absolute comparison) where those are zero too
    or for any other group.  Without it a constant-speed drive's ``theta1_ddot`` was compared in rad/s², so
    the verdict hung on the unit of time."""
    if group == "angle_ddot":
        scale = _peak(reference, spec, "angle_dot") ** 2
    elif group == "length_ddot":
        length = _peak(reference, spec, "length")
        scale = _peak(reference, spec, "length_dot") ** 2 / length if length > 0.0 else 0.0
    else:
        scale = 0.0
    return scale or 1.0


def reference_values(reference: LinkageTable, spec: TableSpec) -> dict:
    """What a baseline keeps of the reference table
    (:func:`~dualmech.validation.compare.baseline.run_summary`): per compared column its peak ``max |R|``
    over the rows that give it and its unit group's scale
    (:func:`unit_scales`), the ``length`` group's scale; no stroke (a linkage has no slider)."""
    columns = spec.kinematics + spec.forces + spec.moments
    scales = unit_scales(reference, reference, spec, columns)
    peaks = {c: float(np.max(np.abs(reference[c][np.isfinite(reference[c])]), initial=0.0)) for c in columns}
    return {"stroke": None, "peaks": peaks, "scales": {c: scales[spec.unit_group(c)] for c in columns},
            "length": scales.get("length", 0.0)}


def relative_differences(reference: LinkageTable, judge: LinkageTable, spec: TableSpec,
                         columns: tuple[str, ...]) -> dict[str, np.ndarray]:
    """``r_i`` of each column (module docstring), each ``(n,)``: NaN where neither table gives the value,
    ``inf`` where only one does."""
    scales = unit_scales(reference, judge, spec, columns)
    out = {}
    for c in columns:
        r_given, j_given = np.isfinite(reference[c]), np.isfinite(judge[c])
        with np.errstate(invalid="ignore"):
            delta = judge[c] - reference[c]
        period = spec.period(c)
        if period is not None:  # an angle: -180 and 180 deg (-pi and pi rad) are the same
            delta = np.mod(delta + period / 2.0, period) - period / 2.0
        rel = np.where(r_given & j_given, np.abs(delta) / scales[spec.unit_group(c)], np.nan)
        out[c] = np.where(r_given != j_given, np.inf, rel)
    return out


def worst(a: LinkageTable, b: LinkageTable, spec: TableSpec) -> dict[str, float]:
    """Per compared column (kinematics, forces, moments), the largest ``r_i`` of ``b`` against ``a``
    (:func:`relative_differences`; ``inf`` where one table gives a value and the other does not)."""
    rel = relative_differences(a, b, spec, spec.kinematics + spec.forces + spec.moments)
    return {c: float(np.max(np.where(np.isnan(r), 0.0, r), initial=0.0)) for c, r in rel.items()}


def _given_under(column: str, spec: TableSpec) -> frozenset[str]:
    """The status words under which an engine gives ``column`` (pose, rates, reactions)."""
    if column in spec.pose:
        return spec.posed
    return RATES_GIVEN if column in spec.rates else frozenset({Status.OK})


def _failures(table: LinkageTable, spec: TableSpec, columns: tuple[str, ...]
              ) -> tuple[np.ndarray, np.ndarray]:
    """Rows where ``table``'s engine failed: by its own word, and by a non-finite value its word gives."""
    failed = ~is_status(table.status, *LINKAGE_VERDICTS)
    non_finite = np.zeros(len(table), dtype=bool)
    for c in columns:
        non_finite |= is_status(table.status, *_given_under(c, spec)) & ~np.isfinite(table[c])
    return failed, non_finite & ~failed


def _at(spec: TableSpec, values: np.ndarray, limit: int = 4) -> str:
    """``"at theta1 = 10, 20 deg"``: the key's ``values`` (at most ``limit``, then a count)."""
    shown = ", ".join(f"{v:.6g}" for v in values[:limit])
    name, unit = spec.key_label
    more = f", ... ({values.size} rows)" if values.size > limit else ""
    return f"at {name} = {shown}{more}" + (f" {unit}" if unit else "")


def _failure_notes(who: str, table: LinkageTable, spec: TableSpec, failed: np.ndarray,
                   non_finite: np.ndarray) -> list[str]:
    """What ``who`` failed at: its failure words and its non-finite given values, with their input values."""
    key, words = table[spec.key], np.asarray(table.status, dtype=str)
    notes = [f"{who} says {w} {_at(spec, key[failed & (words == w)])}" for w in sorted(set(words[failed]))]
    if non_finite.any():
        notes.append(f"{who} gives a non-finite value {_at(spec, key[non_finite])}")
    return notes


def engine_check(case_id: str, engine: str, error: str) -> Check:
    """The failing ``engine`` check of an engine that raised ``error``."""
    nan = float("nan")
    return Check(case_id, engine, ENGINE, nan, nan, nan, EXACT, nan, 0, 0, 0, False, first_line(error))


def reference_check(case_id: str, reference: LinkageTable, spec: TableSpec) -> Check:
    """The reference's own ``status`` check: no engine failure, and assembled at some crank position."""
    failed, non_finite = _failures(reference, spec, spec.kinematics + spec.forces + spec.moments)
    bad = failed | non_finite
    notes = _failure_notes("the reference", reference, spec, failed, non_finite)
    if not is_status(reference.status, *ASSEMBLED).any() and not bad.any():
        notes.append("the reference assembles at no crank position")
        bad = np.ones(len(reference), dtype=bool)
    n_bad = int(bad.sum())
    return Check(case_id, reference.engine, STATUS, float(n_bad), float(n_bad), float("nan"), EXACT, 1.0,
                 len(reference), 0, n_bad, n_bad == 0, "; ".join(notes))


def status_check(case_id: str, reference: LinkageTable, judge: LinkageTable, spec: TableSpec,
                 columns: tuple[str, ...]) -> Check:
    """The judge's ``status`` check (module docstring); rows where the reference failed are left to
    :func:`reference_check`."""
    key = reference[spec.key]
    usable = ~np.logical_or(*_failures(reference, spec, columns))
    failed, non_finite = (rows & usable for rows in _failures(judge, spec, columns))
    rs, js = np.asarray(reference.status, dtype=str), np.asarray(judge.status, dtype=str)
    gone = is_status(rs, *BRANCH_GONE) & is_status(js, *BRANCH_GONE)
    mismatch = usable & ~failed & (rs != js) & ~gone
    notes = _failure_notes("the judge", judge, spec, failed, non_finite)
    for r_word, j_word in sorted(set(zip(rs[mismatch], js[mismatch]))):
        rows = mismatch & (rs == r_word) & (js == j_word)
        notes.append(f"reference {r_word}, judge {j_word} {_at(spec, key[rows])}")
    bad = failed | non_finite | mismatch
    n_bad = int(bad.sum())
    unassembled = usable & ~bad & ~is_status(rs, *ASSEMBLED)
    return Check(case_id, judge.engine, STATUS, float(n_bad), float(n_bad), float("nan"), EXACT, 1.0,
                 int(usable.sum()), int(unassembled.sum()), n_bad, n_bad == 0, "; ".join(notes))


def closure_order(column: str, spec: TableSpec) -> int:
    """The order ``k`` of ``column`` in the closure-condition law
    (:func:`~dualmech.validation.compare.conditioning.closure_allowance`): 1 a pose column, 2 a rate, 3 an
    acceleration or a reaction."""
    if column in spec.pose:
        return 1
    if column in spec.rates and not column.endswith("_ddot"):
        return 2
    return 3


def column_check(case_id: str, reference: LinkageTable, judge: LinkageTable, spec: TableSpec, column: str,
                 rel: np.ndarray, tol: ResolvedTolerance, scale: float) -> Check:
    """One column's check: some row compared, none given by one engine only, ``max r_i <= tol_i``; its
    ``worst_theta_deg`` is the key's value (``spec.key``) at the worst row.  A table with a
    ``closure_condition`` has the row's tolerance ``tol + a_i`` (module docstring): ``max_rel`` is then the
    row's difference scaled to ``tol`` (``r_i tol / tol_i``), and the detail names the law where it was
    needed."""
    theta = reference[spec.key]
    infinite, finite = np.isinf(rel), np.isfinite(rel)
    max_abs = float(np.max(rel[finite])) * scale if finite.any() else float("nan")
    laws = ""
    if tol.value > 0 and CONDITION in spec.pose:
        allowance = {CLOSURE: closure_allowance(closure_order(column, spec), reference, judge)}
        rel, needed, phrase = within(rel, finite, tol.value, 1.0, allowance)
        laws = f"{phrase} {_at(spec, theta[needed])}" if phrase else ""
    max_rel, at = worst_row(rel, finite, theta)
    one_sided = f"given by one engine only {_at(spec, theta[infinite])}" if infinite.any() else None
    notes = ([laws] if laws else []) + column_notes(bool(finite.any()), one_sided, max_rel, tol,
                                                    _at(spec, np.array([at])))
    assembled = is_status(reference.status, *ASSEMBLED) & is_status(judge.status, *ASSEMBLED)
    n_excluded = int((assembled & np.isnan(rel)).sum())
    passed = bool(finite.any()) and not infinite.any() and max_rel <= tol.value
    return Check(case_id, judge.engine, column, max_abs, max_rel, at, tol, scale, int(finite.sum()),
                 n_excluded, int(infinite.sum()), passed, "; ".join(notes))


def judge_checks(case_id: str, reference: LinkageTable, judge: LinkageTable, spec: TableSpec,
                 tolerances: dict[str, ResolvedTolerance] | None = None
                 ) -> tuple[list[Check], tuple[np.ndarray, ...] | None]:
    """Every check of one judge on one case, and per row its worst kinematic and reaction ``r_i`` (the key
    column ``spec.key`` and the two, each ``(n,)``, NaN where nothing was compared; for the report; ``None``
    when the rows differ).  ``reference`` is the in-house table at the judge's
    rows, or another judge's (a pair of judges, :mod:`~dualmech.validation.compare.pairs`): the columns
    compared are those both give; ``tolerances`` (``kinematics``, ``reactions``), the judge's own
    (:func:`~dualmech.validation.matrix.tolerances.group_tolerances`) by default."""
    theta = reference[spec.key]
    if len(judge) != len(reference) or not np.allclose(judge[spec.key], theta, rtol=0, atol=1e-9):
        detail = f"rows differ: {len(judge)} input values against the reference's {len(reference)}"
        nan = float("nan")
        return [Check(case_id, judge.engine, STATUS, nan, nan, nan, EXACT, nan, 0, 0, 0, False, detail)], None
    columns = tuple(c for c in compared_columns(spec, judge) if c in compared_columns(spec, reference))
    tols = tolerances or group_tolerances(judge.engine)
    group = {c: "kinematics" if c in spec.kinematics else "reactions" for c in columns}
    rel = relative_differences(reference, judge, spec, columns)
    scales = unit_scales(reference, judge, spec, columns)
    checks = [status_check(case_id, reference, judge, spec, columns)]
    checks += [column_check(case_id, reference, judge, spec, c, rel[c], tols[group[c]],
                            scales[spec.unit_group(c)]) for c in columns]
    worst = {g: _row_worst([rel[c] for c in columns if group[c] == g], len(theta))
             for g in ("kinematics", "reactions")}
    return checks, (theta, worst["kinematics"], worst["reactions"])


def _row_worst(ratios: list[np.ndarray], n: int) -> np.ndarray:
    """Per row, the largest of ``ratios`` (each ``(n,)``); NaN where none was compared."""
    if not ratios:
        return np.full(n, np.nan)
    stacked = np.stack(ratios)
    seen = ~np.isnan(stacked)
    return np.where(seen.any(0), np.max(np.where(seen, stacked, -np.inf), axis=0), np.nan)


def case_spec(mc: MatrixCase) -> TableSpec:
    """The :class:`~dualmech.models.tables.TableSpec` of matrix case ``mc``'s tables, by its kind."""
    case = case_from_data(mc.raw)
    return table_spec(kind_of(case), case)


def compare_table_case(matrix: Matrix, mc: MatrixCase, tables: dict[str, LinkageTable],
                       rows: dict[str, tuple[np.ndarray, ...]],
                       pairs: dict[tuple[str, str], list[tuple[str, Check]]]) -> list[Check]:
    """The checks of case ``mc`` of a kind with a table spec, whose reference answered (``tables``: engine ->
    its table): the reference's own, then every judge's (status, columns) at its tolerances of
    ``matrix.tolerances`` (``kinematics``, ``reactions``; the defaults of
    :func:`~dualmech.validation.matrix.tolerances.group_tolerances` for a run stored without them); each
    judge's rows kept in ``rows``, each pair of engines added to ``pairs``
    (:func:`~dualmech.validation.compare.pairs.case_pairs`: two judges by :func:`judge_checks`, at the
    looser of their tolerances)."""
    reference, spec = tables[matrix.reference], case_spec(mc)
    tols = {e: _groups(matrix, e) for e in tables}
    checks = [reference_check(mc.id, reference, spec)]
    for e in matrix.judges:
        if e in tables:
            found, worst = judge_checks(mc.id, reference, tables[e], spec, tols[e])
            checks += found
            rows.update({e: worst} if worst is not None else {})
    case_pairs([e for e in matrix.engines if e in tables], matrix.reference, checks,
               lambda one, other: [reference_check(mc.id, tables[one], spec), *judge_checks(
                   mc.id, tables[one], tables[other], spec, looser(tols[one], tols[other]))[0]],
               lambda column: column_group(column, spec.pose, spec.rates), pairs)
    return checks


def _groups(matrix: Matrix, engine: str) -> dict[str, ResolvedTolerance]:
    """Judge ``engine``'s ``kinematics`` and ``reactions`` tolerances in ``matrix`` (the reference's: the
    defaults, used only when it is the first of a pair)."""
    own = matrix.tolerances.get(engine, {})
    if "reactions" not in own:
        return group_tolerances(engine)
    return {g: own[g] for g in ("kinematics", "reactions")}
