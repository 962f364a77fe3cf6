"""Test oracles for the errata and findings tests, gathered under one name (``th`` in the tests).

The thesis's printed equations, transcribed symbol by symbol (Rahman 1991; ``docs/errata.md`` says
where they are wrong), and an independent model.  Nothing here imports the in-house solver.

* :mod:`tests.models.slider_crank.thesis_printed`: matrices (1)-(4), the derivative operators (2a)-(4a)
  and (8)-(10), the loop (5), (18) and the Newton-Raphson system (24)-(25) with its iteration (23a).
* :mod:`tests.models.slider_crank.thesis_printed_rates`: the velocity equations (37a)-(37f), (38),
  (39)-(43) and the accelerations (38a)-(42a), one function per printed equation.
* :mod:`tests.models.slider_crank.thesis_angles`: the thesis's Z-Y angles of an exact closed position
  (sphere-line S4, angles read off the rod direction) and their derivatives by 8th-order central
  differences.
* :mod:`tests.newton_euler_oracle`: closed-form kinematics, the rod's zero-spin angular velocity
  ``u x u_dot``, and the 18 Newton-Euler equations of crank, rod and slider in world axes (moments
  about O), assembled as a matrix and solved by least squares.
"""

from __future__ import annotations

from tests.models.slider_crank.thesis_angles import angle_derivatives, derivatives, exact_s4, thesis_angles
from tests.models.slider_crank.thesis_printed import (
    closure_residual,
    dl2_det2,
    dl2_dth2,
    dl3_det3,
    dl3_dth3,
    dm4_ds4,
    dmul,
    dtr,
    dvec,
    frame_origin,
    l2,
    l3,
    loop_product,
    m1,
    m4,
    newton_system,
    q_eta,
    q_s,
    q_theta,
    thesis_newton,
)
from tests.models.slider_crank.thesis_printed_rates import (
    eq37_residuals,
    printed_accels,
    printed_rates,
    system38,
)
from tests.newton_euler_oracle import (
    AXIAL_FORCE_COLUMN,
    DRIVE_TORQUE_COLUMN,
    F1,
    F4,
    J2,
    J3,
    M1,
    M4,
    kinematics,
    least_squares,
    momentum_rates,
    newton_euler_system,
)

__all__ = [
    "AXIAL_FORCE_COLUMN", "DRIVE_TORQUE_COLUMN", "F1", "F4", "J2", "J3", "M1", "M4",
    "angle_derivatives", "closure_residual", "derivatives", "dl2_det2", "dl2_dth2", "dl3_det3", "dl3_dth3",
    "dm4_ds4", "dmul", "dtr", "dvec", "eq37_residuals", "exact_s4", "frame_origin", "kinematics", "l2",
    "l3", "least_squares", "loop_product", "m1", "m4", "momentum_rates", "newton_euler_system",
    "newton_system", "printed_accels", "printed_rates", "q_eta", "q_s", "q_theta", "system38",
    "thesis_angles", "thesis_newton",
]
