"""The MuJoCo loop judge's model and closure: the table's MJCF compiled, the cut closed by Newton.

The unknowns of one position are the velocity-space coordinates ``u = [qvel (nv), joint n's rates]``:
MuJoCo's dofs of joints 1 .. n-1 (:mod:`.mjcf`) and the cut joint n's variables (``theta``, ``s``,
``eta``: none for a ball), minus the prescribed ones (the drive, and a C drive's slide by its axial law).
The cut's frame ``C`` is the site ``cut_link`` (frame {n}, on link n-1) times joint n's motion
:math:`Z(\\theta_n + \\varepsilon s_n) Y(\\eta_n)`, its point ``p_C`` the origin of that product; closed,
``C`` is the site ``cut_ground`` (6 equations; a ball cut: the two sites' origins meet, 3 equations).
Its Jacobian over ``u`` (:func:`cut_rows`): MuJoCo's ``mj_jac`` of link n-1 at ``p_C`` (translation) and
its rotational rows, and joint n's own screws (a turning axis through ``p_C``: a rotation column; a slide:
a translation column).  Newton takes the minimum-norm step of the free columns (the idle spin of an S-S
link is left where it is), with step halving when the gap grows; the tree's dofs move by
``mj_integratePos``.

Branch: the sign of the determinant of the square matrix of the cut rows and the spin-gauge rows
(:func:`gauge_rows`) over the free columns labels the assembly branch; it changes only through a singular
pose, so a position closed with another sign than the start pose's is a branch jump.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from dualmech.models.loop.description import LoopMechanism
from dualmech.validation.judges.mujoco_loop.mjcf import CUT_SITES, MJ_JOINTS, body_name, joint_name, loop_mjcf

#: Newton stops below this gap (translations over the table's length) ...
CLOSURE_TOL = 1e-14
#: ... or when the gap stops shrinking below this one (the floor of rounding) ...
ROUNDING_GAP = 1e-11
#: ... or after this many iterations; then Levenberg-Marquardt takes at most this many.
MAX_ITER = 30
DESCENT_ITER = 300
#: An unconverged Newton whose gradient ``|J^T e|`` is below this fraction of ``|J| |e|`` stopped at a
#: stationary non-zero gap: no assembly there.
STATIONARY = 1e-7
#: Also no assembly: a Levenberg-Marquardt descent whose gap, above CREEP_FLOOR, fell by less than CREEP of
#: itself over the last CREEP_ITER steps, creeping to a non-zero minimum.  A random RCCC past its assembly
#: limit: 9.32e-2 after 25 steps, 9.31e-2 after 300 (DESCENT_ITER), in each of 911 tries of its branch
#: searches, 26 s of the judge's 26 s.  The descents that closed on three such RCCCs and an RSSR fell to at
#: most 0.09 of their gap in any 50 steps.
CREEP, CREEP_ITER, CREEP_FLOOR = 1e-2, 50, 1e-8


def variable(joint: int, coordinate: str) -> str:
    """Name of joint ``joint``'s (0-based) ``coordinate`` in the result table, e.g. ``theta1``."""
    return f"{coordinate}{joint + 1}"


def _rot(axis: int, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    r = np.eye(3)
    r[i, i], r[i, j], r[j, i], r[j, j] = c, -s, s, c
    return r


@dataclass
class MjLoop:
    """A compiled table and the addresses the judge needs (mutable scratch: ``data`` and ``q_cut``)."""

    mechanism: LoopMechanism
    model: mujoco.MjModel
    data: mujoco.MjData
    bodies: tuple[int, ...]  # body id of links 1 .. n-1
    coordinates: dict[str, tuple[int, int]]  # scalar variable -> (index in u, qpos address; -1: the cut's)
    cut: tuple[str, ...]  # joint n's coordinates (theta, s, eta), empty for a ball
    q_cut: np.ndarray  # their values
    sites: tuple[int, int]  # cut_link, cut_ground
    prescribed: np.ndarray  # indices in u of the prescribed coordinates
    free: np.ndarray  # the others
    idle: tuple[int, ...]  # 0-based joints i whose link i+1 spins idly (S at i and i+1)
    size: float  # the table's length: its largest constant length, or 1

    @property
    def n_u(self) -> int:
        """Size of the velocity-space coordinates ``u``."""
        return self.model.nv + len(self.cut)

    @property
    def ball_cut(self) -> bool:
        """Whether joint n is spherical (a connect cut, 3 equations)."""
        return self.mechanism.joints[-1].type == "S"


def build(mechanism: LoopMechanism, xml: str | None = None) -> MjLoop:
    """Compile :func:`~.mjcf.loop_mjcf` of ``mechanism`` (or the given text) and collect the addresses."""
    model = mujoco.MjModel.from_xml_string(loop_mjcf(mechanism) if xml is None else xml)
    joints = mechanism.joints
    n = len(joints)
    coordinates: dict[str, tuple[int, int]] = {}
    for i in range(n - 1):
        for coordinate, kind, _ in MJ_JOINTS[joints[i].type]:
            if kind != "ball":
                jid = model.joint(joint_name(i, coordinate)).id
                coordinates[variable(i, coordinate)] = (int(model.jnt_dofadr[jid]),
                                                        int(model.jnt_qposadr[jid]))
    cut = tuple(c for c, kind, _ in MJ_JOINTS[joints[-1].type] if kind != "ball")
    for k, coordinate in enumerate(cut):
        coordinates[variable(n - 1, coordinate)] = (model.nv + k, -1)
    d = mechanism.drive
    names = [variable(d.joint, d.coordinate)]
    if joints[d.joint].type == "C":
        names.append(variable(d.joint, "s"))
    prescribed = np.array([coordinates[name][0] for name in names])
    free = np.setdiff1d(np.arange(model.nv + len(cut)), prescribed)
    sizes = [abs(v) for j in joints for v in (j.a, j.s)]
    size = max(sizes) if max(sizes) > 0.0 else 1.0
    idle = tuple(i for i in range(n - 1) if joints[i].type == "S" and joints[i + 1].type == "S")
    return MjLoop(mechanism, model, mujoco.MjData(model),
                  tuple(model.body(body_name(k)).id for k in range(1, n)), coordinates, cut,
                  np.zeros(len(cut)), (model.site(CUT_SITES[0]).id, model.site(CUT_SITES[1]).id),
                  prescribed, free, idle, size)


def positions(lp: MjLoop) -> None:
    """MuJoCo's kinematics and com-based frames at the current ``qpos`` (what ``mj_jac`` needs)."""
    mujoco.mj_kinematics(lp.model, lp.data)
    mujoco.mj_comPos(lp.model, lp.data)


def cut_frame(lp: MjLoop) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """Point ``p_C`` ``(3,)``, rotation ``R_C`` ``(3, 3)`` of the cut frame (module docstring) and the
    world axis ``(3,)`` of each of joint n's coordinates (``z`` of frame {n} for ``theta`` and ``s``, the
    turned ``y`` for ``eta``), at the current pose."""
    d, joint = lp.data, lp.mechanism.joints[-1]
    p_a, r_a = d.site_xpos[lp.sites[0]].copy(), d.site_xmat[lp.sites[0]].reshape(3, 3).copy()
    values = dict(zip(lp.cut, lp.q_cut))
    z = r_a[:, 2]
    turned = r_a @ _rot(2, joint.theta + values.get("theta", 0.0))
    axes = {"theta": z, "s": z, "eta": turned[:, 1]}
    p_c = p_a + (joint.s + values.get("s", 0.0)) * z
    return p_c, turned @ _rot(1, values.get("eta", 0.0)), {c: axes[c] for c in lp.cut}


def cut_rows(lp: MjLoop) -> np.ndarray:
    """Jacobian of the cut frame's motion over ``u``: ``(6, n_u)`` (translation of ``p_C``, then rotation,
    world axes), or ``(3, n_u)`` for a ball cut (module docstring).  Current pose, after
    :func:`positions`."""
    m, d = lp.model, lp.data
    p_c, _, axes = cut_frame(lp)
    rows = np.zeros((6, lp.n_u))
    jacp, jacr = np.empty((3, m.nv)), np.empty((3, m.nv))
    mujoco.mj_jac(m, d, jacp, jacr, p_c, lp.bodies[-1])
    rows[:3, :m.nv], rows[3:, :m.nv] = jacp, jacr
    for k, coordinate in enumerate(lp.cut):  # a slide moves p_C, a turn (about an axis through p_C) does not
        offset = 0 if coordinate == "s" else 3
        rows[offset:offset + 3, m.nv + k] = axes[coordinate]
    return rows[:3] if lp.ball_cut else rows


def gauge_axes(lp: MjLoop) -> list[tuple[int, np.ndarray]]:
    """Each idly spinning link's body id and unit axis ``u`` (from its ball centre to the next), world."""
    d, out = lp.data, []
    n = len(lp.mechanism.joints)
    for i in lp.idle:
        body = lp.bodies[i]
        end = d.xpos[lp.bodies[i + 1]] if i + 1 < n - 1 else d.site_xpos[lp.sites[0]]
        u = end - d.xpos[body]
        out.append((body, u / np.linalg.norm(u)))
    return out


def gauge_rows(lp: MjLoop) -> np.ndarray:
    """The zero-spin gauge ``(g, n_u)``: each idle link's angular velocity along its axis,
    :math:`u^T J_\\omega \\dot q` (``docs/conventions.md``, "Rod spin")."""
    m, d = lp.model, lp.data
    rows = np.zeros((len(lp.idle), lp.n_u))
    jacr = np.empty((3, m.nv))
    for g, (body, u) in enumerate(gauge_axes(lp)):
        mujoco.mj_jacBody(m, d, None, jacr, body)
        rows[g, :m.nv] = u @ jacr
    return rows


def gap(lp: MjLoop) -> np.ndarray:
    """What the cut frame must still move to close, ``(6,)`` (translation, rotation vector; world) or
    ``(3,)`` for a ball cut: ``p_B - p_C`` and :math:`\\log(R_B R_C^T)`."""
    d = lp.data
    p_c, r_c, _ = cut_frame(lp)
    translation = d.site_xpos[lp.sites[1]] - p_c
    if lp.ball_cut:
        return translation
    quat, rotation = np.empty(4), np.empty(3)
    mujoco.mju_mat2Quat(quat, (d.site_xmat[lp.sites[1]].reshape(3, 3) @ r_c.T).reshape(-1))
    mujoco.mju_quat2Vel(rotation, quat, 1.0)
    return np.concatenate([translation, rotation])


def _size(lp: MjLoop, error: np.ndarray) -> float:
    return max(np.abs(error[:3]).max() / lp.size, np.abs(error[3:]).max(initial=0.0))


def move(lp: MjLoop, step: np.ndarray) -> None:
    """Move the coordinates by a step ``(n_u,)`` in velocity space (balls by ``mj_integratePos``)."""
    mujoco.mj_integratePos(lp.model, lp.data.qpos, step[:lp.model.nv], 1.0)
    lp.q_cut = lp.q_cut + step[lp.model.nv:]


def _descend(lp: MjLoop, error: np.ndarray, size: float, scale: np.ndarray) -> tuple[str, int, float]:
    """Levenberg-Marquardt on :math:`\tfrac12|e|^2` from the current pose (Newton's fallback): to a
    closed pose, or to a stationary or creeping (:data:`CREEP`) non-zero gap (no assembly), within
    :data:`DESCENT_ITER` steps."""
    mu = None
    sizes = []
    for it in range(1, DESCENT_ITER + 1):
        if size <= CLOSURE_TOL:
            return "ok", it - 1, size
        sizes.append(size)
        if it > CREEP_ITER and size > max(CREEP_FLOOR, (1.0 - CREEP) * sizes[-1 - CREEP_ITER]):
            return "no_assembly", it - 1, size
        jac = cut_rows(lp)[:, lp.free] * scale[:, None]
        weighted = error * scale
        gradient = jac.T @ weighted
        if np.linalg.norm(gradient) <= STATIONARY * np.linalg.norm(jac) * np.linalg.norm(weighted):
            return "no_assembly", it - 1, size
        normal = jac.T @ jac
        mu = 1e-3 * np.abs(np.diag(normal)).max() if mu is None else mu
        qpos, q_cut = lp.data.qpos.copy(), lp.q_cut.copy()
        for _ in range(40):
            step = np.zeros(lp.n_u)
            try:
                step[lp.free] = np.linalg.solve(normal + mu * np.eye(normal.shape[0]), gradient)
            except np.linalg.LinAlgError:  # mu lost in the rounding of a huge normal matrix: damp more
                mu *= 4.0
                continue
            move(lp, step)
            positions(lp)
            new = gap(lp)
            if np.linalg.norm(new * scale) < np.linalg.norm(weighted):
                mu /= 3.0
                break
            lp.data.qpos[:], lp.q_cut = qpos, q_cut
            mu *= 4.0
        else:
            return "no_assembly" if size > ROUNDING_GAP else "ok", it, size
        error, size = new, _size(lp, new)
    return "not_converged", DESCENT_ITER, size


def close(lp: MjLoop) -> tuple[str, int, float]:
    """Newton on the cut's gap from the current pose, the prescribed coordinates held; where it stalls,
    Levenberg-Marquardt (:func:`_descend`).

    Returns
    -------
    outcome, iterations, gap
        ``outcome`` ``"ok"``, ``"no_assembly"`` (stopped at a stationary non-zero gap) or
        ``"not_converged"``; ``gap`` the largest translation over the table's length or rotation (rad).
    """
    scale = np.r_[np.full(3, 1.0 / lp.size), np.ones(3)][:3 if lp.ball_cut else 6]
    positions(lp)
    error = gap(lp)
    size = _size(lp, error)
    for it in range(1, MAX_ITER + 1):
        if size <= CLOSURE_TOL:
            return "ok", it - 1, size
        jac = cut_rows(lp)[:, lp.free] * scale[:, None]
        step = np.zeros(lp.n_u)
        step[lp.free] = np.linalg.lstsq(jac, error * scale, rcond=None)[0]
        qpos, q_cut = lp.data.qpos.copy(), lp.q_cut.copy()
        move(lp, step)
        positions(lp)
        new = gap(lp)
        new_size = _size(lp, new)
        if new_size >= size:
            lp.data.qpos[:], lp.q_cut = qpos, q_cut
            positions(lp)
            if size < ROUNDING_GAP:  # at the floor of rounding
                return "ok", it, size
            break
        error, size = new, new_size
    outcome, more, size = _descend(lp, error, size, scale)
    return outcome, it + more, size


def branch(lp: MjLoop) -> float:
    """Sign of the determinant of the cut and gauge rows over the free columns (module docstring)."""
    square = np.vstack([cut_rows(lp), gauge_rows(lp)])[:, lp.free]
    return float(np.sign(np.linalg.det(square)))


def coordinate_values(lp: MjLoop) -> dict[str, float]:
    """Every scalar coordinate of the current pose by name (``theta1``, ``s4``, ...; the cut's too)."""
    return {name: float(lp.data.qpos[address] if address >= 0 else lp.q_cut[index - lp.model.nv])
            for name, (index, address) in lp.coordinates.items()}


def prescribe(lp: MjLoop, values: dict[str, float]) -> None:
    """Set scalar coordinates by name (``theta1``, ...), in ``qpos`` or among the cut's."""
    for name, value in values.items():
        index, address = lp.coordinates[name]
        if address >= 0:
            lp.data.qpos[address] = value
        else:
            lp.q_cut[index - lp.model.nv] = value


def set_start(lp: MjLoop) -> None:
    """The joints' ``start`` values (zeros, and identity rotations, where a joint gives none): an S joint's
    rotation vector becomes its ball's quaternion."""
    joints = lp.mechanism.joints
    lp.data.qpos[:] = lp.model.qpos0
    lp.q_cut[:] = 0.0
    for i, joint in enumerate(joints):
        if not joint.start:
            continue
        if joint.type == "S":
            if i < len(joints) - 1:  # joint n's rotation is not a coordinate of the judge
                jid = lp.model.joint(joint_name(i, "ball")).id
                adr = lp.model.jnt_qposadr[jid]
                mujoco.mju_axisAngle2Quat(lp.data.qpos[adr:adr + 4], *_axis_angle(np.array(joint.start)))
            continue
        names = [c for c, kind, _ in MJ_JOINTS[joint.type]]
        prescribe(lp, {variable(i, c): v for c, v in zip(names, joint.start)})


def _axis_angle(rotvec: np.ndarray) -> tuple[np.ndarray, float]:
    angle = float(np.linalg.norm(rotvec))
    return (rotvec / angle if angle > 0.0 else np.array([1.0, 0.0, 0.0])), angle


def scatter(lp: MjLoop, rng: np.random.Generator) -> None:
    """A random pose of every free coordinate: angles in (-pi, pi), slides within twice the table's
    length, balls uniform rotations."""
    m = lp.model
    for j in range(m.njnt):
        adr = m.jnt_qposadr[j]
        if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_BALL:
            q = rng.normal(size=4)
            lp.data.qpos[adr:adr + 4] = q / np.linalg.norm(q)
        elif m.jnt_type[j] == mujoco.mjtJoint.mjJNT_SLIDE:
            lp.data.qpos[adr] = rng.uniform(-2.0, 2.0) * lp.size
        else:
            lp.data.qpos[adr] = rng.uniform(-np.pi, np.pi)
    lp.q_cut = np.array([rng.uniform(-2.0, 2.0) * lp.size if c == "s" else rng.uniform(-np.pi, np.pi)
                         for c in lp.cut])


__all__ = ["CLOSURE_TOL", "MjLoop", "build", "positions", "cut_frame", "cut_rows", "gauge_axes", "gauge_rows",
           "gap", "move", "close", "branch", "prescribe", "set_start", "scatter", "variable"]
