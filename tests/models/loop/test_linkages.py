"""The generic loop engine on the RSSR's and the RCCC's tables against their own engines (bundled cases)."""

from __future__ import annotations

import numpy as np
import pytest

from dualmech.models.linkages import read_linkage
from dualmech.models.linkages.rccc_case import rccc_from_dict
from dualmech.models.linkages.rssr_case import rssr_from_dict
from dualmech.models.loop.engine import analyze_loop
from dualmech.models.loop.presets import rccc_start, rccc_table, rssr_start, rssr_table
from dualmech.models.loop.table_format import loop_from_dict
from tests.linkage_oracles import analyze_rccc, analyze_rssr
from tests.tolerances import LOOP_VS_OWN_ENGINE


def _assert_close(name: str, mine: np.ndarray, theirs: np.ndarray, rows: np.ndarray) -> None:
    """Largest difference on ``rows`` within LOOP_VS_OWN_ENGINE of the reference's peak there."""
    scale = np.abs(theirs[rows]).max()
    np.testing.assert_allclose(mine[rows], theirs[rows], rtol=0, atol=LOOP_VS_OWN_ENGINE * scale,
                               err_msg=name)


def _wrapped(angle: np.ndarray) -> np.ndarray:
    return np.mod(angle + np.pi, 2 * np.pi) - np.pi


@pytest.mark.parametrize(("mode", "branch"), [("torque", 1), ("output", 1), ("output", -1)])
def test_rssr(mode: str, branch: int) -> None:
    data = read_linkage("rssr")
    data = {**data, "mechanism": {**data["mechanism"], "branch": branch}}
    if mode == "torque":
        data = {**data, "loads": {**{k: v for k, v in data["loads"].items() if k != "output_torque"},
                                  "drive_torque": 3.0}}
    case = rssr_from_dict(data)
    ref = analyze_rssr(case)
    an = analyze_loop(rssr_table(case), rssr_start(case))
    np.testing.assert_array_equal(an.status.astype(str), ref.status.astype(str))
    ok = ref.status == "ok"
    theta4, rate, accel = an.coordinate(3, "theta")
    _assert_close("phi4", _wrapped(np.pi - theta4 - ref.phi) + ref.phi, ref.phi, ok)
    _assert_close("phi4_dot", -rate, ref.phi_dot, ok)
    _assert_close("phi4_ddot", -accel, ref.phi_ddot, ok)
    w, r = an.wrenches, ref.reactions
    hub = np.array([0.0, 0.0, case.geometry.s1])
    np.testing.assert_allclose(w.point[:, 3], np.broadcast_to(case.geometry.foot, (len(ok), 3)), rtol=0,
                               atol=LOOP_VS_OWN_ENGINE * case.geometry.a4)
    for name, mine, theirs in (
            ("j1_f", w.force[:, 0], r.force["j1"]),
            ("j1_m about O", w.moment[:, 0], r.moment["j1"] + np.cross(hub, r.force["j1"])),
            ("j2_f", w.force[:, 1], r.force["j2"]), ("j3_f", w.force[:, 2], r.force["j3"]),
            ("j4_f", -w.force[:, 3], r.force["j4"]), ("j4_m about Q4", -w.moment[:, 3], r.moment["j4"]),
            ("drive_torque", w.efforts["theta1"], r.moment["j1"][:, 2]),
            ("output_torque", -w.efforts["theta4"], r.moment["j4"] @ case.geometry.k4)):
        _assert_close(name, mine, theirs, ok)


def test_rccc() -> None:
    case = rccc_from_dict(read_linkage("rccc"))
    ref = analyze_rccc(case)
    an = analyze_loop(rccc_table(case), rccc_start(case))
    np.testing.assert_array_equal(an.status.astype(str), ref.status.astype(str))
    ok = ref.status == "ok"
    for j, name in enumerate(("theta2", "s2", "theta3", "s3", "theta4", "s4")):
        k = an.loop.unknowns.index(name)
        value = an.state.scalars[:, k]
        if name.startswith("theta"):
            value = _wrapped(value - ref.q[:, j]) + ref.q[:, j]
        _assert_close(name, value, ref.q[:, j], ok)
        _assert_close(name + "_dot", an.rates.q_dot[:, k], ref.q_dot[:, j], ok)
        _assert_close(name + "_ddot", an.rates.q_ddot[:, k], ref.q_ddot[:, j], ok)
    w, r = an.wrenches, ref.reactions
    # the RCCC takes j2, j3 about the body origins of links 2, 3 and j4 about G = (-a41, 0, 0)
    about = {"j1": w.point[:, 0], "j2": ref.frames[1][1], "j3": ref.frames[2][1],
             "j4": np.broadcast_to([-case.geometry.a[3], 0.0, 0.0], w.point[:, 3].shape)}
    for k, joint in enumerate(("j1", "j2", "j3", "j4")):
        sign = -1.0 if joint == "j4" else 1.0  # joint 4's wrench acts on the ground
        moment = w.moment[:, k] + np.cross(w.point[:, k] - about[joint], w.force[:, k])
        _assert_close(joint + "_f", sign * w.force[:, k], r.force[joint], ok)
        _assert_close(joint + "_m", sign * moment, r.moment[joint], ok)
    _assert_close("drive_torque", w.efforts["theta1"], r.moment["j1"][:, 2], ok)


def test_rssr_file_as_loop_table() -> None:
    """The bundled RSSR written as a ``kind = "loop"`` file (its cylinders by ``radius``, the output crank's
    mass turned into its link frame) gives the preset table's numbers."""
    case = rssr_from_dict(read_linkage("rssr"))
    g, table = case.geometry, rssr_table(case)
    out = table.bodies[2]
    data = {
        "name": "rssr-as-table", "mechanism": {"kind": "loop"}, "gravity": case.gravity.tolist(),
        "joint": [{"type": "R", "a": g.a1, "s": g.s1}, {"type": "S", "a": g.a2}, {"type": "S", "a": g.a3},
                  {"type": "R", "alpha_deg": np.degrees(g.alpha4), "a": g.a4, "s": -g.h}],
        "drive": {"joint": 1, "positions": {"start": 0.0, "stop": 360.0, "step": 2.0},
                  "speed": case.motion.speed, "accel": case.motion.accel},
        "body": [{"mass": 0.8, "radius": 0.015}, {"mass": 1.2, "radius": 0.01},
                 {"mass": out.mass, "com": out.com.tolist(), "inertia": out.inertia.tolist()}],
        "load": [{"joint": 4, "value": -case.output_torque}],
    }
    mech = loop_from_dict(data)
    for mine, theirs in zip(mech.bodies, table.bodies):
        np.testing.assert_allclose(mine.inertia, theirs.inertia, rtol=1e-14, atol=0)
        np.testing.assert_allclose(mine.com, theirs.com, rtol=1e-14, atol=0)
    start = rssr_start(case)
    mine, theirs = analyze_loop(mech, start), analyze_loop(table, start)
    ok = theirs.status == "ok"
    np.testing.assert_array_equal(mine.status, theirs.status)
    _assert_close("wrenches", mine.wrenches.force, theirs.wrenches.force, ok)
