"""A loop table's answer on an RSSR or RCCC case read back as the mechanism's own table.

Every engine of the RSSR and the RCCC solves the case's preset joint table
(:func:`~dualmech.models.loop.presets.rssr_table`, :func:`~dualmech.models.loop.presets.rccc_table`): the
in-house loop engine (:mod:`dualmech.models.loop.preset_engine`) and the generated judges
(:mod:`dualmech.validation.judges.presets`).  The engine's coordinates, rates, efforts and joint wrenches
are moved to the columns, reference points and signs of ``docs/conventions.md`` ("RSSR", "RCCC"), the
transmissions computed from its own pose, and the status words given by the mechanism's rules
(:func:`~dualmech.models.linkages.rssr.status_words` on the engine's closure, transmissions and residual).
A column the engine does not give (``not_given``: the simulation's ``dynamics_residual``; every rate and
reaction of a closure alone, a crude start's probe) is NaN at every row and claimed by no word.
"""

from __future__ import annotations

import numpy as np

from dualmech.core.status import Status, is_status, settle
from dualmech.models.linkages import rccc, rssr
from dualmech.models.linkages.rccc_case import RcccCase
from dualmech.models.linkages.rssr_case import RssrCase
from dualmech.models.tables import LinkageTable, TableSpec

#: The engine's words of a closed pose (the mechanism's rules then name it).
CLOSED = (Status.OK.value, Status.DEAD_CENTRE.value, Status.BRANCH_JUMP.value)


def rccc_axes(case: RcccCase, theta1: np.ndarray, theta2: np.ndarray) -> tuple[np.ndarray, ...]:
    """The world axes ``z2``, ``z3`` ``(n, 3)`` and ``z4`` ``(3,)`` at the input angles ``theta1`` and joint
    2's angles ``theta2`` ``(n,)`` (NaN where NaN): the rows ``Z(theta_i) X(alpha_i)`` of
    ``docs/conventions.md``, "RCCC".  ``Z(theta) X(alpha)`` turns ``z`` to ``(sin alpha sin theta, -sin alpha
    cos theta, cos alpha)``, so ``z3 = F2 (sin alpha23 sin theta2, -sin alpha23 cos theta2, cos alpha23)`` in
    frame ``F2 = Z(theta1) X(alpha12)`` of columns ``x2, y2, z2``; ``z4 = Rx(-alpha41) z``."""
    alpha = case.geometry.alpha
    c1, s1, ca, sa = np.cos(theta1), np.sin(theta1), np.cos(alpha[0]), np.sin(alpha[0])
    x2 = np.stack([c1, s1, np.zeros_like(c1)], 1)
    y2 = np.stack([-s1 * ca, c1 * ca, np.full_like(c1, sa)], 1)
    z2 = np.stack([sa * s1, -sa * c1, np.full_like(c1, ca)], 1)
    local = (np.sin(alpha[1]) * np.sin(theta2), -np.sin(alpha[1]) * np.cos(theta2), np.cos(alpha[1]))
    z3 = local[0][:, None] * x2 + local[1][:, None] * y2 + local[2] * z2
    return z2, z3, np.array([0.0, np.sin(alpha[3]), np.cos(alpha[3])])


def _wrap(angle: np.ndarray) -> np.ndarray:
    """Angles (rad) in [-pi, pi)."""
    return np.mod(angle + np.pi, 2 * np.pi) - np.pi


def _status(judged: LinkageTable, t1: np.ndarray, t4: np.ndarray, branch: int, torque_mode: bool
            ) -> np.ndarray:
    """The mechanism's status words from the engine's own closure (:data:`CLOSED`) and transmissions;
    ``no_assembly`` where the engine's closure stalled."""
    converged = is_status(judged.status, *CLOSED)
    status = rssr.status_words(converged, t1, t4, branch, torque_mode, judged["residual"])
    status[is_status(judged.status, Status.NO_ASSEMBLY)] = Status.NO_ASSEMBLY.value
    return status


def rssr_columns(case: RssrCase, judged: LinkageTable, not_given: tuple[str, ...] = ()) -> LinkageTable:
    """The RSSR table (:data:`~dualmech.models.linkages.rssr.SPEC`) of an engine's loop table
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
    """The RCCC table (:data:`~dualmech.models.linkages.rccc.SPEC`) of an engine's loop table
    ``judged`` of :func:`~dualmech.models.loop.presets.rccc_table` (``docs/conventions.md``, "RCCC"): joints
    2 and 3's moments moved from their joint points (frames ``{2}``, ``{3}``) to the body origins ``s_i``
    further along ``z_i``; joint 4's wrench is on the ground from the output link, about ``G``, ``s4``
    further along ``z4`` than its joint point."""
    g = case.geometry
    theta1 = np.radians(judged["theta1_deg"])
    z2, z3, z4 = rccc_axes(case, theta1, judged["theta2"])
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
    word (module docstring)."""
    reactions = tuple(c for c in spec.reactions if c not in not_given)
    rates = tuple(c for c in spec.rates if c not in not_given)
    return LinkageTable(judged.engine, case.name, cols,
                        settle(cols, status, reactions, pose=spec.pose, rates=rates), judged.meta)
