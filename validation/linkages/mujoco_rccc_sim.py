"""The RCCC simulated by MuJoCo (the simulated judge, engine ``"mujoco-sim"``): the input driven by a servo
along the case's motion, the loop held by the soft weld at joint 1, the output torque applied at joint 4,
MuJoCo's own constraint solver and ``implicitfast`` integrator (the MJCF:
:mod:`~dualmech.validation.linkages.mjcf_rccc`).

As the RSSR's simulation (:mod:`~dualmech.validation.linkages.mujoco_rssr_sim`, whose time step, servo
bandwidth, run plan and implicit acceleration it uses): the simulation starts from the rigid MuJoCo judge's
own answer at the case's first input state (its own start and Newton, :func:`rigid_start`) and runs over
the case's range of input angles; every ``every`` steps it records the input's actual state, the output
cylinder's angle and slide with their rates, and the weld's wrench on the input link (joint 1).  The
in-house engine is asked about the *recorded* input states, so the servo's lag does not enter the
comparison: what is compared is the soft loop against the rigid one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable

import mujoco
import numpy as np

from dualmech.core.status import Status, settle
from dualmech.models.linkages.rccc import SPEC
from dualmech.models.linkages.rccc_case import RcccCase
from dualmech.models.linkages.rssr import status_words
from dualmech.models.linkages.table import LinkageTable
from dualmech.validation.linkages import mujoco_rccc as rigid
from dualmech.validation.linkages.judges import pose_error, rccc_judge_table, rccc_transmission
from dualmech.validation.linkages.mjcf_rccc import rccc_sim_mjcf, rotor_inertia
from dualmech.validation.linkages.mujoco_rssr_sim import (
    SERVO_BANDWIDTH,
    SIM_TIMESTEP,
    _implicit_acceleration,
    crank_states,
    sim_plan,
)

#: Columns the simulated judge gives (the weld's wrench is the only reaction MuJoCo's soft loop reports as
#: such: joint 1's, the drive torque its moment about z1); the other columns of its table are NaN.
SIM_COLUMNS: tuple[str, ...] = ("theta4_deg", "s4", "theta4_dot", "s4_dot", "theta4_ddot", "s4_ddot",
                                "transmission_out", "j1_fx", "j1_fy", "j1_fz", "j1_mx", "j1_my", "j1_mz",
                                "drive_torque")
#: The RSSR's servo start transient (s) before the first sample.
RUNIN = 0.01


@dataclass(frozen=True)
class MjRcccSim:
    """Compiled model and data of :func:`~dualmech.validation.linkages.mjcf_rccc.rccc_sim_mjcf`; ids of the
    sites ``input`` (on the input link) and ``drive`` (on the rotor) and of the bodies ``axes`` (input
    link, coupler, output link: their z are ``z2, z3, z4``)."""

    model: mujoco.MjModel
    data: mujoco.MjData
    input: int
    drive: int
    axes: tuple[int, int, int]


def servo_gains(case: RcccCase, timestep: float) -> tuple[float, float]:
    """``kp = I_r (SERVO_BANDWIDTH / dt)^2`` (``I_r`` the rotor's inertia, :func:`rotor_inertia`) and ``kv = 2
    sqrt(kp I_high)`` with ``I_high`` = twice the rotor's and the input link's inertia with the coupler's and
    the output link's masses at the loop's size from ``z1``: critically damped or more for any effective
    inertia up to it (the bundled case's generalized inertia is at most 0.13 of its 0.72)."""
    i_rotor = rotor_inertia(case)
    i_high = 2.0 * (2.0 * i_rotor + (case.bodies[1].mass + case.bodies[2].mass) * case.geometry.size**2)
    kp = i_rotor * (SERVO_BANDWIDTH / timestep) ** 2
    return kp, 2.0 * math.sqrt(kp * i_high)


def build(case: RcccCase, timestep: float, servo: tuple[float, float]) -> MjRcccSim:
    """Compile the simulation's MJCF of ``case``."""
    model = mujoco.MjModel.from_xml_string(rccc_sim_mjcf(case, timestep, servo))
    axes = tuple(model.body(name).id for name in ("input_link", "coupler", "output_link"))
    return MjRcccSim(model, mujoco.MjData(model), model.site("input").id, model.site("drive").id, axes)


def rigid_start(case: RcccCase) -> tuple[np.ndarray, np.ndarray]:
    """``qpos``, ``qvel`` ``(6,)`` of the rigid MuJoCo judge's tree at its own answer at the case's first
    input state (its own start and Newton: :func:`~dualmech.validation.linkages.judges.rccc_judge_table`
    on that one position).  Raises ``ValueError`` where the judge does not accept its answer."""
    mr = rigid.build(case)
    first = replace(case, motion=replace(case.motion, angles_deg=case.motion.angles_deg[:1]))
    states: list[tuple[np.ndarray, np.ndarray]] = []

    def position(theta1: float, w: float, wd: float, start: np.ndarray) -> rigid.JudgeAnswer:
        answer = rigid._position(mr, case, theta1, w, wd, start)
        states.append((mr.data.qpos.copy(), mr.data.qvel.copy()))
        return answer

    table = rccc_judge_table(first, "mujoco", lambda q: rigid._axes(mr, q), lambda th: rigid._wanted(mr, th),
                             position)
    if table.status[0] not in (Status.OK.value, Status.DEAD_CENTRE.value):
        raise ValueError("simulate_rccc: the rigid judge does not assemble the case at its first input "
                         f"angle {case.motion.angles_deg[0]:g} deg ({table.status[0]})")
    return states[-1]


def servo_run(sim: MjRcccSim, case: RcccCase, gains: tuple[float, float], timestep: float, duration: float,
              every: int, sample: Callable[[], dict[str, object]]) -> dict[str, np.ndarray]:
    """Step ``sim`` for ``duration`` s with the servo's reference on the case's motion ``theta_0 + w t + a t^2
    / 2`` (its rate's share ``kv / kp`` added: no lag at constant speed), calling ``sample()`` every
    ``every`` steps after :data:`RUNIN`; returns each key of the samples stacked, ``(m, ...)``."""
    m, d = sim.model, sim.data
    kp, kv = gains
    theta0 = math.radians(float(case.motion.angles_deg[0]))
    w0, acc = case.motion.speed, case.motion.accel
    out: dict[str, list] = {}
    for step in range(int(round(duration / timestep)) + 1):
        t = d.time
        d.ctrl[0] = theta0 + w0 * t + 0.5 * acc * t**2 + kv / kp * (w0 + acc * t)
        if step % every == 0 and t >= RUNIN:
            for key, value in sample().items():
                out.setdefault(key, []).append(value)
        mujoco.mj_step(m, d)
    return {k: np.array(v) for k, v in out.items()}


def simulate_rccc(case: RcccCase, timestep: float, duration: float, every: int) -> dict[str, np.ndarray]:
    """Simulate ``case`` for ``duration`` s at ``timestep``, a sample every ``every`` steps after
    :data:`RUNIN`.

    Returns ``time`` (s), ``theta1``, ``theta1_dot``, ``theta1_ddot`` (rad, rad/s, rad/s^2; the acceleration
    the implicit step integrates), ``q``, ``q_dot``, ``q_ddot`` ``(m, 2)`` (``theta4``, ``s4`` and their
    rates, the table's signs), ``t`` (the transmission of the simulated axes), ``j1`` ``(m, 6)`` (the weld's
    force on the input link and its moment about O, world axes), ``gap`` (the weld's pose gap over the
    loop's size) and ``fit`` (the wrench's relative least-squares residual), each over the ``m`` samples.
    """
    gains = servo_gains(case, timestep)
    sim = build(case, timestep, gains)
    d = sim.data
    qpos, qvel = rigid_start(case)
    d.qpos[0], d.qvel[0] = math.radians(float(case.motion.angles_deg[0])), case.motion.speed
    d.qpos[1:], d.qvel[1:] = qpos, qvel
    d.qfrc_applied[:] = 0.0
    d.qfrc_applied[1] = case.output_torque  # the ground's moment on the output link about +z4 (joint 4)
    return servo_run(sim, case, gains, timestep, duration, every,
                     lambda: _sample(sim, case, timestep, gains[1]))


def weld_wrench(sim: MjRcccSim) -> tuple[np.ndarray, np.ndarray, float]:
    """The weld's force on the input link and its moment about O ``(3,)`` each (world), from the constraint's
    generalized force ``qfrc_constraint = G^T w`` with ``G`` the site ``input``'s Jacobian minus the site
    ``drive``'s (linear rows first; exact for a weld, whose rows are ``G`` up to a 3x3 map of the rotational
    ones), and the fit's relative residual."""
    m, d = sim.model, sim.data
    jac = np.zeros((6, m.nv))
    for site, sign in ((sim.input, 1.0), (sim.drive, -1.0)):
        jp, jr = np.empty((3, m.nv)), np.empty((3, m.nv))
        mujoco.mj_jacSite(m, d, jp, jr, site)
        jac += sign * np.vstack([jp, jr])
    w, *_ = np.linalg.lstsq(jac.T, d.qfrc_constraint, rcond=None)
    fit = float(np.linalg.norm(jac.T @ w - d.qfrc_constraint) / max(np.linalg.norm(d.qfrc_constraint),
                                                                        np.finfo(float).tiny))
    return w[:3], w[3:] + np.cross(d.site_xpos[sim.input], w[:3]), fit


def _sample(sim: MjRcccSim, case: RcccCase, timestep: float, kv: float) -> dict[str, object]:
    """One row of :func:`simulate_rccc` at the current state (after ``mj_forward``)."""
    m, d = sim.model, sim.data
    mujoco.mj_forward(m, d)
    accel = _implicit_acceleration(m, d, timestep, kv)
    force, moment, fit = weld_wrench(sim)
    z2, z3, z4 = (d.xmat[b].reshape(3, 3)[:, 2].copy() for b in sim.axes)
    size, site = case.geometry.size, sim.input
    err = pose_error(d.site_xmat[site].reshape(3, 3), d.site_xpos[site], d.qpos[0], case.geometry.s1)
    return {"time": d.time, "theta1": d.qpos[0], "theta1_dot": d.qvel[0], "theta1_ddot": accel[0],
            "q": -d.qpos[1:3].copy(), "q_dot": -d.qvel[1:3].copy(), "q_ddot": -accel[1:3],
            "t": rccc_transmission(z2, z3, z4, case), "j1": np.concatenate([force, moment]),
            "gap": max(np.linalg.norm(err[:3]), size * np.linalg.norm(err[3:])) / size, "fit": fit}


def solve_mujoco_sim_rccc(case: RcccCase) -> LinkageTable:
    """The simulated judge's table of an RCCC case (engine ``"mujoco-sim"``): one row per sample of
    :func:`simulate_rccc` over :func:`~dualmech.validation.linkages.mujoco_rssr_sim.sim_plan`, at the
    *simulated* input states (``theta1_deg``; the rates are in ``meta["crank"]``), the columns
    :data:`SIM_COLUMNS` (``meta["gives"]``), ``residual`` the weld's gap, ``dynamics_residual`` the wrench's
    fit; the status words every linkage engine sets from its own transmission (here the simulated axes'),
    the table settled by them (``not_finite`` where a given value is not)."""
    duration, every = sim_plan(case)
    sim = simulate_rccc(case, SIM_TIMESTEP, duration, every)
    cols = {c: np.full(sim["theta1"].shape[0], np.nan) for c in SPEC.columns}
    theta4 = np.mod(sim["q"][:, 0] + np.pi, 2 * np.pi) - np.pi  # in [-pi, pi), as every engine gives it
    cols.update(theta1_deg=np.degrees(sim["theta1"]), theta4_deg=np.degrees(theta4), s4=sim["q"][:, 1],
                theta4_dot=sim["q_dot"][:, 0], s4_dot=sim["q_dot"][:, 1], theta4_ddot=sim["q_ddot"][:, 0],
                s4_ddot=sim["q_ddot"][:, 1], transmission_out=sim["t"], residual=sim["gap"],
                drive_torque=sim["j1"][:, 5], dynamics_residual=sim["fit"])
    for i, name in enumerate(("j1_fx", "j1_fy", "j1_fz", "j1_mx", "j1_my", "j1_mz")):
        cols[name] = sim["j1"][:, i]
    n = cols["theta1_deg"].shape[0]
    status = status_words(np.ones(n, dtype=bool), np.ones(n), sim["t"], case.branch, False, sim["gap"])
    given = tuple(c for c in SPEC.reactions if c in SIM_COLUMNS or c == "dynamics_residual")
    status = settle(cols, status, given, pose=SPEC.pose, rates=SPEC.rates)
    note = (f"simulated {duration:.3g} s at dt = {SIM_TIMESTEP:g} s, a row every {every} steps, at the "
            "simulated input states")
    return LinkageTable("mujoco-sim", case.name, cols, status,
                        {"crank": crank_states(sim), "gives": SIM_COLUMNS, "messages": [note]})
