"""The forward dynamics of the RSSR and the RCCC on the loop engine: their analysis at given input states.

:mod:`dualmech.models.linkages.forward_dynamics` integrates a linkage's input from the drive torque its
in-house inverse dynamics needs at given input states (the coefficient table of a turn, then the table
along the motion); :func:`at_states` is that analysis here: the case's preset joint table
(:func:`~dualmech.models.loop.presets.rssr_table`, :func:`~dualmech.models.loop.presets.rccc_table`) solved
by the in-house loop engine at the states (:func:`~dualmech.models.loop.forward_dynamics.analyze_samples`:
taken into the turn from the case's first crank angle, merged with that turn's 0.5 deg grid and sorted, so
that the continuation's steps stay small whatever the states), started from the mechanism's own estimate
there as :mod:`dualmech.models.loop.preset_engine` starts its runs, read back as the mechanism's table
(:mod:`dualmech.models.linkages.readback`).  The links' motions are turned from the table's link frames
into the mechanism's body frames (``docs/conventions.md``, "RSSR", "RCCC"): the RSSR's output crank frame
is its ball-3 link frame turned by pi about z and moved by ``a3`` along its x
(:data:`~dualmech.models.loop.presets.FLIP`), its coupler's frame completed about the coupler's axis as its
own estimate completes it; the RCCC's link frames are its body frames.
The input must turn fully: states where the geometry does not reach are a one-line ``ValueError``.
"""

from __future__ import annotations

from dataclasses import fields, replace
from typing import Any, Callable

import numpy as np

from dualmech.core.motion import CrankState
from dualmech.core.reactions import BodyMotion
from dualmech.core.status import Status
from dualmech.models.linkages import forward_dynamics, rssr
from dualmech.models.linkages.forward_dynamics import POINTS, LinkageSimulation, StatesAnalysis
from dualmech.models.linkages.rccc_case import RcccCase
from dualmech.models.linkages.rssr_case import RssrCase
from dualmech.models.loop.forward_dynamics import analyze_samples, link_motions
from dualmech.models.loop.preset_engine import RCCC, RSSR, Preset, answer
from dualmech.models.loop.presets import FLIP
from dualmech.models.tables import LinkageTable


def _rssr_frames(case: RssrCase, motions: list[BodyMotion]) -> list[BodyMotion]:
    """The coupler's motion in the completion of its frame the RSSR's own estimate uses
    (:func:`~dualmech.models.linkages.rssr.frame_x` of its axis ``u``: the engine leaves the gauged spin
    about ``u`` as its continuation carried it, and the coupler is axisymmetric about ``u``, so only its
    ``rotation`` changes), and the output crank's moved from its ball-3 link frame (origin ``P3``, x toward
    ``Q4``) to its body frame (origin ``Q4``, x toward ``P3``): ``R_body = R_link FLIP``,
    ``O_body = O_link + a3 x_link``."""
    coupler, out = motions[1:]
    coupler = replace(coupler, rotation=rssr.frame_x(coupler.rotation[:, :, 0]))
    moved = replace(out, rotation=out.rotation @ FLIP,
                    origin=out.origin + case.geometry.a3 * out.rotation[:, :, 0])
    return [motions[0], coupler, moved]


#: Each kind's preset (:mod:`dualmech.models.loop.preset_engine`) and its links' motions moved from the
#: table's link frames to the mechanism's body frames.
PRESETS: dict[type, tuple[Preset, Callable[[Any, list[BodyMotion]], list[BodyMotion]]]] = {
    RssrCase: (RSSR, _rssr_frames),
    RcccCase: (RCCC, lambda case, motions: motions),
}


def _preset(case: Any) -> tuple[Preset, Callable[[Any, list[BodyMotion]], list[BodyMotion]]]:
    """The :data:`PRESETS` entry of ``case``; a one-line ``ValueError`` for anything else."""
    if type(case) not in PRESETS:
        raise ValueError(f"forward dynamics: a {type(case).__name__} is not simulated here (an RSSR or RCCC "
                         "case is; a loop table by dualmech.models.loop.forward_dynamics)")
    return PRESETS[type(case)]


def _rows(motion: BodyMotion, rows: np.ndarray) -> BodyMotion:
    """``motion`` at its positions ``rows``."""
    return BodyMotion(*(getattr(motion, f.name)[rows] for f in fields(motion)))


def at_states(case: RssrCase | RcccCase, crank: CrankState) -> StatesAnalysis:
    """The in-house analysis of ``case`` at the input states ``crank`` ``(n,)`` (its ``theta``, ``theta_dot``,
    ``theta_ddot``; module docstring): the mechanism's table (``theta1_deg`` the given angles; ``meta``:
    ``iterations``, ``messages``, ``branch`` as :func:`~dualmech.models.loop.preset_engine.solve_preset`
    gives them), the output link's rate (minus joint 4's angle rate: ``phi4_dot``, ``-theta4_dot``) and the
    links' motions in the mechanism's body frames.

    Raises ``ValueError`` (one line) for a case of another kind, or states where the geometry does not reach.
    """
    preset, body_frames = _preset(case)
    theta0 = float(np.radians(case.motion.angles_deg[0]))
    grid = theta0 + np.linspace(0.0, 2 * np.pi, POINTS)[:-1]
    theta = theta0 + np.mod(crank.theta - theta0, 2 * np.pi)
    angles = np.sort(np.concatenate([grid, theta]))
    reaches = rssr.assembles(preset.reach(case, angles))
    if not reaches.all():
        words = np.where(reaches, Status.OK.value, Status.NO_ASSEMBLY.value)
        gaps = rssr.no_assembly_messages(np.degrees(angles), words, preset.why)[0]
        raise ValueError(f"simulate: {case.name!r} does not turn fully ({gaps}); the forward dynamics of a "
                         "linkage needs an input that does")
    an, rows = analyze_samples(preset.table(case), preset.start(case, 0), grid, 0, theta, crank.theta_dot,
                               crank.theta_ddot)
    loop = answer(an, preset.length(case))
    cols = {c: v[rows] for c, v in loop.columns.items()} | {"theta1_deg": np.degrees(crank.theta)}
    at = preset.readback(case, LinkageTable(loop.engine, loop.case, cols, loop.status[rows],
                                            {"iterations": loop.meta["iterations"][rows]}))
    messages = rssr.no_assembly_messages(at["theta1_deg"], at.status, preset.why)
    table = LinkageTable(at.engine, case.name, at.columns, at.status,
                         {"iterations": at.meta["iterations"], "messages": messages, "branch": case.branch})
    motions = tuple(_rows(m, rows) for m in body_frames(case, link_motions(an)))
    return StatesAnalysis(table, -an.coordinate(3, "theta")[1][rows], motions)


def simulate(case: RssrCase | RcccCase, duration: float, **options: Any) -> LinkageSimulation:
    """The forward dynamics of an RSSR or RCCC case by :func:`at_states`
    (:func:`dualmech.models.linkages.forward_dynamics.simulate`, whose options ``options`` are).

    Raises
    ------
    ValueError
        One line: a case of another kind, or as :func:`dualmech.models.linkages.forward_dynamics.simulate`.
    """
    _preset(case)  # a kind without forward dynamics: one line, before any of its keys is read
    return forward_dynamics.simulate(case, at_states, duration, **options)
