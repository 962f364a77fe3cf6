"""The judge's own closure of a loop table: Levenberg-Marquardt on the cut's rows, continued along the drive.

At each drive position the prescribed coordinates are set and the free ones moved by damped Gauss-Newton
(Levenberg-Marquardt) steps on the cut's residual (:mod:`.model`: linear rows over the table's length, angular
rows as they are) from Pinocchio's frame placement and Jacobian, ``pin.integrate`` turning the quaternions.
The damping keeps the steps minimum-norm in the idle spins' directions.

The first pose is the table's ``start`` values (what the user wrote) at the first position when any joint
gives them (the last joint's, which are no coordinates of the tree, through a least-squares fit of the cut's
six relative motions that picks the branch: :func:`_fit_cut`), else, of the poses this module's own random
search closes at the first of up to :data:`SEARCH_POSITIONS` evenly spread positions where any closes, the
one nearest the zero pose (:func:`~dualmech.models.loop.start.nearest_to_zero`). From there the loop is closed
position by position (:mod:`.continuation`). The branch is the sign of the determinant of the square rate
matrix (the cut's rows and the gauge rows over the free coordinates: :func:`branch`). Statuses
(:mod:`dualmech.core.status`'s words): ``no_assembly`` where the steps stall at a non-zero residual (the
gradient vanishes, a Gauss-Newton step barely lowers it: :data:`STALL`, or the iterations run out with
the damped steps creeping: :data:`CREEP`), ``not_converged`` where the iterations run out otherwise or the
steps reach a root the cut joint cannot take (an R or C cut's axes opposite,
:func:`aligned`), else ``ok``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from dualmech.core.status import Status
from dualmech.models.loop.start import nearest_to_zero
from dualmech.validation.judges.pinocchio_loop.model import COORDINATES, LoopModel

LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
#: Closure tolerance on the scaled residual's norm (linear rows over the table's length): two orders above
#: rounding, so every converged pose is within ~1e-13 of the table's length of closing.
CLOSURE_TOL = 1e-13
#: Iterations before ``not_converged``.
MAX_ITER = 400
#: The gradient over (Jacobian norm x residual) below which the steps have stalled: ``no_assembly``.
STATIONARY = 1e-9
#: Also ``no_assembly``: an undamped (Gauss-Newton) step that lowers a residual above STALL_FLOOR by less
#: than STALL of it.  Beyond an assembly limit the residual's least-squares minimum is a singular pose, where
#: the steps creep (a random RRSRR: 256 steps to meet STATIONARY); a residual that
#: goes to zero drops by a fixed fraction per step at least, and STALL_FLOOR keeps rounding out of it.
STALL, STALL_FLOOR = 1e-6, 1e-8
#: Also ``no_assembly``, when the iterations run out: a residual above STALL_FLOOR that fell by less than
#: CREEP of itself over the last CREEP_ITER iterations, the damped steps creeping to a non-zero minimum (a
#: random RRSC beyond its assembly limit: 5.6e-2 of the table's length after 400 iterations, 2e-4 of it less
#: than 100 iterations before); a residual that goes to zero falls by orders of magnitude in as many.
CREEP, CREEP_ITER = 1e-2, 100
#: Positions tried, evenly spread, random poses tried at each, and iterations per try, when searching for a
#: start (a random pose that closes does so in a few dozen iterations; the others are dropped early).
SEARCH_POSITIONS, SEARCH_TRIES, SEARCH_ITER = 8, 64, 50


@dataclass(frozen=True)
class Closure:
    """The loop closed at ``n`` drive positions.

    Attributes
    ----------
    q : numpy.ndarray, shape (n, nq)
        Pinocchio configurations (meaningful where ``status`` is ``ok``).
    status : numpy.ndarray of str, shape (n,)
    residual : numpy.ndarray, shape (n,)
        Scaled residual norm at the end.
    iterations : numpy.ndarray of int, shape (n,)
    """

    q: np.ndarray
    status: np.ndarray
    residual: np.ndarray
    iterations: np.ndarray


def prescribed_motion(lm: LoopModel) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Value, rate and acceleration ``(n, p)`` of the prescribed coordinates (order of ``lm.prescribed``):
    the drive's, and a C drive's slide by its axial law :math:`S = S_0 + S_S\\sin(c\\,\\theta)` (thesis
    eq. 27-28) differentiated here."""
    d = lm.mechanism.drive
    x = d.positions
    w, wd = np.full_like(x, d.speed), np.full_like(x, d.accel)
    columns = [(x, w, wd)]
    if len(lm.prescribed) == 2:
        amp, cyc = d.axial_amplitude, d.axial_cycles
        phase = cyc * x
        columns.append((d.axial_shift + amp * np.sin(phase), amp * cyc * np.cos(phase) * w,
                        amp * cyc * (np.cos(phase) * wd - cyc * np.sin(phase) * w**2)))
    return tuple(np.stack(c, axis=1) for c in zip(*columns))


def _tilt(lm: LoopModel, relative: np.ndarray) -> float:
    """The angular rows' divisor: :math:`(1 + z_{A'}\\cdot z_B)/2` for an R or C cut (1 when the axes are
    along each other, 0 when opposite), else 1."""
    if lm.mechanism.joints[-1].type not in ("R", "C"):
        return 1.0
    return max((1.0 + relative[2, 2]) / 2.0, 1e-12)


def cut_rows(lm: LoopModel, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The cut's residual ``(m,)``, Jacobian ``(m, nv)`` and each row's unit wrench ``(m, 6)`` on link n-1
    (force, moment about ``A'``; world) at ``q``, unscaled (lengths, unit dots, radians).  Row ``k``'s
    Jacobian is its wrench's power on the frame's twist, so its multiplier is the size of that wrench.

    An R or C cut's angular rows are divided by :func:`_tilt`, so they grow without bound toward their
    spurious root (the axes opposite) and the steps keep away from it; at the closed pose the divisor is 1
    and its derivative multiplies a zero residual, so the Jacobian there is exact (elsewhere the divisor's
    derivative is left out: a Newton step with it would converge no faster)."""
    model, data = lm.model, lm.data
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    a, b = data.oMf[lm.cut], lm.ground
    jac = pin.getFrameJacobian(model, data, lm.cut, LWA)
    relative = b.rotation.T @ a.rotation
    log = pin.log3(relative)
    turn = a.rotation @ pin.Jlog3(relative).T  # columns: the moments of the rotation-vector rows
    tilt = _tilt(lm, relative)
    res, wrenches = [], []
    for kind, i, k in lm.rows:
        axis = b.rotation[:, k]
        if kind == "lin":
            res.append((a.translation - b.translation) @ axis)
            wrenches.append(np.r_[axis, np.zeros(3)])
        elif kind == "ang":
            res.append(a.rotation[:, i] @ axis / tilt)
            wrenches.append(np.r_[np.zeros(3), np.cross(a.rotation[:, i], axis)] / tilt)
        else:
            res.append(log[k])
            wrenches.append(np.r_[np.zeros(3), turn[:, k]])
    wrenches = np.array(wrenches)
    return np.array(res), wrenches @ jac, wrenches


def aligned(lm: LoopModel) -> bool:
    """Whether the cut's angular rows hold with the axes parallel, not opposite (``z_A'`` along ``z_B``,
    the spurious root of the dot products; after :func:`cut_rows`)."""
    if lm.mechanism.joints[-1].type not in ("R", "C"):
        return True
    return bool(lm.data.oMf[lm.cut].rotation[:, 2] @ lm.ground.rotation[:, 2] > 0.0)


def rate_matrix(lm: LoopModel, jac: np.ndarray) -> np.ndarray:
    """The cut's Jacobian with the idle spins' gauge rows below, ``(m + spins, nv)`` (after
    :func:`cut_rows` at the same ``q``)."""
    gauge = [pin.getJointJacobian(lm.model, lm.data, j, pin.ReferenceFrame.LOCAL)[3] for j in lm.spins]
    return np.vstack([jac, *gauge]) if gauge else jac


def _scale(lm: LoopModel) -> np.ndarray:
    return np.array([1.0 / lm.length if kind == "lin" else 1.0 for kind, _, _ in lm.rows])


def _set(lm: LoopModel, q: np.ndarray, values: np.ndarray) -> np.ndarray:
    """``q`` with the prescribed coordinates at ``values`` (order of ``lm.prescribed``)."""
    q = q.copy()
    for key, value in zip(lm.mechanism.prescribed, values):
        q[lm.coordinates[key][0]] = value
    return q


def _polish(lm: LoopModel, q: np.ndarray, norm: float, ju: np.ndarray,
            r: np.ndarray) -> tuple[np.ndarray, float]:
    """One more minimum-norm Gauss-Newton step from a converged pose, kept if it lowers the residual: near an
    edge of assembly the kinematics carry the residual over a small condition, so the closure goes on to
    rounding (a random RRSRR's accelerations moved from 2.4e-10 to 7e-13 of their peak)."""
    step = np.zeros(lm.model.nv)
    step[list(lm.free)] = -np.linalg.lstsq(ju, r, rcond=None)[0]
    trial = pin.integrate(lm.model, q, step)
    r_trial, _, _ = cut_rows(lm, trial)
    polished = float(np.linalg.norm(r_trial * _scale(lm)))
    if polished < norm:
        return trial, polished
    cut_rows(lm, q)  # the caller reads the frames of q
    return q, norm


def close_at(lm: LoopModel, q: np.ndarray, values: np.ndarray,
             max_iter: int = MAX_ITER) -> tuple[np.ndarray, str, float, int]:
    """Levenberg-Marquardt from ``q`` with the prescribed coordinates at ``values``: the pose, its status
    word, the scaled residual and the iterations, at most ``max_iter`` (module docstring)."""
    q, scale, free, mu = _set(lm, q, values), _scale(lm), list(lm.free), 1e-12
    r, jac, _ = cut_rows(lm, q)
    r, norms = r * scale, []
    for it in range(max_iter):
        norm = float(np.linalg.norm(r))
        norms.append(norm)
        ju = jac[:, free] * scale[:, None]
        if norm <= CLOSURE_TOL:
            q, norm = _polish(lm, q, norm, ju, r)
            return q, Status.OK.value if aligned(lm) else Status.NOT_CONVERGED.value, norm, it
        grad = ju.T @ r
        if np.linalg.norm(grad) <= STATIONARY * np.linalg.norm(ju) * norm or mu > 1e12:
            return q, Status.NO_ASSEMBLY.value, norm, it
        normal = ju.T @ ju
        while mu <= 1e12:
            step = np.zeros(lm.model.nv)
            step[free] = -np.linalg.solve(normal + mu * max(normal.diagonal().max(), 1.0) * np.eye(len(free)),
                                          grad)
            trial = pin.integrate(lm.model, q, step)
            r_trial, jac_trial, _ = cut_rows(lm, trial)
            progress = norm - float(np.linalg.norm(r_trial * scale))
            if progress > 0.0:
                if mu <= 1e-6 and norm > STALL_FLOOR and progress <= STALL * norm:
                    return trial, Status.NO_ASSEMBLY.value, norm - progress, it + 1
                q, r, jac, mu = trial, r_trial * scale, jac_trial, max(mu / 10.0, 1e-15)
                break
            mu *= 10.0
    norm = float(np.linalg.norm(r))
    crept = len(norms) >= CREEP_ITER and norm > STALL_FLOOR and norms[-CREEP_ITER] - norm < CREEP * norm
    return q, (Status.NO_ASSEMBLY if crept else Status.NOT_CONVERGED).value, norm, max_iter


def branch(lm: LoopModel, q: np.ndarray) -> float:
    """The sign of the determinant of the rate matrix over the free coordinates at ``q`` (module
    docstring)."""
    _, jac, _ = cut_rows(lm, q)
    return float(np.sign(np.linalg.det(rate_matrix(lm, jac)[:, list(lm.free)])))


def _joint_motion(kind: str, start: tuple[float, ...]) -> pin.SE3:
    """Joint motion of a cut joint of type ``kind`` at its ``start`` values, after its constant part."""
    values = dict(zip(COORDINATES[kind], start))
    if kind == "S":
        return pin.SE3(pin.exp3(np.asarray(start, float)), np.zeros(3))
    rot = pin.exp3(np.array([0.0, 0.0, values.get("theta", 0.0)])) @ \
        pin.exp3(np.array([0.0, values.get("eta", 0.0), 0.0]))
    return pin.SE3(rot, np.array([0.0, 0.0, values.get("s", 0.0)]))


def _fit_cut(lm: LoopModel, q: np.ndarray, values: np.ndarray) -> np.ndarray:
    """``q`` moved by Gauss-Newton steps toward the cut frame that joint n's ``start`` values give: all six
    relative motions held, so the user's start picks the branch (a fit: it need not close)."""
    last = lm.mechanism.joints[-1]
    target = lm.ground * _joint_motion(last.type, last.start).inverse()
    q, free = _set(lm, q, values), list(lm.free)
    for _ in range(MAX_ITER):
        pin.computeJointJacobians(lm.model, lm.data, q)
        pin.updateFramePlacements(lm.model, lm.data)
        error = target.actInv(lm.data.oMf[lm.cut])
        r = pin.log6(error).vector * np.r_[np.full(3, 1.0 / lm.length), np.ones(3)]
        jac = pin.Jlog6(error) @ pin.getFrameJacobian(lm.model, lm.data, lm.cut, pin.ReferenceFrame.LOCAL)
        jac = jac[:, free] * np.r_[np.full(3, 1.0 / lm.length), np.ones(3)][:, None]
        step = np.zeros(lm.model.nv)
        step[free] = -np.linalg.lstsq(jac, r, rcond=None)[0]
        if np.linalg.norm(step) <= CLOSURE_TOL:
            break
        q = pin.integrate(lm.model, q, step)
    return q


def start_pose(lm: LoopModel, values: np.ndarray) -> np.ndarray:
    """The joints' ``start`` values as a configuration (zeros, identity rotations where none is given),
    fitted to the last joint's start if it has one (:func:`_fit_cut`); ``values``: the prescribed
    coordinates at the first position."""
    q = pin.neutral(lm.model)
    for k, joint in enumerate(lm.mechanism.joints[:-1]):
        if not joint.start:
            continue
        if joint.type == "S":
            iq = lm.model.joints[lm.link_joints[k]].idx_q
            q[iq:iq + 4] = pin.Quaternion(pin.exp3(np.asarray(joint.start, float))).coeffs()
            continue
        for name, value in zip(COORDINATES[joint.type], joint.start):
            q[lm.coordinates[(k, name)][0]] = value
    return _fit_cut(lm, q, values) if lm.mechanism.joints[-1].start else q


def _random_pose(lm: LoopModel, rng: np.random.Generator) -> np.ndarray:
    q = pin.neutral(lm.model)
    for (k, name), (iq, _) in lm.coordinates.items():
        q[iq] = rng.uniform(-2.0, 2.0) * lm.length if name == "s" else rng.uniform(-np.pi, np.pi)
    for k, joint in enumerate(lm.mechanism.joints[:-1]):
        if joint.type == "S":
            iq = lm.model.joints[lm.link_joints[k]].idx_q
            quat = rng.normal(size=4)
            q[iq:iq + 4] = quat / np.linalg.norm(quat)
    return q


def cut_values(lm: LoopModel) -> dict[str, float]:
    """The cut joint's (joint n's) coordinates, by name (``theta<n>``, ``s<n>``, ``eta<n>``), from the frame
    placements Pinocchio last computed: the relative pose ``A'^-1 B`` of its two frames."""
    pin.updateFramePlacements(lm.model, lm.data)
    r = lm.data.oMf[lm.cut].actInv(lm.ground)
    rot, n = r.rotation, len(lm.mechanism.joints)
    kind = lm.mechanism.joints[n - 1].type
    out = {}
    if kind in ("R", "C"):
        out[f"theta{n}"] = float(np.arctan2(rot[1, 0], rot[0, 0]))
    if kind in ("P", "C"):
        out[f"s{n}"] = float(r.translation[2])
    if kind == "U":
        out[f"theta{n}"] = float(np.arctan2(-rot[0, 1], rot[1, 1]))
        out[f"eta{n}"] = float(np.arctan2(-rot[2, 0], rot[2, 2]))
    return out


def pose_values(lm: LoopModel, q: np.ndarray) -> dict[str, float]:
    """Every scalar joint coordinate of the closed pose ``q`` by name (``theta2``, ``s4``, ...)."""
    pin.forwardKinematics(lm.model, lm.data, q)
    values = {f"{name}{k + 1}": float(q[iq]) for (k, name), (iq, _) in lm.coordinates.items()}
    return {**values, **cut_values(lm)}


def search_start(lm: LoopModel, values: np.ndarray, seed: int = 0) -> tuple[np.ndarray, int]:
    """A closed start pose and its position: the table's ``start`` values at position 0 if any joint gives
    them, else, at the first of :data:`SEARCH_POSITIONS` evenly spread positions where one of
    :data:`SEARCH_TRIES` random poses closes, the closed pose nearest the zero pose
    (:func:`~dualmech.models.loop.start.nearest_to_zero`, module docstring)."""
    if any(j.start for j in lm.mechanism.joints):
        return start_pose(lm, values[0]), 0
    rng = np.random.default_rng(seed)
    n = values.shape[0]
    for at in np.unique(np.linspace(0, n - 1, min(n, SEARCH_POSITIONS)).round().astype(int)):
        closed = [q for q, status, _, _ in (close_at(lm, _random_pose(lm, rng), values[at], SEARCH_ITER)
                                            for _ in range(SEARCH_TRIES)) if status == Status.OK.value]
        if closed:
            return closed[nearest_to_zero([pose_values(lm, q) for q in closed])], int(at)
    raise ValueError(f"start: the Pinocchio judge found no assembled pose at {min(n, SEARCH_POSITIONS)} "
                     "drive positions; give the joints' start values")
