"""Thresholds the solver decides with: the edges of assembly, the dead-centre and joint-lock flags.

These are the in-house engine's own numerical decisions (which status word a row gets), not
tolerances of a comparison; every engine applies the same ones so that their statuses can be
compared row by row (``docs/conventions.md``, "Edges of assembly" and "Dead centres").  The
tolerances the judges are compared with live in ``validation/tolerances.py``, which imports
these where it needs them: each number has this one home.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class Tolerance:
    """A tolerance or threshold and the one-line reason for its size."""

    value: float
    reason: str


#: Dead-centre flag: |transmission| below this makes the slider load meaningless in torque mode.
DEAD_CENTRE_TRANSMISSION = Tolerance(
    1e-9, "below 1e-9 the slider load ~ T/(a1 t) carries fewer than ~7 significant digits")
#: Assembly-limit flag, every engine: closure_condition |u·k4| below this makes a row ``assembly_limit``
#: (S1, S4 given).
ASSEMBLY_LIMIT_CONDITION = Tolerance(
    1e-2, "S4 carries the closure error times 1/c, S4_ddot and reactions ~1/c^3: rigid engines measured "
    "2.8e-10 apart (row-relative) at c = 1.4e-3, ~1/c^2, so 1e-2 keeps 100x under MATRIX_KINEMATICS")
#: Assembly limit of a loop table, every engine: the closure condition c of its pose (the smallest over the
#: largest singular value of the solved freedoms' twists, ``models/loop/condition.py``) below this.
LOOP_LIMIT_CONDITION = Tolerance(
    1e-3, "the rates grow as 1/c, accelerations as 1/c^3: on the slider crank's table 1e-6 a2 inside a "
    "turning point of its drive (c = 6.5e-4) the compiled and numpy engines' s4 rates and accelerations stay "
    "within 9e-11 of the closed form's peak; "
    "the bundled 7R's closest approach, c = 8.9e-3 with every rate at most 1.7x the drive's, stays ok")
#: Joint lock of a loop table, every engine: a row at an assembly limit by LOOP_LIMIT_CONDITION whose closure
#: condition with the drive's twist as one more column (models/loop/condition.py, drive_condition) is below
#: this is ``joint_lock``: the drive still moves the loop there.
LOOP_LOCK_CONDITION = Tolerance(
    1e-2, "at a lock the drive's twist stays in the span of the solved freedoms: c_d = 0.85 c on the "
    "slider crank's table with a universal joint at the slider whose rod passes along the slider line; at an "
    "edge of assembly it leaves it: c_d = 0.14 at the planar slider crank table's edge (c = 1.8e-3)")
#: Walk through a joint lock, every engine of a loop table (the in-house engine's
#: ``dualmech.core.continuation.cross_lock``, each judge's own walk): the drive walked from the last row
#: closed on the branch to a row past the lock in this many steps per row, each closed from the secant
#: through the two before it; the walk is smooth when no closure corrects the secant by more than
#: LOCK_CORRECTION of the step before it.
LOCK_SUBSTEPS = 8
LOCK_CORRECTION = Tolerance(
    0.5, "on a smooth curve the secant's error over the step is about the step times the curve's turn per "
    "step (a few % at 8 steps a row on the slider crank's table through its universal joint's lock); a "
    "closure that lands on another assembly corrects by the whole jump")
#: Rows past the last row closed on the branch that a walk through a lock tries to reach in turn (a row at
#: the lock itself has a singular pose: the walk goes on to the next).
LOCK_ROWS = 3
#: A pose is regular (off a lock or limit) when the smallest singular value of its square closure Jacobian
#: is at least this fraction of the largest; a walk through a lock starts and ends on regular poses.
REGULAR_POSE = Tolerance(
    1e-5, "at a lock or limit the closure's root is double: a pose closed there to a residual r is ~sqrt(r) "
    "off it (Pinocchio's 1e-13: its ratio ~3e-7); above 1e-5 the determinant's sign and tangent are sure")
#: Universal-joint lock, every engine: with a universal joint at the slider, a closure_condition |u·k4| at
#: or above this makes a row ``joint_lock`` (pose and rates given, reactions not).
JOINT_LOCK_CONDITION = Tolerance(
    math.sqrt(1.0 - 1e-4), "the rod within asin(1e-2) = 0.57 deg of the slider axis (the crank pin within "
    "a2/100 of the slider line): the rod's spin rate carries 1/sin, its rate and the reactions 1/sin^2, "
    "so 1e-2 keeps the margin of ASSEMBLY_LIMIT_CONDITION")
#: Near an edge of assembly, in-house engine: a closed row whose geometric closure_condition
#: sqrt(1 - (rho/a2)^2) is below this (and not below ASSEMBLY_LIMIT_CONDITION, where Newton has no
#: regular root to go on to) is refined by Newton to the rounding level (core/closure.py ``refine``).
EDGE_REFINE_CONDITION = Tolerance(
    0.1, "S4 carries the closure residual times 1/c, S4_ddot ~1/c^3: at c = 0.025 the residual CLOSURE_TOL "
    "(1e-14) left S4_ddot 3e-11 of its peak off the closed form; below c = 0.1 the closure goes on to "
    "rounding (a row or two of a revolution near an edge, so its cost is not measurable)")
#: Structurally zero output: a load whose largest magnitude is at most this fraction of the case's own scale
#: of its unit group (the largest force, or moment) is the solver's round-off, reported as 0 with its level
#: (a peak that varies by no more than this is constant).
ROUND_OFF_RELATIVE = Tolerance(
    1e6 * 2.220446049250313e-16,
    "10^6 eps: the in-house Newton-Euler solve leaves exact zeros at 0.5-5 eps of the case's scale (j4's "
    "moment with a ball joint, 10 presets x 2 load modes), 1.4e4 eps where the lock's "
    "1/sin amplifies it (the planar ideal case with a universal joint); the smallest genuine peak measured "
    "is 1.3e-6 of its scale, 6e3 times above")
#: Edge of reach, every engine: P2 farther than a2 from the slider line by more than this (relative to a2)
#: is ``no_assembly``.
ASSEMBLY_REACH = Tolerance(
    1e-12, "P2 and the slider line are placed to ~1e-16 of the length scale; rounding must not decide "
    "assembly_limit vs no_assembly at the exact edge")
