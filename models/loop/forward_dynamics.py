"""Forward dynamics of a loop table: the drive's equation of motion from the in-house inverse dynamics.

The construction of the RSSR's and RCCC's (:mod:`dualmech.models.linkages.forward_dynamics`) on any
one-degree-of-freedom loop driven by an angle.  With the drive's effort solved and the other loads given,
the in-house engine (:func:`~dualmech.models.loop.engine.analyze_loop`) returns a drive effort affine in the
drive's acceleration and quadratic in its rate:

.. math:: \\tau(\\theta, \\dot\\theta, \\ddot\\theta) = I(\\theta)\\,\\ddot\\theta
          + C(\\theta)\\,\\dot\\theta^2 + Q(\\theta)

where :math:`\\tau` is the drive's *generalized* effort, the power of the driven joint's efforts per unit
drive rate: its torque, plus, for a C joint under the axial law :math:`S(\\theta)`, its axial force times
:math:`dS/d\\theta` (the law is a workless cam, as the slider crank's in
:mod:`dualmech.models.slider_crank.forward_dynamics`).
Three solves per angle (rate 0 and acceleration 0, rate 1, acceleration 1) on a 0.5 deg grid of a turn from
the first assembled drive position (refined where the pose turns sharply) give :math:`I`,
:math:`C = \\tfrac12 I'` and :math:`Q` (gravity and the given loads), and the loads' power per unit drive
rate :math:`P = \\sum_k e_k\\, dq_k/d\\theta` (the ``ratio`` of
:class:`~dualmech.models.linkages.forward_dynamics.Coefficients`, with a unit scale: its work is the loads'
work).  A case whose drive effort is given and one load solved simulates with that load 0
(as the RSSR in drive-torque mode) and the drive effort as its default.  Under a drive effort
:math:`\\tau^A` (number, expression in ``t, psi, psidot`` or function) and a viscous drive bearing :math:`c`,
:math:`\\ddot\\theta = (\\tau^A - c\\dot\\theta - C\\dot\\theta^2 - Q)/I`, integrated by the linkages'
right-hand side and the slider crank's integrator, budget and checks.  Along the result the in-house engine
solves the loop at the simulated states (each with its own rate and acceleration) for the loop table's
columns and the energies (``docs/conventions.md``, "Loop tables", simulate).

A drive that does not turn fully (or a loop that does not come back to its pose after a turn) is tabulated
over the range of its drive positions instead, and a motion leaving that range stops in one line.  Refused
in one line: a drive by a slide (P: its stroke ends where a crank it drives has a dead centre, the slide's
generalized inertia unbounded there), a C drive whose axial law does not repeat every turn, a loop that
neither turns fully nor assembles over its drive positions.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from dualmech.core.loop import LoopState
from dualmech.core.loop_reactions import link_frames
from dualmech.core.reactions import BodyMotion, body_motion, kinetic_energy
from dualmech.core.status import Status
from dualmech.core.table import write_csv
from dualmech.models.expressions import LoadFunction
from dualmech.models.inputs import check_number
from dualmech.models.integration import (
    CRANK_ANGLE,
    CRANK_SPEED,
    MAX_EVALUATIONS,
    TIME_LIMIT,
    Budget,
    Progress,
    checked_settings,
    integrate,
)
from dualmech.models.linkages.forward_dynamics import (
    POINTS,
    Coefficients,
    EquationOfMotion,
    drive_load,
    interpolation_error,
)
from dualmech.models.loop.columns import key_column, loop_table
from dualmech.models.loop.description import LoopMechanism
from dualmech.models.loop.engine import LoopAnalysis, analyze_loop, find_start
from dualmech.models.loop.table import ENGINE, analysis_columns
from dualmech.models.loop.translate import drive_state, to_loop, variable
from dualmech.models.simulation_summary import simulation_summary
from dualmech.models.tables import LinkageTable

#: The coefficient table's aim: :func:`~dualmech.models.linkages.forward_dynamics.interpolation_error` at
#: most this, the grid's step halved until it is (the linkages' tables reach ~1e-13 at 0.5 deg; the 7R's,
#: whose pose swings ~10 deg per degree of drive near 120 deg: 4.4e-3 at 0.5 deg, 4e-11 at 1/16 deg).
INTERPOLATION_TARGET = 1e-11
#: Most halvings of the 0.5 deg step (to 1/32 deg).
REFINEMENTS = 4
#: How far the coefficients after a turn may differ from those at its start, over the largest of each:
#: the same pose gives them to rounding (~1e-13); another assembly differs at order 1.
PERIOD_TOL = 1e-8


def check_simulated(mechanism: LoopMechanism) -> None:
    """A one-line ``ValueError`` if ``mechanism``'s drive cannot be simulated (module docstring)."""
    d = mechanism.drive
    kind = mechanism.joints[d.joint].type
    if d.coordinate != "theta":
        raise ValueError(f"simulate: {mechanism.name!r} is driven at joint[{d.joint + 1}]'s slide ({kind}); "
                         "a loop's forward dynamics integrates a drive angle (a slide's stroke ends where "
                         "the joint it drives has a dead centre, its inertia unbounded there): drive an R or "
                         "C joint")
    if kind == "C" and d.axial_amplitude and d.axial_cycles != round(d.axial_cycles):
        raise ValueError(f"simulate: drive.axial_cycles = {d.axial_cycles!r} does not repeat the C joint's "
                         "axial law every turn; the forward dynamics needs a whole number")


def free_mechanism(mechanism: LoopMechanism) -> LoopMechanism:
    """``mechanism`` with its drive effort solved and every load given (a solved load becomes 0)."""
    loads = tuple(replace(load, value=0.0) if load.value is None else load for load in mechanism.loads)
    return replace(mechanism, drive=replace(mechanism.drive, effort=None), loads=loads)


def start_pose(mechanism: LoopMechanism, start: LoopState | None = None) -> tuple[LoopState, float]:
    """An assembled pose of ``mechanism`` and its drive angle (rad): ``start`` at the drive's first position
    if given, else the pose its analysis starts from (:func:`~dualmech.models.loop.engine.find_start`)."""
    if start is not None:
        return start, float(mechanism.drive.positions[0])
    pose, at = find_start(mechanism, to_loop(mechanism), drive_state(mechanism))
    return pose, float(mechanism.drive.positions[at])


def analyze_states(mechanism: LoopMechanism, start: LoopState, theta: np.ndarray, theta_dot: np.ndarray,
                   theta_ddot: np.ndarray, at: int = 0) -> LoopAnalysis:
    """The in-house analysis of ``mechanism`` at drive states ``(n,)`` each (rad, rad/s, rad/s²), closed by
    continuation from ``start``, a pose at ``theta[at]``."""
    at_states = replace(mechanism, drive=replace(mechanism.drive, positions=theta))
    return analyze_loop(at_states, start, at, drive=drive_state(at_states, theta, theta_dot, theta_ddot))


def analyze_samples(mechanism: LoopMechanism, start: LoopState, grid: np.ndarray, at: int, theta: np.ndarray,
                    theta_dot: np.ndarray, theta_ddot: np.ndarray) -> tuple[LoopAnalysis, np.ndarray]:
    """:func:`analyze_states` at drive states ``(n,)`` each in any order, merged with the drive angles
    ``grid`` (at rest; ``start`` a pose at ``grid[at]``) and sorted, so that consecutive angles stay close
    whatever the states: the analysis and each state's row in it ``(n,)``."""
    angles = np.concatenate([grid, theta])
    order = np.argsort(angles, kind="stable")
    inverse = np.argsort(order)
    pad = np.zeros(grid.shape[0])
    an = analyze_states(mechanism, start, angles[order], np.concatenate([pad, theta_dot])[order],
                        np.concatenate([pad, theta_ddot])[order], int(inverse[at]))
    return an, inverse[grid.shape[0]:]


def drive_effort(an: LoopAnalysis, unit: dict[str, np.ndarray]) -> np.ndarray:
    """The generalized drive effort ``(n,)`` of ``an``: each prescribed coordinate's solved effort times its
    rate per unit drive rate ``unit`` (by variable name)."""
    return sum(an.wrenches.efforts[variable(*p)] * unit[variable(*p)] for p in an.mechanism.prescribed)


def load_power(an: LoopAnalysis) -> np.ndarray:
    """The given loads' power ``(n,)`` in ``an`` (at a unit drive rate: per unit drive rate)."""
    n = an.status.shape[0]
    return sum((load.value * an.coordinate(load.joint, load.coordinate)[1] for load in an.mechanism.loads),
               np.zeros(n))


def range_grid(theta0: float, low: float, high: float, points: int = POINTS) -> tuple[np.ndarray, int]:
    """Drive angles ``(m,)`` from ``low`` to ``high`` (rad) through ``theta0``, at most a turn's
    ``points``-grid step apart and an odd count (:func:`~dualmech.models.linkages.forward_dynamics.
    interpolation_error` skips every other one), and the index of ``theta0``."""
    step = 2 * np.pi / (points - 1)
    down, up = math.ceil((theta0 - low) / step - 1e-9), math.ceil((high - theta0) / step - 1e-9)
    if (down + up) % 2:
        up, down = (up + 1, down) if up >= down else (up, down + 1)
    below = np.linspace(low, theta0, down + 1)[:-1]
    return np.concatenate([below, np.linspace(theta0, high, up + 1)]), below.size


def _table(free: LoopMechanism, pose: LoopState, theta: np.ndarray, at: int,
           periodic: bool) -> tuple[Coefficients | None, list[str]]:
    """The coefficients of ``free`` (drive effort solved) at the angles ``theta`` ``(m,)`` from ``pose`` at
    ``theta[at]``, or ``None`` and the statuses that are not ``ok`` (``["another assembly"]``: a periodic
    table whose ends differ)."""
    m = theta.shape[0]
    zero, one = np.zeros(m), np.ones(m)
    unit = drive_state(free, theta, one, zero).rates
    with np.errstate(all="ignore"):  # rows that do not assemble are reported
        runs = [analyze_states(free, pose, theta, rate, accel, at)
                for rate, accel in ((zero, zero), (one, zero), (zero, one))]
    bad = sorted({str(s) for an in runs for s in an.status} - {Status.OK.value})
    if bad:
        return None, bad
    tau = np.stack([drive_effort(an, unit) for an in runs])
    c = Coefficients(theta, tau[2] - tau[0], tau[1] - tau[0], tau[0], load_power(runs[1]), periodic)
    if not periodic:
        return c, []
    data = c.stacked()
    scale = np.maximum(np.abs(data).max(axis=0), np.finfo(float).tiny)
    if (np.abs(data[-1] - data[0]) > PERIOD_TOL * scale).any():
        return None, ["another assembly"]
    for array in (c.inertia, c.velocity, c.load, c.ratio):
        array[-1] = array[0]  # 2 pi is 0: the same pose, equal to rounding
    return c, []


def coefficients(mechanism: LoopMechanism, points: int = POINTS,
                 start: LoopState | None = None) -> Coefficients:
    """:class:`~dualmech.models.linkages.forward_dynamics.Coefficients` of ``mechanism``, ``ratio`` the
    loads' power per unit rate: at ``points`` drive angles over a turn from its start pose (:func:`start_pose`
    of ``start``) if the drive turns fully and the loop comes back to its pose; else on the same step over
    the range of the drive's positions (not periodic: the motion must stay in it, :class:`RangeEquation`);
    the step halved (at most :data:`REFINEMENTS` times) until the table's interpolation error is at most
    :data:`INTERPOLATION_TARGET`.

    Raises ``ValueError`` (one line) for a drive :func:`check_simulated` refuses, or a loop that neither
    turns fully nor assembles over its drive's positions on the start pose's branch."""
    check_simulated(mechanism)
    free = free_mechanism(mechanism)
    pose, theta0 = start_pose(free, start)
    positions = mechanism.drive.positions
    low, high = float(positions.min()), float(positions.max())

    def turn(m: int) -> tuple[Coefficients | None, list[str]]:
        return _table(free, pose, theta0 + np.linspace(0.0, 2 * np.pi, m), 0, True)

    def drive_range(m: int) -> tuple[Coefficients | None, list[str]]:
        return (None, ["a single position"]) if low == high else \
            _table(free, pose, *range_grid(theta0, low, high, m), False)

    build = turn
    c, bad = turn(points)
    if c is None:
        build = drive_range
        c, bad_range = drive_range(points)
        if c is None:
            raise ValueError(f"simulate: {mechanism.name!r} neither turns fully (statuses {bad} on the turn "
                             f"from {math.degrees(theta0):g} deg) nor assembles over its drive positions "
                             f"{math.degrees(low):g}..{math.degrees(high):g} deg ({bad_range}); the forward "
                             "dynamics of a loop needs one of them")
    for _ in range(REFINEMENTS):  # a pose that turns sharply along the drive needs a finer grid
        if interpolation_error(c) <= INTERPOLATION_TARGET:
            break
        points = 2 * points - 1
        finer, _ = build(points)
        if finer is None:
            break
        c = finer
    return c


@dataclass(frozen=True)
class RangeEquation(EquationOfMotion):
    """The equation of motion on a table over a range of the drive, not a turn: the drive leaving the
    table's angles is a one-line ``ValueError`` (past them the loop does not assemble on its branch, or the
    case does not say it does)."""

    def model(self, theta: float | np.ndarray) -> np.ndarray:
        theta = np.atleast_1d(theta)
        low, high = float(self.spline.t[0]), float(self.spline.t[-1])
        outside = theta[(theta < low) | (theta > high)]
        if outside.size:
            raise ValueError(f"simulate: the drive reached {math.degrees(outside[0]):.6g} deg, outside "
                             f"{math.degrees(low):g}..{math.degrees(high):g} deg, the drive positions the "
                             "loop is tabulated over (it does not turn fully); shorten --duration or change "
                             "the loads")
        return self.spline(theta).T


def simulate(mechanism: LoopMechanism, duration: float, torque: float | str | LoadFunction | None = None,
             psi0: float | None = None, psidot0: float | None = None, damping: float = 0.0,
             samples: int = 1001, method: str = "DOP853", rtol: float = 1e-12, atol: float = 1e-12,
             coeffs: Coefficients | None = None, max_evaluations: int = MAX_EVALUATIONS,
             time_limit: float = TIME_LIMIT, progress: Progress | None = None,
             start: LoopState | None = None) -> "LoopSimulation":
    """Integrate the drive's equation of motion of a loop table from ``t = 0`` to ``duration`` s.

    ``torque``: the drive effort about the driven joint's axis on its link (default: the case's
    ``drive.effort``, else 0; :func:`~dualmech.models.linkages.forward_dynamics.drive_load`); the loads
    are the case's given ones.  ``psi0`` (rad), ``psidot0`` (rad/s): the start, default the drive's first
    position and speed; ``damping``: the drive bearing's viscous coefficient; the other options as for
    :func:`dualmech.models.linkages.forward_dynamics.simulate`, ``coeffs`` a table built before; ``start`` a
    pose at the drive's first position whose branch is followed (default :func:`start_pose`'s).

    Raises
    ------
    ValueError
        One line: an input out of range, a drive that cannot be simulated (:func:`coefficients`), a load
        that is not a finite real number, the budget used up, or a motion that runs away.
    """
    duration, damping, _, rtol, atol, _ = checked_settings(duration, damping, 0.0, rtol, atol, 1e-12,
                                                             samples, method)
    budget = Budget(max_evaluations, time_limit)
    check_simulated(mechanism)
    d = mechanism.drive
    tau = drive_load(torque, 0.0 if d.effort is None else d.effort)
    psi0 = float(d.positions[0]) if psi0 is None else check_number("psi0", psi0, CRANK_ANGLE)
    psidot0 = d.speed if psidot0 is None else check_number("psidot0", psidot0, CRANK_SPEED)
    c = coefficients(mechanism, start=start) if coeffs is None else coeffs
    rhs = (EquationOfMotion if c.periodic else RangeEquation)(c.spline(), tau, 1.0, damping)
    sol = integrate(rhs, budget, np.array([psi0, psidot0, 0.0, 0.0, 0.0]),
                    np.linspace(0.0, duration, int(samples)), method, rtol, atol, progress)
    info = {"method": method, "rtol": rtol, "atol": atol, "nfev": int(sol.nfev), "coefficients": "table",
            "table_size": c.theta.shape[0], "interpolation_error": interpolation_error(c),
            "message": sol.message}
    info["drive_range"] = None if c.periodic else (float(c.theta[0]), float(c.theta[-1]))
    return trajectory(mechanism, rhs, sol.t, sol.y, info, start)


@dataclass(frozen=True)
class LoopSimulation:
    """A simulated motion of a loop table at ``n`` output times; arrays ``(n,)``.

    ``t`` s; ``psi``, ``psi_dot``, ``psi_ddot`` the drive angle (rad) and its rates; ``effort`` the applied
    drive effort :math:`\\tau^A`; ``kinetic``, ``potential`` (:math:`V = -\\sum m_b g\\cdot c_b`) from the
    in-house motion; ``work_drive``, ``work_loads``, ``dissipated`` integrated with the ODE; ``table`` the
    loop table's columns along the motion (the in-house solve at the simulated states with the drive effort
    solved: its generalized drive effort is ``effort - damping * psi_dot``); ``info`` integrator facts.
    """

    case: LoopMechanism
    t: np.ndarray
    psi: np.ndarray
    psi_dot: np.ndarray
    psi_ddot: np.ndarray
    effort: np.ndarray
    kinetic: np.ndarray
    potential: np.ndarray
    work_drive: np.ndarray
    work_loads: np.ndarray
    dissipated: np.ndarray
    table: LinkageTable
    info: dict

    def energy_residual(self) -> np.ndarray:
        """Work-energy balance :math:`\\Delta(T + V) - (W^A + W^L - D)`, ``(n,)`` (zero when exact)."""
        e = self.kinetic + self.potential
        return (e - e[0]) - (self.work_drive + self.work_loads - self.dissipated)

    def columns(self) -> dict[str, np.ndarray]:
        """Output columns in CSV order: ``t``, the table's key (the drive angle, degrees), then
        :data:`SIMULATION_COLUMNS`, then the table's other columns (``docs/conventions.md``, "Loop
        tables", simulate)."""
        key = key_column(self.case)
        cols = {"t": self.t, key: self.table.columns[key], "psi": self.psi, "psi_dot": self.psi_dot,
                "psi_ddot": self.psi_ddot, "effort_applied": self.effort, "kinetic_energy": self.kinetic,
                "potential_energy": self.potential, "work_drive": self.work_drive,
                "work_loads": self.work_loads, "dissipated": self.dissipated}
        return cols | {k: v for k, v in self.table.columns.items() if k != key}

    def to_csv(self, path: str | Path | None = None) -> str:
        """CSV text of :meth:`columns` plus ``status`` (:func:`~dualmech.core.table.write_csv`)."""
        return write_csv(self.columns(), self.table.status, path)


#: The columns of :meth:`LoopSimulation.columns` after ``t`` and the key (then the table's, then ``status``).
SIMULATION_COLUMNS: tuple[str, ...] = (
    "psi", "psi_dot", "psi_ddot", "effort_applied", "kinetic_energy", "potential_energy", "work_drive",
    "work_loads", "dissipated",
)


def energies(an: LoopAnalysis) -> tuple[np.ndarray, np.ndarray]:
    """Kinetic :math:`\\sum \\tfrac12 m v_G^2 + \\tfrac12\\omega\\cdot I_G\\omega` and potential
    :math:`-\\sum m g\\cdot G` energy of the moving links of ``an``, each ``(n,)``."""
    mech = an.mechanism
    motions = link_motions(an)
    kinetic = sum(kinetic_energy(b, m) for b, m in zip(mech.bodies, motions))
    potential = -sum(b.mass * m.com @ mech.gravity for b, m in zip(mech.bodies, motions))
    return kinetic, potential


def link_motions(an: LoopAnalysis) -> list[BodyMotion]:
    """The motion of each moving link's body of ``an`` in its link frame
    (:func:`~dualmech.core.loop_reactions.link_frames`), ``(n,)`` positions each."""
    frames = link_frames(an.chain, an.loop, an.drive.values)
    return [body_motion(body, *frames[r], an.rates.link_twist[r], an.rates.link_accel[r])
            for r, body in enumerate(an.mechanism.bodies)]


def trajectory(mechanism: LoopMechanism, rhs: EquationOfMotion, t: np.ndarray, y: np.ndarray, info: dict,
               start: LoopState | None = None) -> LoopSimulation:
    """The in-house solve and energies along an integrated motion ``y`` ``(5, n)``.

    The states are closed by continuation along their drive angles (taken into the turn of the start pose,
    or in the tabulated range, ``info["drive_range"]``) and sorted, merged with the 0.5 deg grid of that
    turn or range (so that consecutive angles stay close whatever the samples), then put back in time
    order; the table's drive coordinate is the unwrapped angle.  ``start``: as for :func:`simulate`."""
    psi, w = y[0], y[1]
    acc = np.array([rhs(ti, yi)[1] for ti, yi in zip(t, y.T)])
    effort = np.array([rhs.torque(ti, p, v, math.nan, math.nan) for ti, p, v in zip(t, psi, w)])
    free = free_mechanism(mechanism)
    pose, theta0 = start_pose(free, start)
    if info.get("drive_range") is None:  # a turn's grid and the angles taken into it
        grid, at = theta0 + np.linspace(0.0, 2 * np.pi, POINTS)[:-1], 0
        angles = theta0 + np.mod(psi - theta0, 2 * np.pi)
    else:
        grid, at = range_grid(theta0, *info["drive_range"])
        angles = psi
    an, rows = analyze_samples(free, pose, grid, at, angles, w, acc)
    kinetic, potential = (e[rows] for e in energies(an))
    cols = {k: v[rows] for k, v in analysis_columns(an).items()}
    cols[variable(*free.driven_coordinate)] = psi
    at_samples = replace(free, drive=replace(free.drive, positions=psi))
    table = loop_table(ENGINE, at_samples, cols, an.status[rows], {"iterations": an.iterations[rows]})
    return LoopSimulation(mechanism, t, psi, w, acc, effort, kinetic, potential, y[2], y[3], y[4], table,
                          info)


def loop_summary(sim: LoopSimulation) -> str:
    """What ``dualmech simulate`` prints about ``sim``
    (:func:`~dualmech.models.simulation_summary.simulation_summary`): the work of its given loads in place
    of the
    slider crank's slider."""
    middle = f"given loads: work {sim.work_loads[-1]:.6g}; dissipated {sim.dissipated[-1]:.6g}"
    return simulation_summary(sim, middle, (sim.work_drive, sim.work_loads), "drive")
