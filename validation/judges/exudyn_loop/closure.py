"""The judge's own closure of a loop table in joint coordinates: the start pose of each Exudyn run.

A pose is every joint's scalar coordinates and every S joint's rotation (:mod:`.frames`).  The loop is closed
when the chain's last link frame is the ground's, :math:`F_{n-1} = B`; the residual is

.. math:: r = \\begin{bmatrix} (p_{F_{n-1}} - p_B)/L \\\\ \\log(R_B^T R_{F_{n-1}}) \\end{bmatrix}

(``L`` the table's length), driven to zero by Levenberg-Marquardt over the free coordinates (all but the
prescribed ones).  Its Jacobian is the joints' screws in world axes: a turn :math:`\\delta\\varphi` about
axis ``u`` through ``c`` moves the end by :math:`u\\times(p - c)\\,\\delta\\varphi` and turns it by
:math:`u\\,\\delta\\varphi`; a slide moves it by :math:`u\\,\\delta s`; an S joint turns about the world axes
through its centre (the rotation rows' :math:`J_{\\log}` is taken as the identity, exact at the root).  The
steps are minimum-norm, so an idle spin (a link between two S joints) is not turned.

The start: the joints' ``start`` values at the first drive position when any joint gives them (S: a
rotation vector in the joint frame's axes; the last joint's held while the others are fitted first, so
that its start picks the branch), else of :data:`SEARCH_TRIES` random poses closed at each of up
to :data:`SEARCH_POSITIONS` evenly spread positions, at the first where any closes, the one nearest the zero
pose (:func:`~dualmech.models.loop.start.nearest_to_zero`, the rule every engine shares).  From it the loop
is closed position by position (:mod:`.continuation`), which gives every row's status word and the closed
pose where each run of assembled rows starts; the branch is the sign of the square Jacobian's determinant
(:func:`branch_sign`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from dualmech.core.status import Status
from dualmech.models.loop.description import LoopMechanism
from dualmech.models.loop.start import nearest_to_zero
from dualmech.validation.judges.exudyn_loop.frames import COORDINATES, chain, ground_frame

#: Closure tolerance on the scaled residual's norm (two orders above rounding).
CLOSURE_TOL = 1e-13
#: Iterations before ``not_converged``.
MAX_ITER = 200
#: A Gauss-Newton step that lowers a residual above STALL_FLOOR by less than STALL of it: ``no_assembly``.
STALL, STALL_FLOOR = 1e-6, 1e-8
#: Positions and random poses per position of the start search; iterations per try.
SEARCH_POSITIONS, SEARCH_TRIES, SEARCH_ITER = 8, 64, 60
#: Intermediate drive positions between two rows of the continuation.
SUBSTEPS = 4


@dataclass(frozen=True)
class Pose:
    """One pose: ``values`` ``(joint, name) -> value`` and ``rotations`` (S joint -> ``(3, 3)``)."""

    values: dict[tuple[int, str], float]
    rotations: dict[int, np.ndarray]

    def named(self) -> dict[str, float]:
        """Every scalar coordinate by its column name (``theta2``, ``s4``)."""
        return {f"{name}{k + 1}": v for (k, name), v in self.values.items()}


def prescribed_values(mechanism: LoopMechanism, position: float) -> dict[tuple[int, str], float]:
    """The prescribed coordinates at a drive position: the drive's, a C drive's slide by its axial law
    :math:`S = S_0 + S_S\\sin(c\\,\\theta)`."""
    d = mechanism.drive
    out = {(d.joint, d.coordinate): float(position)}
    if len(mechanism.prescribed) == 2:
        out[(d.joint, "s")] = d.axial_shift + d.axial_amplitude * np.sin(d.axial_cycles * position)
    return out


def residual(mechanism: LoopMechanism, pose: Pose) -> tuple[np.ndarray, list, list]:
    """The scaled residual ``(6,)`` (module docstring) and the chain's joint and link frames."""
    joint_frames, link_frames = chain(mechanism, pose.values, pose.rotations)
    end, ground = link_frames[-1], ground_frame(mechanism)
    turn = Rotation.from_matrix(ground[:3, :3].T @ end[:3, :3]).as_rotvec()
    return np.r_[(end[:3, 3] - ground[:3, 3]) / mechanism.length, ground[:3, :3] @ turn], \
        joint_frames, link_frames


def _columns(mechanism: LoopMechanism, pose: Pose, joint_frames: list, end: np.ndarray,
             held: tuple[int, ...] = ()) -> list:
    """``[(key, column (6,))]`` of every free variable: ``(k, name)`` or ``(k, axis)`` of an S joint (none of
    the joints ``held``)."""
    length, p = mechanism.length, end[:3, 3]
    prescribed = set(mechanism.prescribed)
    out = []
    for k, joint in enumerate(mechanism.joints):
        if k in held:
            continue
        g = joint_frames[k]
        c, z = g[:3, 3], g[:3, 2]
        if joint.type == "S":
            out += [((k, axis), np.r_[np.cross(e, p - c) / length, e]) for axis, e in enumerate(np.eye(3))]
            continue
        for name in COORDINATES[joint.type]:
            if (k, name) in prescribed:
                continue
            if name == "s":
                out.append(((k, name), np.r_[z / length, np.zeros(3)]))
                continue
            u = z if name == "theta" else g[:3, :3] @ np.array([-np.sin(pose.values[(k, "theta")]),
                                                                  np.cos(pose.values[(k, "theta")]), 0.0])
            out.append(((k, name), np.r_[np.cross(u, p - c) / length, u]))
    return out


def _moved(pose: Pose, keys: list, step: np.ndarray, joint_frames: list) -> Pose:
    values, rotations = dict(pose.values), dict(pose.rotations)
    for key, dx in zip(keys, step):
        if isinstance(key[1], str):
            values[key] += dx
    for k in rotations:
        world = np.array([dx for key, dx in zip(keys, step) if key[0] == k and not isinstance(key[1], str)])
        if world.size:
            g = joint_frames[k][:3, :3]
            # projected back onto the rotations: products of thousands of steps drift off them by
            # round-off, and the residual with them (a random CSSP's grew to 1e-13 over 15 rows)
            turned = g.T @ Rotation.from_rotvec(world).as_matrix() @ g @ rotations[k]
            rotations[k] = Rotation.from_matrix(turned).as_matrix()
    return Pose(values, rotations)


def close_at(mechanism: LoopMechanism, pose: Pose, position: float, max_iter: int = MAX_ITER,
             held: tuple[int, ...] = ()) -> tuple[Pose, str, float]:
    """Levenberg-Marquardt from ``pose`` with the prescribed coordinates at ``position`` (and the joints
    ``held`` as they are): the pose, its status word and its scaled residual (module docstring)."""
    pose = Pose({**pose.values, **prescribed_values(mechanism, position)}, pose.rotations)
    r, joint_frames, link_frames = residual(mechanism, pose)
    mu = 1e-12
    for _ in range(max_iter):
        norm = float(np.linalg.norm(r))
        columns = _columns(mechanism, pose, joint_frames, link_frames[-1], held)
        keys, jac = [key for key, _ in columns], np.array([col for _, col in columns]).T
        if norm <= CLOSURE_TOL:
            trial = _moved(pose, keys, -np.linalg.lstsq(jac, r, rcond=None)[0], joint_frames)
            r_trial = residual(mechanism, trial)[0]
            better = float(np.linalg.norm(r_trial)) < norm
            return (trial if better else pose), Status.OK.value, min(norm, float(np.linalg.norm(r_trial)))
        normal, grad = jac.T @ jac, jac.T @ r
        while mu <= 1e12:
            step = -np.linalg.solve(normal + mu * max(normal.diagonal().max(), 1.0) * np.eye(len(keys)), grad)
            trial = _moved(pose, keys, step, joint_frames)
            r_trial, g_trial, l_trial = residual(mechanism, trial)
            progress = norm - float(np.linalg.norm(r_trial))
            if progress > 0.0:
                if mu <= 1e-6 and norm > STALL_FLOOR and progress <= STALL * norm:
                    return trial, Status.NO_ASSEMBLY.value, norm - progress
                pose, r, joint_frames, link_frames = trial, r_trial, g_trial, l_trial
                mu = max(mu / 10.0, 1e-15)
                break
            mu *= 10.0
        else:
            return pose, Status.NO_ASSEMBLY.value, norm
    return pose, Status.NOT_CONVERGED.value, float(np.linalg.norm(r))


def branch_sign(mechanism: LoopMechanism, pose: Pose) -> int:
    """The sign of the determinant of :func:`square_jacobian`: it changes only through a singular pose (an
    edge of assembly, a joint lock), so it labels the branch; 0 where the Jacobian is not square (a loop of
    other mobility)."""
    square = square_jacobian(mechanism, pose)
    return 0 if square is None else int(np.sign(np.linalg.det(square)))


def square_jacobian(mechanism: LoopMechanism, pose: Pose) -> np.ndarray | None:
    """The closure's Jacobian over the free variables (:func:`_columns`) made square by one gauge row per
    idle spin (an S-S link: its spin about the line through the two centres at the first S joint's
    columns); ``None`` where it is not square (a loop of other mobility)."""
    joint_frames, link_frames = chain(mechanism, pose.values, pose.rotations)
    columns = _columns(mechanism, pose, joint_frames, link_frames[-1])
    keys, jac = [key for key, _ in columns], np.array([col for _, col in columns])
    joints = mechanism.joints
    gauges = []
    for k, joint in enumerate(joints):
        after = (k + 1) % len(joints)
        if joint.type == "S" and joints[after].type == "S":
            u = joint_frames[after][:3, 3] - joint_frames[k][:3, 3]
            u /= np.linalg.norm(u)
            gauges.append([u[key[1]] if key[0] == k and not isinstance(key[1], str) else 0.0 for key in keys])
    square = np.vstack([jac.T, *gauges]) if gauges else jac.T
    return square if square.shape[0] == square.shape[1] else None


def close_along(mechanism: LoopMechanism, pose: Pose, start: float, end: float,
                step: float = math.radians(2.0)) -> tuple[Pose, str]:
    """``pose`` (closed at drive position ``start``) carried to ``end`` in steps of at most ``step`` (a
    slide drive: times the table's length), each closed from the last: the pose and its status word
    (``branch_jump`` where a step closes on another branch, :func:`branch_sign`)."""
    if mechanism.drive.coordinate == "s":
        step *= mechanism.length
    word, branch = Status.OK.value, branch_sign(mechanism, pose)
    for x in np.linspace(start, end, max(1, math.ceil(abs(end - start) / step)) + 1)[1:]:
        pose, word, _ = close_at(mechanism, pose, x)
        if word == Status.OK.value and branch_sign(mechanism, pose) != branch:
            word = Status.BRANCH_JUMP.value
        if word != Status.OK.value:
            break
    return pose, word


def start_guess(mechanism: LoopMechanism) -> Pose:
    """The joints' ``start`` values as a pose (zeros, identity rotations where none is given)."""
    values, rotations = {}, {}
    for k, joint in enumerate(mechanism.joints):
        if joint.type == "S":
            rotations[k] = Rotation.from_rotvec(joint.start).as_matrix() if joint.start else np.eye(3)
            continue
        start = joint.start or (0.0,) * len(COORDINATES[joint.type])
        values.update({(k, name): float(v) for name, v in zip(COORDINATES[joint.type], start)})
    return Pose(values, rotations)


def _random_pose(mechanism: LoopMechanism, rng: np.random.Generator) -> Pose:
    length = mechanism.length
    guess = start_guess(mechanism)
    values = {key: rng.uniform(-2.0, 2.0) * length if key[1] == "s" else rng.uniform(-np.pi, np.pi)
              for key in guess.values}
    rotations = {k: Rotation.random(random_state=rng).as_matrix() for k in guess.rotations}
    return Pose(values, rotations)


def search_start(mechanism: LoopMechanism, seed: int = 0) -> tuple[Pose, int]:
    """A closed start pose and the row it is closed at (module docstring).

    Raises
    ------
    ValueError
        If no joint gives ``start`` values and the search closes no pose.
    """
    positions = mechanism.drive.positions
    if any(j.start for j in mechanism.joints):
        guess = start_guess(mechanism)
        last = len(mechanism.joints) - 1
        if mechanism.joints[last].start:  # the last joint's start picks the branch: the others fitted first
            guess = close_at(mechanism, guess, positions[0], held=(last,))[0]
        return close_at(mechanism, guess, positions[0])[0], 0
    rng = np.random.default_rng(seed)
    n = positions.size
    for at in np.unique(np.linspace(0, n - 1, min(n, SEARCH_POSITIONS)).round().astype(int)):
        tries = (close_at(mechanism, _random_pose(mechanism, rng), positions[at], SEARCH_ITER)
                 for _ in range(SEARCH_TRIES))
        closed = [pose for pose, status, _ in tries if status == Status.OK.value]
        if closed:
            pose = closed[nearest_to_zero([pose.named() for pose in closed])]
            values = {key: float(np.remainder(v + np.pi, 2 * np.pi) - np.pi) if key[1] != "s" else v
                      for key, v in pose.values.items()}
            return Pose(values, pose.rotations), int(at)
    raise ValueError(f"start: the Exudyn judge found no assembled pose at {min(n, SEARCH_POSITIONS)} drive "
                     "positions; give the joints' start values")
