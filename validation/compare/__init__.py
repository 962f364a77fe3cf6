"""Judge against reference: per case, engine and quantity, how far apart and whether that is fine.

The gate is strict: it passes only on what it has actually compared.

**Statuses first.**  Every engine says one word of :mod:`dualmech.core.status` per
crank position.  ``ok``, ``dead_centre``, ``assembly_limit`` and ``no_assembly`` are
verdicts about the mechanism; ``branch_jump``, ``not_converged`` and ``not_finite``
are failures of the engine, and so is any non-finite number where the word says the
value is given (an ``ok`` row with NaN or inf).  Per row, the judge's word must equal
the reference's, except where a stated rule (:data:`STATUS_RULES`) explains the
difference: in drive-torque mode, ``ok`` against ``dead_centre`` where both engines'
``|transmission|`` lie between half the in-house flag and the judge's ``dead_centre_band``
(never at an exact dead centre, where every engine owes the flag), and ``ok`` against ``assembly_limit`` where
its ``closure_condition`` is within the judge's ``assembly_limit_band`` of the flag
``ASSEMBLY_LIMIT_CONDITION`` (``validation/tolerances.py``), since each engine sets these flags from its own
values.  Rows the two engines agree not to assemble are agreement, counted in ``n_excluded``.  The reference
gets a ``status`` check of its own: engine failures, or no assembled position at all (unless the matrix case
declares ``expect = "no_assembly"``, in which case every engine must say so at every position, and nothing
else is compared).

**Then the numbers.**  For one case, the reference's table ``R`` and a judge's
table ``J`` are compared row by row on the rows where both give the quantity:

.. math::

    d_i = |J_i - R_i|, \\qquad
    r_i = \\frac{d_i}{s_g\\, c_i}, \\qquad
    \\text{pass} \\iff n_\\text{compared} > 0 \\text{ and } \\max_i r_i \\le \\text{tol}

* ``c_i`` is the condition factor of the row (``docs/conventions.md``, "Dead
  centres"): ``1/|t_i|`` for reactions in drive-torque mode, with ``t`` the
  reference's ``transmission`` column, else 1.
* ``s_g`` is the scale of the quantity's unit group (:data:`UNIT_GROUP`): the
  largest ``|R_i| / c_i`` over the case's compared rows of every compared quantity
  of that group, so every verdict is relative to the case's own scale and does not
  depend on its unit system.
* A quantity with no row compared fails: a gate that compared nothing says so.
* Near a universal joint's lock a judge's tolerance of a rate or reaction column is
  multiplied row by row by ``f_i`` (at most the judge's ``joint_lock_cap``; 1 beyond 5 deg of
  the lock), from the measured turning rate of the joint's cross
  (:mod:`~dualmech.validation.compare.joint_lock`; ``docs/conventions.md``, "Near a joint
  lock"); every check so widened says :data:`NEAR_JOINT_LOCK` in its detail.
* Where a row is ill-conditioned (the double root of the closure at an edge of assembly, beside a
  dead centre, an extreme aspect ratio) its tolerance grows by the allowances ``a_i`` of
  :mod:`~dualmech.validation.compare.conditioning`, derived laws with stated bounds: a row passes at
  ``r_i <= f_i tol + a_i`` (``docs/conventions.md``, "Conditioning of a row"); a check so widened says
  ``conditioned`` and names the law in its detail.

**The odd one out.**  Where three or more engines compare a quantity, a failing check names the
engine that disagrees with the others (its ``odd_one_out``, leading its detail): the reference when
two judges agree with each other and both disagree with it, a judge when another judge, as precise,
agrees with the reference and not with it (:mod:`~dualmech.validation.compare.odd_one_out`).

**Every pair.**  Beside the verdicts, every pair of engines that answered a case is measured as the
gate measures a judge, the pair's first engine in the reference's place, at the looser of the two
tolerances (:attr:`Comparison.pairs`, :mod:`~dualmech.validation.compare.pairs`): the report's pair table.
A pair of two judges is informative, not a verdict.

**Missing work.**  A case, or an engine of a case, absent from the results gives a
failing ``engine`` check marked ``incomplete``; the run's :class:`Verdict` is then
``INCOMPLETE`` (never ``PASS``), unless a comparison failed outright (``FAIL``).
"""

from dualmech.validation.compare.checks import (
    STATUS_RULES,
    StatusRule,
    compare_case,
    compare_slider_crank,
    first_line,
    quantity_check,
    reference_check,
    status_check,
    stroke_check,
)
from dualmech.validation.compare.differences import (
    condition_factor,
    engine_failures,
    given_under,
    relative_differences,
    rows_given,
    stroke,
    unit_scales,
)
from dualmech.validation.compare.joint_lock import lock_factor, lock_rate
from dualmech.validation.compare.results import (
    ENGINE,
    EXPECT_NO_ASSEMBLY,
    NEAR_JOINT_LOCK,
    POSE_COLUMNS,
    RATE_COLUMNS,
    STATUS,
    STROKE,
    STROKE_PROXY,
    UNIT_GROUP,
    VERDICTS,
    Check,
    Comparison,
    Pair,
    Verdict,
)
from dualmech.validation.compare.run import compare_run

__all__ = [
    "ENGINE", "EXPECT_NO_ASSEMBLY", "NEAR_JOINT_LOCK", "POSE_COLUMNS", "RATE_COLUMNS", "STATUS",
    "STATUS_RULES", "STROKE", "STROKE_PROXY", "UNIT_GROUP", "VERDICTS", "Check", "Comparison", "Pair",
    "StatusRule", "Verdict", "compare_case", "compare_run", "compare_slider_crank", "condition_factor",
    "engine_failures",
    "first_line", "given_under", "lock_factor", "lock_rate", "quantity_check", "reference_check",
    "relative_differences", "rows_given", "status_check", "stroke", "stroke_check", "unit_scales",
]
