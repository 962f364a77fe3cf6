"""The generated judges on the RSSR and RCCC: each case's joint table solved by the judge of any loop table,
its columns read back as the mechanism's own table.

The case becomes its table (:func:`~dualmech.models.loop.presets.rssr_table`,
:func:`~dualmech.models.loop.presets.rccc_table`; ``docs/conventions.md``, "Loop tables") with every joint's
start a crude pose of this module's own on the case's branch (:func:`rssr_start`, :func:`rccc_start`: the
cut joint's angle at a grid point of a scan next to the wanted root, the other joints aimed from it), so
nothing of the in-house solver enters the judge.  The generated judge
(:mod:`~dualmech.validation.judges.pinocchio_loop`, :mod:`~dualmech.validation.judges.mujoco_loop`) closes
the loop from there by its own continuation; its coordinates, rates, efforts and joint wrenches are moved
to the columns, reference points and signs of ``docs/conventions.md`` ("RSSR", "RCCC"), the transmissions
computed from its own pose, and the status words given by the mechanism's rules
(:func:`~dualmech.models.linkages.rssr.status_words` on the judge's closure, transmissions and residual).

The simulated judge (:func:`simulate_case`) runs the generated simulation from the same kind of start.

**Gaps and restarts** (:func:`judge_case`): rows where the case's geometry does not reach (the coupler
misses the output crank's circle, the cones about ``z2`` and ``z4`` miss: :func:`rssr_reach`,
:func:`rccc_reach`, :func:`~dualmech.models.linkages.rssr.assembles`) are ``no_assembly``; the judge runs
from the first row that reaches, and again, from a crude start there, from every later row that reaches
but that no run has answered on the branch (past a gap, where continuity is lost; next to an assembly
limit, where the continuation may cross to the other branch).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Callable

import numpy as np
from scipy.spatial.transform import Rotation

from dualmech.core.status import Status, is_status, settle
from dualmech.models.linkages import rccc, rssr
from dualmech.models.linkages.rccc_case import RcccCase
from dualmech.models.linkages.rssr_case import RssrCase
from dualmech.models.linkages.table import LinkageTable, TableSpec
from dualmech.models.loop.description import LoopMechanism
from dualmech.models.loop.presets import rccc_table, rssr_table
from dualmech.validation.judges.mujoco_loop.table import solve_sim_table
from dualmech.validation.judges.mujoco_loop.table import solve_table as mujoco_table
from dualmech.validation.judges.pinocchio_loop.table import solve_table as pinocchio_table

#: Values of the scanned cut angle in a start (10 deg apart).
SCAN_POINTS = 36
#: Starts (:func:`scan_starts`) tried at a row before the judge's run from there is taken as it is.
MAX_CRUDE_STARTS = 4
#: The judge's words of a closed pose (the mechanism's rules then name it).
CLOSED = (Status.OK.value, Status.DEAD_CENTRE.value, Status.BRANCH_JUMP.value)
#: The mechanism's words of a row answered on the case's branch: no restart there.
ACCEPTED = (Status.OK.value, Status.DEAD_CENTRE.value, Status.ASSEMBLY_LIMIT.value)

Judge = Callable[[LoopMechanism], LinkageTable]


def _rx(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _rz(angle: np.ndarray) -> np.ndarray:
    """``Rz(angle)`` ``(..., 3, 3)`` of angles ``(...)``."""
    c, s, z, o = np.cos(angle), np.sin(angle), np.zeros_like(angle), np.ones_like(angle)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2)


def _wrap(angle: np.ndarray) -> np.ndarray:
    """Angles (rad) in [-pi, pi)."""
    return np.mod(angle + np.pi, 2 * np.pi) - np.pi


def scan_starts(mismatch: np.ndarray, slope: int) -> list[float]:
    """Start angles (rad) for a root of the periodic ``mismatch`` ``(m,)`` sampled at ``k 2 pi / m``: grid
    points, never roots, best first.

    The mismatch has two roots a turn (a circle meets a sphere, a cone meets a cone): the one where it
    changes sign as ``slope`` (``+1`` rising) is wanted.  A start is taken on the longer of the two arcs
    between the roots, next to the root, so that Newton meets that root first, not the other one across
    the shorter arc (which near the assembly limit may be narrower than the grid step): of a bracket (two
    neighbours, cyclically, of opposite signs) the end with the sign most grid points have; with no sign
    change on the grid (both roots between two neighbours), the neighbour of the point of the smallest
    ``|mismatch|`` on the wanted root's outer side.  Order: the wanted root's start, then the other
    root's, then the ends on the shorter arc.
    """
    m = mismatch.shape[0]
    grid = 2.0 * np.pi * np.arange(m) / m
    below = mismatch < 0.0
    after = np.roll(below, -1)
    rising, falling = np.flatnonzero(below & ~after), np.flatnonzero(~below & after)
    if rising.size + falling.size == 0:
        i = int(np.argmin(np.abs(mismatch)))
        side = slope if mismatch[i] >= 0.0 else -slope
        return [float(grid[(i + side) % m]), float(grid[(i - side) % m])]
    negative_longer = 2 * int(below.sum()) >= m  # a rising bracket's outer end: its low one, if so
    pairs = [(rising, True), (falling, False)][::1 if slope > 0 else -1]
    order = [(int(lo) + int(up != negative_longer)) % m for brackets, up in pairs for lo in brackets]
    order += [(int(lo) + k) % m for lo in np.concatenate([rising, falling]) for k in (0, 1)]
    return [float(grid[i]) for i in dict.fromkeys(order)]


def rssr_start_angles(case: RssrCase, theta1: float) -> list[float]:
    """Joint 4's angles ``theta4 = pi - phi4`` (rad) to start the judge at the crank angle ``theta1`` (rad)
    on the case's branch, best first (:func:`scan_starts`): grid points next to the root of ``|P3(phi4) -
    P2|^2 - a2^2`` whose slope has the sign ``branch`` (the slope is ``2 a2 a3 t4``)."""
    g = case.geometry
    p2 = np.array([g.a1 * np.cos(theta1), g.a1 * np.sin(theta1), g.s1])
    phi = 2.0 * np.pi * np.arange(SCAN_POINTS) / SCAN_POINTS
    p3 = g.foot + g.a3 * np.stack([np.cos(phi), np.sin(phi), np.zeros_like(phi)], 1) @ g.ground_rotation().T
    return [np.pi - phi for phi in scan_starts(np.sum((p3 - p2) ** 2, axis=1) - g.a2**2, case.branch)]


def _rccc_axes(case: RcccCase, theta1: np.ndarray, theta2: np.ndarray) -> tuple[np.ndarray, ...]:
    """The world axes ``z2``, ``z3`` ``(n, 3)`` and ``z4`` ``(3,)`` at the input angles ``theta1`` and joint
    2's angles ``theta2`` ``(n,)``: rows ``Z(theta_i) X(alpha_i)`` of ``docs/conventions.md``, "RCCC"."""
    alpha = case.geometry.alpha
    link1 = _rz(theta1) @ _rx(alpha[0])
    z2 = link1[..., 2]
    z3 = (link1 @ _rz(theta2) @ _rx(alpha[1]))[..., 2]
    return z2, z3, _rx(-alpha[3])[:, 2]


def rccc_start_angles(case: RcccCase, theta1: float) -> list[float]:
    """Joint 4's angles (rad) to start the judge at the crank angle ``theta1`` (rad) on the case's branch,
    best first (:func:`scan_starts`): grid points next to the root of ``z3(theta4)·z2 - cos alpha23``
    (``z3`` from the ground through joint 4 and row 3, ``z2`` the input pose's) whose slope has the sign
    ``branch`` (the slope is ``det[z2, z3, z4]``)."""
    alpha = case.geometry.alpha
    z2, _, _ = _rccc_axes(case, np.array([theta1]), np.zeros(1))
    theta4 = 2.0 * np.pi * np.arange(SCAN_POINTS) / SCAN_POINTS
    z3 = (_rx(-alpha[3]) @ _rz(-theta4) @ _rx(-alpha[2]))[..., 2]
    return scan_starts(z3 @ z2[0] - np.cos(alpha[1]), case.branch)


def _rotvec(rot: np.ndarray) -> tuple[float, float, float]:
    """The rotation vector (rad) of a rotation matrix ``(3, 3)``."""
    return tuple(Rotation.from_matrix(rot).as_rotvec().tolist())


def rssr_start(case: RssrCase, theta1: float, theta4: float) -> tuple:
    """Every joint's start at the crank angle ``theta1`` (rad; a crude pose of this module's own): joint 4's
    angle ``theta4`` (:func:`rssr_start_angles`), the coupler aimed from ``P2`` at that output pin (its spin
    any), ball 3 the rotation left to close the loop's axes (``docs/conventions.md``, "Loop tables")."""
    g = case.geometry
    p2 = np.array([g.a1 * np.cos(theta1), g.a1 * np.sin(theta1), g.s1])
    p3 = g.foot + g.ground_rotation() @ (g.a3 * np.array([-np.cos(theta4), np.sin(theta4), 0.0]))
    u = (p3 - p2) / np.linalg.norm(p3 - p2)
    v = np.cross([0.0, 0.0, 1.0] if abs(u[2]) < 0.9 else [1.0, 0.0, 0.0], u)
    v /= np.linalg.norm(v)
    coupler = np.column_stack([u, v, np.cross(u, v)])
    output = (_rz(np.array(theta4)) @ _rx(g.alpha4)).T  # link 3's frame: row 4 closes onto the world
    return (), _rotvec(_rz(np.array(theta1)).T @ coupler), _rotvec(coupler.T @ output), (theta4,)


def rccc_start(case: RcccCase, theta1: float, theta4: float) -> tuple:
    """Every joint's start at the crank angle ``theta1`` (rad; a crude pose of this module's own): joint
    4's angle ``theta4`` (:func:`rccc_start_angles`), joint 2's turning ``z3`` nearest to the ``z3`` that
    joint 4 and row 3 give from the ground, joint 3's turning the coupler's frame nearest to link 3's; then
    the slides that close the loop's translation at those angles (it is linear in them: ``s2 z2 + s3 z3 +
    s4 z4 = -(s1 z1 + sum a_i x_i)``, least squares)."""
    g = case.geometry
    alpha, a = g.alpha, g.a
    link3 = _rx(-alpha[3]) @ _rz(np.array(-theta4))  # frame {4} from the ground's side
    z3 = link3 @ _rx(-alpha[2])[:, 2]
    frame2 = _rz(np.array(theta1)) @ _rx(alpha[0])
    z2 = frame2[:, 2]
    now = frame2 @ _rx(alpha[1])[:, 2]  # z3 at theta2 = 0
    theta2 = float(np.arctan2(z2 @ np.cross(now, z3), now @ z3 - (z2 @ now) * (z2 @ z3)))
    turn = (frame2 @ _rz(np.array(theta2)) @ _rx(alpha[1])).T @ link3 @ _rx(-alpha[2])
    theta3 = float(np.arctan2(turn[1, 0], turn[0, 0]))
    frame, axes, rest = np.eye(3), [], np.zeros(3)
    for i, theta in enumerate((theta1, theta2, theta3, theta4)):
        turned = frame @ _rz(np.array(theta))
        axes.append(frame[:, 2])
        rest += a[i] * turned[:, 0]
        frame = turned @ _rx(alpha[i])
    rest += g.s1 * axes[0]
    slides = np.linalg.lstsq(np.column_stack(axes[1:]), -rest, rcond=None)[0]
    return (), (theta2, float(slides[0])), (theta3, float(slides[1])), (theta4, float(slides[2]))


def _status(judged: LinkageTable, t1: np.ndarray, t4: np.ndarray, branch: int, torque_mode: bool
            ) -> np.ndarray:
    """The mechanism's status words from the judge's own closure (:data:`CLOSED`) and transmissions;
    ``no_assembly`` where the judge's closure stalled."""
    converged = is_status(judged.status, *CLOSED)
    status = rssr.status_words(converged, t1, t4, branch, torque_mode, judged["residual"])
    status[is_status(judged.status, Status.NO_ASSEMBLY)] = Status.NO_ASSEMBLY.value
    return status


def rssr_columns(case: RssrCase, judged: LinkageTable, not_given: tuple[str, ...] = ()) -> LinkageTable:
    """The RSSR table (:data:`~dualmech.models.linkages.rssr.SPEC`) of a generated judge's loop table
    ``judged`` of :func:`~dualmech.models.loop.presets.rssr_table` (``docs/conventions.md``, "RSSR"):
    ``phi4 = pi - theta4``; joint 4's wrench is on the ground from the output crank, about ``Q4``."""
    g = case.geometry
    theta1 = np.radians(judged["theta1_deg"])
    phi = np.pi - judged["theta4"]
    cols = {"theta1_deg": judged["theta1_deg"], "phi4_deg": np.degrees(_wrap(phi)),
            "phi4_dot": -judged["theta4_dot"], "phi4_ddot": -judged["theta4_ddot"]}
    for joint, sign, kinds in (("1", 1.0, "fm"), ("2", 1.0, "f"), ("3", 1.0, "f"), ("4", -1.0, "fm")):
        for kind in kinds:
            for axis in "xyz":
                cols[f"j{joint}_{kind}{axis}"] = sign * judged[f"joint{joint}_{kind}{axis}"]
    cols["drive_torque"] = cols["j1_mz"]
    cols["output_torque"] = np.stack([cols[f"j4_m{axis}"] for axis in "xyz"], 1) @ g.k4
    p2 = np.stack([g.a1 * np.cos(theta1), g.a1 * np.sin(theta1), np.full_like(theta1, g.s1)], 1)
    arm = g.a3 * np.stack([np.cos(phi), np.sin(phi), np.zeros_like(phi)], 1) @ g.ground_rotation().T
    u = (g.foot + arm - p2) / np.linalg.norm(g.foot + arm - p2, axis=1)[:, None]
    t1 = np.cross(p2 - np.array([0.0, 0.0, g.s1]), u)[:, 2] / g.a1
    t4 = np.cross(arm, u) @ g.k4 / g.a3
    cols.update(transmission_in=t1, transmission_out=t4, residual=judged["residual"],
                dynamics_residual=judged["dynamics_residual"])
    status = _status(judged, t1, t4, case.branch, case.mode == "torque")
    cols = {c: np.array(cols[c], dtype=float) for c in rssr.COLUMNS}
    return _settled(case, judged, cols, status, rssr.SPEC, not_given)


def rccc_columns(case: RcccCase, judged: LinkageTable, not_given: tuple[str, ...] = ()) -> LinkageTable:
    """The RCCC table (:data:`~dualmech.models.linkages.rccc.SPEC`) of a generated judge's loop table
    ``judged`` of :func:`~dualmech.models.loop.presets.rccc_table` (``docs/conventions.md``, "RCCC"): joints
    2 and 3's moments moved from their joint points (frames ``{2}``, ``{3}``) to the body origins ``s_i``
    further along ``z_i``; joint 4's wrench is on the ground from the output link, about ``G``, ``s4``
    further along ``z4`` than its joint point."""
    g = case.geometry
    theta1 = np.radians(judged["theta1_deg"])
    z2, z3, z4 = _rccc_axes(case, theta1, judged["theta2"])
    cols = {"theta1_deg": judged["theta1_deg"], "theta4_deg": np.degrees(_wrap(judged["theta4"]))}
    cols.update({name: judged[name] for name in ("s4", "theta4_dot", "s4_dot", "theta4_ddot", "s4_ddot")})
    for joint, sign, axis_of, slide in (("1", 1.0, None, None), ("2", 1.0, z2, "s2"), ("3", 1.0, z3, "s3"),
                                        ("4", -1.0, np.broadcast_to(z4, z2.shape), "s4")):
        force = np.stack([judged[f"joint{joint}_f{a}"] for a in "xyz"], 1)
        moment = np.stack([judged[f"joint{joint}_m{a}"] for a in "xyz"], 1)
        if axis_of is not None:  # about the point s_i further along z_i: m - (s_i z_i) x f
            moment = moment - np.cross(judged[slide][:, None] * axis_of, force)
        for k, a in enumerate("xyz"):
            cols[f"j{joint}_f{a}"], cols[f"j{joint}_m{a}"] = sign * force[:, k], sign * moment[:, k]
    cols["drive_torque"] = cols["j1_mz"]
    cols["output_torque"] = np.stack([cols[f"j4_m{a}"] for a in "xyz"], 1) @ z4
    t = np.einsum("ij,ij->i", z2, np.cross(z3, z4)) / abs(np.sin(g.alpha[1]) * np.sin(g.alpha[2]))
    cols.update(transmission_out=t, residual=judged["residual"],
                dynamics_residual=judged["dynamics_residual"])
    status = _status(judged, np.full_like(t, np.nan), t, case.branch, False)
    cols = {c: np.array(cols[c], dtype=float) for c in rccc.COLUMNS}
    return _settled(case, judged, cols, status, rccc.SPEC, not_given)


def _settled(case: RssrCase | RcccCase, judged: LinkageTable, cols: dict[str, np.ndarray], status: np.ndarray,
             spec: TableSpec, not_given: tuple[str, ...]) -> LinkageTable:
    """The mechanism's table of ``judged``'s columns ``cols`` and words ``status``, settled
    (:func:`~dualmech.core.status.settle`); the ``not_given`` columns are NaN at every row and claimed by no
    word (the simulation's ``dynamics_residual``)."""
    reactions = tuple(c for c in spec.reactions if c not in not_given)
    return LinkageTable(judged.engine, case.name, cols,
                        settle(cols, status, reactions, pose=spec.pose, rates=spec.rates), judged.meta)


def rssr_reach(case: RssrCase, theta1: np.ndarray) -> np.ndarray:
    """The RSSR's reach ratio ``(n,)`` at the crank angles ``theta1`` ``(n,)`` (rad): ``|P3(phi) - P2|^2 = K
    + A cos phi + B sin phi`` on the output pin's circle, ``rho = (a2^2 - K) / sqrt(A^2 + B^2)``; the coupler
    reaches the circle iff ``|rho| <= 1``."""
    g = case.geometry
    p2 = np.stack([g.a1 * np.cos(theta1), g.a1 * np.sin(theta1), np.full_like(theta1, g.s1)], 1)
    centre = g.foot[None] - p2
    x, y = g.ground_rotation()[:, 0], g.ground_rotation()[:, 1]
    k = np.sum(centre**2, axis=1) + g.a3**2
    return (g.a2**2 - k) / (2.0 * g.a3 * np.hypot(centre @ x, centre @ y))


def rccc_reach(case: RcccCase, theta1: np.ndarray) -> np.ndarray:
    """The RCCC's reach ``(n,)`` at the crank angles ``theta1`` ``(n,)`` (rad): ``z3`` on the cones
    ``z3·z2 = cos alpha23`` and ``z3·z4 = cos alpha34`` is ``a z2 + b z4 + c z2 x z4``; ``rho = |a z2 + b
    z4|^2`` (``> 1``: the cones miss)."""
    alpha = case.geometry.alpha
    z2, _, z4 = _rccc_axes(case, theta1, np.zeros_like(theta1))
    c23, c34, g = np.cos(alpha[1]), np.cos(alpha[2]), z2 @ z4
    return (c23**2 + c34**2 - 2.0 * g * c23 * c34) / (1.0 - g**2)


def with_start(mechanism: LoopMechanism, starts: tuple, k: int = 0, stop: int | None = None) -> LoopMechanism:
    """``mechanism`` driven at its positions ``k`` to ``stop`` (exclusive; ``None``: the last), every joint
    started at ``starts`` (one tuple per joint, as :func:`rssr_start` and :func:`rccc_start` give them)."""
    drive = replace(mechanism.drive, positions=mechanism.drive.positions[k:stop])
    return replace(mechanism, drive=drive, joints=tuple(replace(j, start=s) for j, s in
                                                        zip(mechanism.joints, starts)))


def judge_case(case: RssrCase | RcccCase, engine: str, judge: Judge) -> LinkageTable:
    """An RSSR or RCCC ``case`` judged by ``judge`` (a generated judge's table of a loop table), as the
    mechanism's own table of engine ``engine`` (module docstring).

    At a row to start from, each crude start (:data:`MAX_CRUDE_STARTS` at most) is tried on that row alone
    until one answers on the branch; the judge then runs from there to the last row, and its answers are
    taken where no run answered on the branch before.  With none on the branch the row keeps the first
    start's answer and the next row is tried (so a judge that fails everywhere costs a few solves a row).
    ``meta``: ``iterations`` per row (of the run that answered it) and ``restarts``, the rows a run
    started from.
    """
    table, reach, columns_of, spec, _, _ = _kind_of(case)
    mechanism, theta1 = table(case), np.radians(case.motion.angles_deg)
    n = theta1.shape[0]
    cols = {c: np.full(n, np.nan) for c in spec.columns}
    cols["theta1_deg"] = np.degrees(theta1)
    status = np.full(n, Status.NOT_CONVERGED.value, dtype=object)
    reaches = rssr.assembles(reach(case, theta1))
    status[~reaches] = Status.NO_ASSEMBLY.value
    iterations, restarts = np.zeros(n, dtype=int), []

    def take(run: LinkageTable, rows: np.ndarray, k: int) -> None:
        for c in spec.columns:
            cols[c][rows] = run[c][rows - k]
        status[rows] = run.status[rows - k]
        iterations[rows] = np.asarray(run.meta["iterations"])[rows - k]

    for k in range(n):
        if not reaches[k] or is_status(status[k:k + 1], *ACCEPTED)[0]:
            continue
        good, accepted, first = crude_start(case, mechanism, k, judge)
        if not accepted:
            take(first, np.array([k]), k)
            continue
        restarts.append(k)
        take(columns_of(case, judge(with_start(mechanism, good, k))), k + np.flatnonzero(
            ~is_status(status[k:], *ACCEPTED) & reaches[k:]), k)
    return LinkageTable(engine, case.name, cols, status,
                        {"iterations": iterations, "restarts": np.array(restarts, dtype=int)})


def _kind_of(case: RssrCase | RcccCase) -> tuple[Callable, Callable, Callable, TableSpec, Callable, Callable]:
    """The table, reach, column reader, spec, crude start angles and crude start of ``case``'s kind."""
    if isinstance(case, RssrCase):
        return rssr_table, rssr_reach, rssr_columns, rssr.SPEC, rssr_start_angles, rssr_start
    return rccc_table, rccc_reach, rccc_columns, rccc.SPEC, rccc_start_angles, rccc_start


def crude_start(case: RssrCase | RcccCase, mechanism: LoopMechanism, k: int, judge: Judge
                ) -> tuple[tuple, bool, LinkageTable]:
    """The first of the crude starts at row ``k`` (:data:`MAX_CRUDE_STARTS` at most: :func:`rssr_start`,
    :func:`rccc_start`) from which ``judge`` answers that row alone on the case's branch, ``True`` and that
    answer (the mechanism's one-row table); with none on the branch, the first start, ``False`` and its
    answer."""
    _, _, columns_of, _, angles, start = _kind_of(case)
    theta1 = float(np.radians(case.motion.angles_deg[k]))
    first = None
    for theta4 in angles(case, theta1)[:MAX_CRUDE_STARTS]:
        starts = start(case, theta1, theta4)
        probe = columns_of(case, judge(with_start(mechanism, starts, k, k + 1)))
        if is_status(probe.status, *ACCEPTED)[0]:
            return starts, True, probe
        first = (starts, False, probe) if first is None else first
    return first


def simulate_case(case: RssrCase | RcccCase) -> LinkageTable:
    """The ``mujoco-sim`` engine of an RSSR or RCCC case: the generated simulated judge
    (:func:`~dualmech.validation.judges.mujoco_loop.table.solve_sim_table`) on the case's table, every joint
    started at the first crude start from which the rigid generated MuJoCo judge answers the first row on
    the branch (:func:`crude_start`; with none, the first crude start: the simulation's words then say where
    it is), as the mechanism's table (``dynamics_residual`` not given: the simulation has no least squares).
    The simulation plans its runs from its own rigid closure, so one start serves every row (the engine
    runs only on cases whose every row assembles: :func:`~dualmech.validation.engines.solves`).  ``meta``:
    the simulation's (time step, steps per degree, run-in, servo gains, the largest drive lag, ``L_ref``).
    """
    table, _, columns_of, _, _, _ = _kind_of(case)
    mechanism = table(case)
    starts, _, _ = crude_start(case, mechanism, 0, mujoco_table)
    return columns_of(case, solve_sim_table(with_start(mechanism, starts)), ("dynamics_residual",))


def simulate_rssr(case: RssrCase) -> LinkageTable:
    """The ``mujoco-sim`` engine of an RSSR case (:func:`simulate_case`)."""
    return simulate_case(case)


def simulate_rccc(case: RcccCase) -> LinkageTable:
    """The ``mujoco-sim`` engine of an RCCC case (:func:`simulate_case`)."""
    return simulate_case(case)


def solve_pinocchio_rssr(case: RssrCase) -> LinkageTable:
    """The ``pinocchio`` engine of an RSSR case: :func:`judge_case` with the generated Pinocchio judge
    (:func:`~dualmech.validation.judges.pinocchio_loop.table.solve_table`)."""
    return judge_case(case, "pinocchio", pinocchio_table)


def solve_pinocchio_rccc(case: RcccCase) -> LinkageTable:
    """The ``pinocchio`` engine of an RCCC case (as :func:`solve_pinocchio_rssr`)."""
    return judge_case(case, "pinocchio", pinocchio_table)


def solve_mujoco_rssr(case: RssrCase) -> LinkageTable:
    """The ``mujoco`` engine of an RSSR case: :func:`judge_case` with the generated rigid MuJoCo judge
    (:func:`~dualmech.validation.judges.mujoco_loop.table.solve_table`)."""
    return judge_case(case, "mujoco", mujoco_table)


def solve_mujoco_rccc(case: RcccCase) -> LinkageTable:
    """The ``mujoco`` engine of an RCCC case (as :func:`solve_mujoco_rssr`)."""
    return judge_case(case, "mujoco", mujoco_table)
