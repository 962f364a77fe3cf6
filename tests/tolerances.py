"""Tolerances of the in-house solver's own tests, each with its reason and measured value.

Why not in ``validation/tolerances.py``: that module is the suite's table of what a judge is held
to, and matrix files name its entries (``validation/matrix.py`` offers every ``Tolerance`` in it),
so a test-only number there would become a selectable comparison tolerance and would move the
regression gate's contract whenever a test changes.  Here are the numbers only tests use (the
in-house solver against closed forms, identities, the kernel, another unit system); a test that
compares a judge imports ``validation/tolerances.py``.  The solver's own decision thresholds are
``core/thresholds.py``.
"""

from dualmech.core.thresholds import Tolerance

#: S4 against the closed form, relative to a2: Newton stops at a closure residual of 1e-14 (x a2).
S4_VS_CLOSED_FORM = 1e-12
#: Kinematics near an edge of assembly (closure condition ~0.025) against the closed form, relative to the
#: case's peak: refined to rounding (EDGE_REFINE_CONDITION) the in-house engine measured 2e-13 there, 3e-11
#: stopped at CLOSURE_TOL; what is left is rounding times 1/c^3 (up to 3e-12 on 150 random cases).
NEAR_EDGE_VS_CLOSED_FORM = 3e-12
#: Kinematics of seeded random geometries against the closed form, relative to the case's peak, on the rows
#: with closure condition >= 0.05 (below, rounding times 1/c^3 reaches ~5e-12): measured <= 3.7e-13 on 450
#: random cases, 7.6e-12 without the near-edge refinement (EDGE_REFINE_CONDITION).
RANDOM_VS_CLOSED_FORM = 1e-12
#: Closure condition from which RANDOM_VS_CLOSED_FORM holds.
RANDOM_VS_CLOSED_FORM_CONDITION = 0.05
#: The Pinocchio judge there (closure condition 0.016), relative to the case's peak, unscaled: measured
#: 4.5e-12 once it goes on to rounding (pinocchio_closure.EDGE_CONDITION), 2.1e-10 stopped at its tolerance
#: (over the matrix's 1e-10 against the in-house engine); rounding times 1/c^3 is ~3e-11 there.
JUDGE_NEAR_EDGE_VS_CLOSED_FORM = 2e-11
#: Rates against exact (dual-number + complex-step) derivatives, relative to the case's peak.
RATES_VS_EXACT = 1e-11
#: Identity tests of the dynamics (power, momentum balance), relative to the largest term.
BALANCE = 1e-10
#: A batched answer against the same answer computed one position at a time.
BATCH_VS_SINGLE = 1e-12
#: Finite-difference checks of screws and twists (central differences, step 1e-6: error ~1e-10).
FINITE_DIFFERENCE = 1e-7
#: Shared inputs (mass properties, crank motion) against the same formula evaluated by hand: round-off only
#: (measured <= 2e-16 relative).
COMMON_MODE_INPUT = 1e-13
#: S4 at the assembly limit (c ~ 0) against the closed form, relative to a2: a closure residual r moves S4 by
#: ~sqrt(2 r) a2 there (r ~ 1e-14: 1.4e-7); measured <= 1.6e-7 (Pinocchio), 4.6e-8 (MuJoCo).
S4_AT_ASSEMBLY_LIMIT = 1e-6
#: Compiled kernel against the batched numpy solver (same algorithm), kinematics relative to the case's scale
#: of each unit group (validation/compare.py): both close to 1e-14 of a2; measured <= 1.2e-14.
KERNEL_VS_NUMPY_KINEMATICS = 1e-12
#: The same for reactions, relative to the case's peak and condition-scaled by |t| in torque mode:
#: 3x3 products summed in another order; measured <= 5.1e-14.
KERNEL_VS_NUMPY_REACTIONS = 1e-11
#: Newton-Euler residual of a table's reactions (the engines' ``meta["dynamics_residual"]``, and the 18
#: equations of tests/newton_euler_oracle.py evaluated on the table's columns), relative to the
#: position's force scale: a closed-form elimination, round-off only; measured <= 3.5e-16 (the engines' own),
#: <= 2.9e-14 (the oracle's equations, whose closed-form kinematics differ from the engine's by round-off) on
#: the presets.
NEWTON_EULER_ROUND_OFF = 1e-12
#: MuJoCo's simulation: the crank servo's largest lag against max |drive torque| / kp, relative: the servo's
#: damping kv times the lag's rate adds to kp times the lag; measured 2e-4 on the thesis case at 50 N.
SERVO_LAG = 1e-2
#: S4 at assembly_limit rows (c < 1e-2), kernel against numpy, relative to a2: a closure residual r moves S4
#: by ~r/c, and by ~sqrt(2 r) at c = 0 (r ~ 1e-14: 1.4e-7); measured 2.3e-10 at the exact edge.
KERNEL_VS_NUMPY_AT_LIMIT = 1e-6
#: The in-house answers in another length unit against the unscaled ones in that unit, relative to each unit
#: group's scale (reactions condition-weighted by |t|): scale factors are not powers of two, so round-off
#: only; measured <= 5.4e-13.
UNIT_CHANGE = 1e-11
#: Identities of the planar model in closed form (core/planar.py): round-off of O(1) quantities.
PLANAR_IDENTITY = 1e-13
#: Errata checks: round-off of products of O(1) trigonometric entries and O(a) lengths, relative to the
#: length scale.
ERRATA_ROUND_OFF = 1e-12
#: Errata checks: 8th-order central differences with h = 2e-3 rad: truncation ~1e-20, round-off
#: ~eps/h^2 ~ 1e-10 for f''.
HIGH_ORDER_DIFFERENCE = 1e-8
#: Errata checks: complex-step first derivatives are exact to round-off.
COMPLEX_STEP = 1e-13
#: Errata checks: "wrong" means wrong by at least this fraction of the natural scale (theta1_dot,
#: a1*theta1_dot, ...); every such threshold is >= 5x below the measured deviation quoted in docs/errata.md.
PRINTED_IS_WRONG = 1e-3
#: Findings: reactions from two independent linear solves of the same equations, relative to the case's
#: force scale.
FINDINGS_REACTIONS = 1e-9
#: Findings: extremes and roots located to round-off of lengths ~50 in (S4) or angles (deg).
FINDINGS_LOCATION = 1e-9
#: The thesis's printed input numbers (masses, inertias, speeds) carry 10-11 significant digits.
PRINTED_DIGITS = 1e-9
#: Power of the reactions against the kinetic energy's rate along the crank by Richardson's extrapolation of
#: central differences (h = 1e-5 and 5e-6 rad), relative to the largest power term: truncation ~h^4, round-off
#: ~eps K / h ~ 1e-11; measured <= 4.5e-10 over 240 seeded geometries of the test (one central difference
#: alone reached 1.8e-7 next to a universal joint's lock band, where the spin rate's derivatives are large).
ENERGY_RATE_BY_DIFFERENCE = 1e-8
#: Ground wrench plus weights against the momentum's central difference (h = 1e-5 rad), relative to the
#: rate's peak: truncation ~h^2 ~ 1e-10 times the motion's third derivative; measured <= 1.8e-10.
MOMENTUM_RATE_BY_DIFFERENCE = 1e-6
#: Torque mode, its slider load fed back in force mode, torque mode again: the same linear solve twice,
#: relative to each reaction's scale; measured <= 9e-16 (drive torque) and 2e-17 (reactions).
MODE_ROUND_TRIP = 1e-10
#: Reactions of a rotated copy of every input vector, rotated back, relative to each reaction's scale:
#: round-off of the rotation; measured <= 5.4e-16 (components), 3.2e-15 (norms).
FRAME_ROTATION = 1e-12
#: IFToMM benchmark (tests/models/slider_crank/test_iftomm.py), total energy, J: the published 0.76643568
#: has 8 decimals, so half a unit of the last one; dualmech's drift over 5 s at the default rtol = 1e-12
#: measured 1.5e-11.
IFTOMM_ENERGY_DIGITS = 5e-9
#: Its initial crank acceleration, rad/s^2: half a unit of the published -25.684's last digit (measured
#: -25.68419; a ball joint instead of the universal joint gives -25.77794).
IFTOMM_ACCELERATION_DIGITS = 5e-4
#: Slider X against Masarati's and González's published solutions at t = 0.1, 0.2 s, m: issue 15's "mutual
#: spread (about 1e-5 m)". Measured: Masarati - González 1.3e-6, 1.8e-6; dualmech - Masarati 4.9e-7, 2.2e-6;
#: dualmech - González 1.8e-6, 4.0e-6 (both published solutions lag, docs/findings.md); a ball joint instead
#: of the universal joint moves X by 7.5e-6, 1.9e-5.
IFTOMM_SLIDER_VS_PUBLISHED = 1e-5
#: dualmech's simulated motion against the independent oracle (tests/models/slider_crank/iftomm_oracle.py)
#: over 5 s, m of slider travel (crank angle: this over the crank length): both integrate at rtol 1e-12 /
#: 1e-13; measured 2e-11.
IFTOMM_VS_ORACLE = 1e-9
#: González's published slider X against dualmech's over 5 s (every 0.1 s), m: measured 7.0e-5 (3.3e-5 at
#: 1 s); Masarati's departs by up to 1.1e-2 (docs/findings.md).
IFTOMM_GONZALEZ_OVER_5S = 1e-4

# ----------------------------------------------------------------------- the RSSR and RCCC linkages
# Tolerances of the linkages' checks (in-house against both judges, and against identities), each with
# its reason and the value measured when it was set.
#
# A comparison of a column is ``|a - b| <= tol * peak`` with ``peak`` the largest magnitude over the case of
# the column's unit group (the output angle, its rates, the transmissions, every force, every moment column;
# :meth:`~dualmech.models.tables.TableSpec.unit_group`), so that a tolerance means the same in any
# unit system (``dualmech.validation.compare.tables.worst``; ``dualmech validate linkages`` holds the
# judges to the slider crank's tolerances instead).
# The suite's gates for the slider crank (``validation/tolerances.py``: ``MATRIX_KINEMATICS`` 1e-9,
# ``MATRIX_REACTIONS`` 1e-8) are looser; these are what the RSSR and the RCCC are held to.  Measured on the
# bundled cases and the random ones of ``tests/models/linkages/`` (RSSR seeds 21, 22, 11; RCCC 1, 4, 7).

#: Output angle (and slide), its rates and the transmissions, every judge against the in-house engine.
LINKAGE_JUDGE_KINEMATICS = Tolerance(
    1e-10, "all close the loop to ~1e-14 of its length scale and solve the same rate equations; measured "
    "<= 5.6e-13 (RSSR), <= 2.3e-12 (RCCC, rows near the edge of assembly, |t| ~ 0.02)")
#: Joint forces and moments, every judge against the in-house engine.
LINKAGE_JUDGE_REACTIONS = Tolerance(
    1e-9, "least squares on the judge's RNE vs the in-house Newton-Euler least squares on kinematics equal "
    "to ~1e-13; measured <= 7.4e-13 (RSSR), <= 1.4e-12 (RCCC)")
#: Output rates against central differences of the output angle (step 1e-4 rad), relative to the peak.
LINKAGE_FINITE_DIFFERENCE = Tolerance(
    1e-5, "truncation h^2 f'''/6 ~ 1e-8 of the peak, growing near the edge of assembly where f''' ~ 1/t^5; "
    "measured <= 9.3e-7 (RSSR random seed 2, phi4_ddot)")
#: The in-house pose from a perturbed start against the one from the closed-form estimate (rad, length).
LINKAGE_CLOSED_FORM = Tolerance(
    1e-12, "Newton stops at a closure residual of 1e-14 (x the length scale); measured <= 2e-15")
#: Power balance: drive and output power plus the weight's power equals the kinetic energy's rate.
LINKAGE_POWER_BALANCE = Tolerance(
    1e-10, "an identity of the in-house reactions and motions, to round-off of the largest power term; "
    "measured <= 1.5e-13")
#: The in-house Newton-Euler least squares: relative residual of the consistent system.
LINKAGE_DYNAMICS_RESIDUAL = Tolerance(
    1e-11, "rounding of an SVD solve of a consistent system; measured <= 1.7e-14 (RSSR, away from dead "
    "centres); the RCCC reaches 7.6e-11 next to its assembly limits and is not held to it")
#: The answers of a case rewritten in another length unit (masses and seconds kept) against the scaled ones.
LINKAGE_UNIT_CHANGE = Tolerance(
    1e-10, "the scale 1e3 is not a power of two, so round-off only, amplified ~1/|t1| next to a dead centre "
    "in torque mode (reactions up to 7e8 there); measured <= 2.2e-11 (RSSR seed 3, torque mode, j1_my)")
#: MuJoCo's free simulation (drive torque 0.3 N m, dt = 2e-5 s) against the in-house forward dynamics:
#: crank angle (rad) over 0.5 s.
LINKAGE_SIM_FREE_ANGLE = Tolerance(
    5e-3, "semi-implicit Euler and the soft weld err O(dt): measured 9.1e-4 (the generated model, "
    "dt = 2e-5; a hand-written model of the RSSR: 3.5e-3 at dt = 1e-4, 6.9e-4 at 2e-5, 3.4e-4 at 1e-5)")
#: The same, crank rate relative to its peak.
LINKAGE_SIM_FREE_RATE = Tolerance(
    2e-3, "O(dt) as the angle: measured 5.0e-4 (the generated model, dt = 2e-5; the hand-written one: "
    "1.7e-3 at dt = 1e-4, 3.4e-4 at 2e-5, 1.7e-4 at 1e-5)")
#: The generic loop engine against a mechanism's own engine (the slider crank's kinematics; the RSSR's and the
#: RCCC's kinematics and reactions), relative to the peak: both close the same table to rounding and solve the
#: same equations (measured <= 2.4e-14 on the thesis presets, 2.7e-14 on the bundled RSSR and RCCC).
LOOP_VS_OWN_ENGINE = 1e-12
#: Its reactions, relative to the case's peak: the larger of this and LOOP_REACTIONS_ROUNDING / (|t| s), t the
#: transmission, s = 1 (balls) or the sine of the rod's angle to the slider axis (a universal joint, whose
#: moment carries 1/s). Near a dead centre the least squares loses rounding times 1/|t| that the slider
#: crank's closed-form elimination of the axial rod force does not (measured 8.9e-12 at |t| = 2.9e-5 on
#: a4-30-s1-3.5; error x |t| x s <= 3.3e-15 of the peak on the thesis presets, 6.7e-15 on the IFToMM one).
LOOP_VS_SLIDER_CRANK_REACTIONS = 1e-12
LOOP_REACTIONS_ROUNDING = 1e-14
#: ... and near an edge of assembly (closure condition c) the larger of these and LOOP_EDGE_ROUNDING / c^3:
#: the closure's rounding reaches the reactions times 1/c^3 there (as NEAR_EDGE_VS_CLOSED_FORM's kinematics;
#: measured 3.7e-12 at c = 0.069, error x c^3 = 1.2e-15 of the peak).
LOOP_EDGE_ROUNDING = 5e-15
#: The RSSR's and RCCC's in-house engine (the loop engine on their preset tables) against their closed form
#: at an ``assembly_limit`` row (|t| ~ 1e-6, 1e-9 deg inside an edge of assembly), each pose value relative
#: to itself (and absolute, for a transmission near 0): both stop at a closure residual up to LIMIT_CLOSURE
#: (1e-9), where the pose moves by ~r/|t|; measured 1.05e-6 (RCCC s4 = 1.9e5 at |t| = 4e-6), 6e-11 (RSSR t4).
PRESET_AT_ASSEMBLY_LIMIT = 1e-5
#: The compiled loop engine (core/kernel/loop_engine.py) against the numpy solver, relative to each column's
#: peak: the same algorithm per position from the same stations, both closed to the rounding level; only the
#: order of sums and, on a fine grid, the kernel's start estimates differ (measured <= 1.1e-14 on the
#: presets).
KERNEL_VS_NUMPY_LOOP = 1e-12
#: The compiled rates solved with the branch sign's LU factors (the closure Jacobian, its dual rows over the
#: length scale) against the rate equations' own factorization, relative to each output's peak: the same
#: equations, their rows scaled, so the pivots and the rounding differ (measured 8.7e-15 on the slider crank,
#: RSSR and RCCC).
REUSED_FACTORS = 1e-13
#: The compiled square Newton-Euler solve along the chain (core/kernel/wrench_chain_nb.py) against the
#: Householder QR of the whole system, the unknowns relative to their peak and the transmission relative to
#: itself, each over the condition's gain 1/|t| near a dead centre: two factorizations of one system, each
#: backward stable (measured 1.3e-14 for the unknowns, 1.1e-14 for the transmission, on the 7R, RSCR, RSRC
#: and RCCC; 6.6e-15 and 1.2e-15 on the tables with an S-S link, the RSSR and the slider crank's, with the
#: link's mass on its axis or off it).
CHAIN_VS_QR = 1e-13
#: The compiled transposed LU solve (core/kernel/linalg_nb.py) against numpy's solve, relative to the
#: solution's peak, on well-conditioned random matrices up to 9x9 (measured 7.4e-15).
KERNEL_LINALG = 1e-13
#: A column that is nil in theory (a force along an axis the loads never load, the ground link's twist) is
#: rounding noise in both: compared against this fraction of its group's peak instead of its own.
NIL_COLUMN = 1e-2
#: Closure residual of the generic loop engine on its closed rows (lengths over the loop's length): it refines
#: to the rounding level (measured <= 2e-15 on random tables).
LOOP_CLOSURE = 1e-13
#: A loop table's pose (the bundled RSCR and RSRC) against the closed form of its ball-to-axis link: distance,
#: perpendicularity and direction, relative to the link's length.
LOOP_CLOSED_FORM = Tolerance(
    1e-12, "every engine closes to ~1e-14 of the table's length; measured <= 1.1e-14 (MuJoCo, RSRC), "
    "<= 9e-16 (in-house, Pinocchio)")
#: A loop table's rates against central differences of its pose (step 1e-2 deg), relative to each column's
#: peak; and its solved drive torque at rest against the virtual work of the loads and weights, relative to
#: the largest.
LOOP_FINITE_DIFFERENCE = Tolerance(
    1e-6, "truncation h^2 q'''/6 ~ 1e-8 of the peak and rounding eps/h^2 ~ 4e-9 for the second difference; "
    "measured <= 1e-7 (RSCR rates), <= 9e-9 (virtual work)")
