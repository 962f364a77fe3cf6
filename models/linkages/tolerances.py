"""Tolerances of the linkages' checks (in-house against both judges, and against identities), each with
its reason and the value measured when it was set.

A comparison of a column is ``|a - b| <= tol * peak`` with ``peak`` the largest magnitude over the case of
the column's unit group (the output angle, its rates, the transmissions, every force, every moment column;
:meth:`~dualmech.models.linkages.table.TableSpec.unit_group`), so that a tolerance means the same in any unit
system (``dualmech.validation.linkages.gate.worst``; ``dualmech validate linkages`` holds the judges to the
slider crank's tolerances instead).
The suite's gates for the slider crank (``validation/tolerances.py``: ``MATRIX_KINEMATICS`` 1e-9,
``MATRIX_REACTIONS`` 1e-8) are looser; these are what the RSSR and the RCCC are held to.  Measured on the
bundled cases and the random ones of ``tests/models/linkages/`` (RSSR seeds 21, 22, 11; RCCC 1, 4, 7).
"""

from __future__ import annotations

from dualmech.core.thresholds import Tolerance

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
#: MuJoCo simulation of the bundled RSSR (dt = 2e-5 s, soft connect of time constant 2 dt): output angle,
#: rad.
LINKAGE_SIM_ANGLE = Tolerance(
    1e-5, "the connect settles open by ~|Jdot qdot|/k ~ dt^2 (gap 2e-7 of a2); measured 6.4e-7 rad "
    "(1.6e-5 at dt = 1e-4: converges like dt^2)")
#: The same, output rate relative to its peak.
LINKAGE_SIM_RATE = Tolerance(
    2e-3, "semi-implicit Euler lags velocities by dt/2 x acceleration (2e-4 of the peak here); "
    "measured 2.3e-4")
#: The same, joint 3's force (the connect's) relative to its peak, at the implicit step's input
#: acceleration.
LINKAGE_SIM_FORCE = Tolerance(
    1e-3, "O(dt) velocity lag and O(dt^2) gap; measured 3.3e-5 (2.7e-4 at dt = 1e-4; 2.6e-2 when the "
    "explicit qacc is taken for the input acceleration instead of the implicit step's)")
#: MuJoCo's free simulation (drive torque 0.3 N m, dt = 2e-5 s) against the in-house forward dynamics:
#: crank angle (rad) over 0.5 s.
LINKAGE_SIM_FREE_ANGLE = Tolerance(
    5e-3, "semi-implicit Euler and the soft connect err O(dt): measured 3.5e-3 (dt = 1e-4), 6.9e-4 (2e-5), "
    "3.4e-4 (1e-5)")
#: The same, crank rate relative to its peak.
LINKAGE_SIM_FREE_RATE = Tolerance(
    2e-3, "O(dt) as the angle: measured 1.7e-3 (dt = 1e-4), 3.4e-4 (2e-5), 1.7e-4 (1e-5)")
