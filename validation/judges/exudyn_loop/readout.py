"""One state of an Exudyn run read as a row of the loop table: coordinates, rates, efforts, joint wrenches.

**Kinematics.**  Each body's node gives its link frame's pose, velocity, angular velocity and their
derivatives (world axes).  Joint ``k``'s coordinates are read from :math:`G_k^{-1} F_k` and their rates from
the relative motion in :math:`G_k`'s axes (:func:`~.frames.relative_rates`; a point's velocity
:math:`v + \\omega\\times r` and acceleration
:math:`a + \\dot\\omega\\times r + \\omega\\times(\\omega\\times r)`).

**Reactions.**  Exudyn's equations of motion are :math:`M\\ddot q + C_q^T\\lambda = f`, so a constraint's
generalized force on the bodies is :math:`-C_q^T\\lambda`.  On the side of marker ``m1`` (link ``k``; the
ground for the last joint), which is the side of the table's wrench "on link k from link k-1":

* all three slides held: :math:`C = p_{m1} - p_{m0}` (world), force :math:`-\\lambda_{0:3}` at :math:`p_{m1}`;
  some held: :math:`C_i = t_{i0}\\cdot(p_{m1} - p_{m0})`, force :math:`-\\sum_i\\lambda_i t_{i0}` at
  :math:`p_{m1}`;
* a rotation row :math:`C = t_{a0}\\cdot t_{b1}` turns with body 1's small rotation :math:`\\delta\\varphi` by
  :math:`\\delta\\varphi\\cdot(t_{b1}\\times t_{a0})`: a couple :math:`-\\lambda\\,(t_{b1}\\times t_{a0})`
  (Exudyn's raw multipliers, whatever the ``TorqueLocal`` output calls them);
* the drive's coordinate constraint on link 1's angle (slide) node coordinate: a couple about (a force
  along) :math:`z_1` of :math:`-\\lambda`, which is the drive's effort;
* a given effort at joint ``k``: its torque about (force along) the joint's axis.

The wrench's moment is then taken about the joint's point (:func:`~.frames.joint_point`).
"""

from __future__ import annotations

import exudyn as exu
import numpy as np

from dualmech.validation.judges.exudyn_loop.frames import (
    COORDINATES,
    joint_point,
    relative_coordinates,
    relative_rates,
    transform,
)
from dualmech.validation.judges.exudyn_loop.model import U_J0, U_J1, ExudynLoop

OUT = exu.OutputVariableType
#: The bodies' constraint forces are ``CONSTRAINT_SIGN`` times :math:`C_q^T\\lambda` (Exudyn's equations of
#: motion :math:`M\\ddot q + C_q^T\\lambda = f`: -1).
CONSTRAINT_SIGN = -1.0
#: Rotation rows of each type's generic joint: multiplier index, axis of J0, axis of J1 (``t_a0 . t_b1``).
ROTATION_ROWS: dict[str, tuple[tuple[int, int, int], ...]] = {
    "R": ((3, 2, 0), (4, 2, 1)), "C": ((3, 2, 0), (4, 2, 1)), "P": ((3, 2, 1), (4, 2, 0), (5, 0, 1)),
    "U": ((3, 1, 2),), "S": ()}


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """:math:`a\\times b` of two 3-vectors (``numpy.cross`` costs ten times more on so few numbers)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def body_states(loop: ExudynLoop) -> list[tuple[np.ndarray, ...]]:
    """``(frame (4, 4), velocity, angular velocity, acceleration, angular acceleration)`` of every link's
    node in the current configuration (world axes)."""
    out = []
    for node in loop.nodes:
        get = lambda kind, node=node: np.asarray(loop.mbs.GetNodeOutput(node, kind), float)  # noqa: E731
        frame = transform(get(OUT.RotationMatrix).reshape(3, 3), get(OUT.Position))
        out.append((frame, get(OUT.Velocity), get(OUT.AngularVelocity), get(OUT.Acceleration),
                    get(OUT.AngularAcceleration)))
    return out


def _at(state: tuple[np.ndarray, ...], point: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Velocity and acceleration of a body's ``point`` (world)."""
    frame, v, w, a, wd = state
    r = point - frame[:3, 3]
    return v + cross(w, r), a + cross(wd, r) + cross(w, cross(w, r))


def _sides(loop: ExudynLoop, states: list, k: int) -> tuple[tuple, tuple]:
    """World frames and motion of joint ``k``'s two sides: ``(G, omega, omega_dot, states)`` of link
    ``k-1`` at the joint frame and ``(F, ...)`` of link ``k`` (the ground: at rest)."""
    rest = (np.eye(4), np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3))
    before = states[k - 1] if k > 0 else rest
    after = states[k] if k < len(states) else rest
    g = before[0] @ loop.joint_frames[k]
    f = after[0] @ loop.link_markers[k]
    return (g, before), (f, after)


def kinematics(loop: ExudynLoop, states: list) -> dict[str, float]:
    """Every scalar coordinate, ``_dot`` and ``_ddot`` by column name at the current state."""
    out = {}
    for k, joint in enumerate(loop.mechanism.joints):
        if joint.type == "S":
            continue
        (g, before), (f, after) = _sides(loop, states, k)
        relative = np.linalg.solve(g, f)
        rg = g[:3, :3]
        w_rel = rg.T @ (after[2] - before[2])
        wd_rel = rg.T @ (after[4] - before[4] - cross(before[2], after[2] - before[2]))
        r = f[:3, 3] - g[:3, 3]
        vg, ag = _at(before, g[:3, 3])
        vf, af = _at(after, f[:3, 3])
        rd, rdd = vf - vg, af - ag
        w = before[2]
        d_dot = rg.T @ (rd - cross(w, r))
        d_ddot = rg.T @ (rdd - cross(before[4], r) - 2 * cross(w, rd) + cross(w, cross(w, r)))
        values = relative_coordinates(joint.type, relative)
        rates = relative_rates(joint.type, relative, w_rel, wd_rel, d_dot, d_ddot)
        for name in COORDINATES[joint.type]:
            key = f"{name}{k + 1}"
            out[key], (out[f"{key}_dot"], out[f"{key}_ddot"]) = values[name], rates[name]
    return out


def reactions(loop: ExudynLoop, states: list) -> dict[str, float]:
    """Every given and prescribed coordinate's effort ``effort_<name>`` and joint wrench ``joint<i>_f*``,
    ``joint<i>_m*`` (module docstring) from the current multipliers.  (The table's efforts are among them:
    this module reads no column list, so that the engine loads nothing of the result table.)"""
    mbs, mech = loop.mbs, loop.mechanism
    ae = np.asarray(mbs.systemData.GetAECoordinates(), float)
    sign = CONSTRAINT_SIGN
    drive = {name: sign * float(ae[mbs.systemData.GetObjectLTGAE(obj)[0]]) for name, obj in loop.drives}
    given = {(load.joint, load.coordinate): load.value for load in mech.loads if load.value is not None}
    out = {}
    for k, joint in enumerate(mech.joints):
        lam = ae[mbs.systemData.GetObjectLTGAE(loop.joints[k])]
        (g, _), (f, _) = _sides(loop, states, k)
        j0, j1 = g[:3, :3], f[:3, :3]
        if joint.type == "U":  # Exudyn's J0, J1 axes (model.U_J0, U_J1)
            j0, j1 = j0 @ U_J0, j1 @ U_J1
        held = [i for i in range(3) if (joint.type, i) not in (("P", 2), ("C", 2))]
        force = sign * (lam[:3] if len(held) == 3 else sum(lam[i] * j0[:, i] for i in held))
        moment = sign * sum((lam[i] * cross(j1[:, b], j0[:, a]) for i, a, b in ROTATION_ROWS[joint.type]),
                            np.zeros(3))
        axis = g[:3, 2]
        efforts = dict(drive) if k == 0 else {}
        efforts.update({name: given[(k, name)] for name in COORDINATES[joint.type] if (k, name) in given})
        for name, effort in efforts.items():
            if name == "s":
                force = force + effort * axis
            else:
                moment = moment + effort * axis
        point = joint_point(joint.type, joint.s, g)
        moment = moment + cross(f[:3, 3] - point, force)
        for kind, vector in (("f", force), ("m", moment)):
            out.update({f"joint{k + 1}_{kind}{axis_name}": float(x) for axis_name, x in zip("xyz", vector)})
    out.update({f"effort_{c}{k + 1}": float(value) for (k, c), value in given.items()})
    out.update({f"effort_{name}1": value for name, value in drive.items()})
    return out


def read_row(loop: ExudynLoop) -> dict[str, float]:
    """The current state of the run as a row: kinematics and reactions by column name."""
    states = body_states(loop)
    return {**kinematics(loop, states), **reactions(loop, states)}
