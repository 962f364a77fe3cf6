"""A given drive effort with one load solved: two prescribed runs combined.

The judge prescribes the drive's motion, so the drive's multiplier is always an answer, never an input.
With the drive's effort :math:`e` given and one load :math:`x` solved, the motion is still the table's, and
every multiplier is affine in the loads at a fixed motion (the equations of motion are linear in the
applied forces, the states of the runs do not depend on them: the motion is prescribed).  Two runs, the
solved load at 0 and at 1, give the drive effort :math:`e_0`, :math:`e_1` and every reaction :math:`R_0`,
:math:`R_1`; then

.. math:: x = \\frac{e - e_0}{g}, \\quad g = e_1 - e_0, \\qquad R = R_0 + x\\,(R_1 - R_0),

row by row and step size by step size, before the Richardson extrapolation.  :math:`g` is the drive
effort's change per unit load, the transmission: where its extrapolation is within its own Richardson
estimate plus ``DEAD_CENTRE_TRANSMISSION`` of its largest value over the table of zero, the loads cannot be
balanced (a dead centre: at the slider crank's, ``g`` of the three runs was 1.1e-6, 2.6e-7, 6.6e-8, going to
zero with the step, and ``x`` some 1e9 times the load).
"""

from __future__ import annotations

import dataclasses

from dualmech.models.loop.description import LoopMechanism


def solved_load(mechanism: LoopMechanism) -> tuple[str, str] | None:
    """``(drive effort column, solved load column)`` names (``theta1``, ``s4``), or ``None`` when the drive's
    effort is the solved one."""
    d = mechanism.drive
    if d.effort is None:
        return None
    load = next(load for load in mechanism.loads if load.value is None)
    return f"{d.coordinate}{d.joint + 1}", f"{load.coordinate}{load.joint + 1}"


def variants(mechanism: LoopMechanism) -> tuple[LoopMechanism, LoopMechanism]:
    """The table with the drive's effort solved and the solved load given as 0, then as 1."""
    drive = dataclasses.replace(mechanism.drive, effort=None)

    def with_load(value: float) -> LoopMechanism:
        loads = tuple(dataclasses.replace(load, value=value) if load.value is None else load
                      for load in mechanism.loads)
        return dataclasses.replace(mechanism, drive=drive, loads=loads)

    return with_load(0.0), with_load(1.0)


def combine(mechanism: LoopMechanism, zero: dict[str, float], unit: dict[str, float]) -> tuple[dict, float]:
    """One row of the table from its rows with the solved load at 0 and 1 (module docstring), and ``g``."""
    drive, load = solved_load(mechanism)
    e0, e1 = zero[f"effort_{drive}"], unit[f"effort_{drive}"]
    g = e1 - e0
    x = (mechanism.drive.effort - e0) / g if g != 0.0 else float("nan")
    out = {}
    for name, r0 in zero.items():
        reaction = name.startswith(("effort_", "joint"))
        out[name] = r0 + x * (unit[name] - r0) if reaction else r0
    out[f"effort_{drive}"], out[f"effort_{load}"] = float(mechanism.drive.effort), x
    return out, g
