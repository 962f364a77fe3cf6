"""The loop table's file format: ``[mechanism] kind = "loop"`` with ``[[joint]]``, ``[drive]``, ``[[body]]``
and ``[[load]]`` tables, read into a :class:`~dualmech.models.loop.description.LoopMechanism`.

The format and its frames: ``docs/conventions.md``, "Loop tables".  Every bad value is a one-line
:class:`~dualmech.models.inputs.CaseError` (a ``ValueError``) naming the key, e.g.
``joint[3].type: expected one of R, P, C, S, U, got 'Q'``; rows are numbered from 1, as the thesis
numbers its joints.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from dualmech.core.inertia import BodyInertia, solid_cube, solid_cylinder_x
from dualmech.models.bodies import _tensor as inertia_tensor
from dualmech.models.inputs import (
    ACCELERATION,
    ANGLE_DEG,
    FORCE,
    LENGTH,
    MAX_CASE_NAME,
    MAX_POSITIONS,
    POSITIVE_LENGTH,
    POSITIVE_MASS,
    CaseError,
    Range,
    check_keys,
    check_number,
    check_text,
    check_vector,
    show,
)
from dualmech.models.loop.description import FREEDOMS, Drive, Joint, Load, LoopMechanism
from dualmech.models.loop.mobility import check_mobility

TOP_KEYS = ("name", "units", "description", "gravity", "mechanism", "joint", "drive", "body", "load")
JOINT_KEYS = ("type", "alpha_deg", "a", "theta_deg", "s", "start")
DRIVE_KEYS = ("joint", "positions", "speed", "accel", "axial_shift", "axial_amplitude", "axial_cycles",
              "effort")
BODY_KEYS = ("mass", "com", "inertia", "radius", "side")
LOAD_KEYS = ("joint", "coordinate", "value")
#: A drive's speed and acceleration: rad/s and rad/s^2, or length/s and length/s^2.
RATE = Range(-1e15, 1e15, "a rate (rad/s or length/s)")
EFFORT = Range(FORCE.low, FORCE.high, "a torque or a force (case units)")
CYCLES = Range(-1e3, 1e3, "axial cycles per turn of the driven joint")


def _rows(data: dict, key: str) -> list:
    rows = data.get(key, [])
    if not isinstance(rows, list) or not all(isinstance(r, dict) for r in rows):
        raise CaseError(f"{key}: expected an array of tables ([[{key}]]), got {show(rows)}")
    return rows


def _joint(k: int, row: dict) -> Joint:
    where = f"joint[{k + 1}]"
    check_keys(where, row, JOINT_KEYS)
    kind = row.get("type")
    if kind not in FREEDOMS:
        raise CaseError(f"{where}.type: expected one of {', '.join(FREEDOMS)}, got {show(kind)}")
    values = {name: math.radians(check_number(f"{where}.{name}", row.get(name, 0.0), ANGLE_DEG))
              for name in ("alpha_deg", "theta_deg")}
    values.update({name: check_number(f"{where}.{name}", row.get(name, 0.0), LENGTH) for name in ("a", "s")})
    start = row.get("start", [])
    if not isinstance(start, list) or len(start) not in (0, FREEDOMS[kind]):
        raise CaseError(f"{where}.start: a {kind} joint has {FREEDOMS[kind]} variables, got {show(start)}")
    # angles in degrees, slides in lengths: only a P joint's variable and a C joint's second are slides
    slides = {"P": (0,), "C": (1,)}.get(kind, ())
    start = tuple(check_number(f"{where}.start[{i}]", v, LENGTH) if i in slides
                  else math.radians(check_number(f"{where}.start[{i}]", v, ANGLE_DEG))
                  for i, v in enumerate(start))
    try:
        return Joint(kind, values["alpha_deg"], values["a"], values["theta_deg"], values["s"], start)
    except ValueError as err:
        raise CaseError(f"{where}.{err}") from None


def _positions(key: str, spec: Any, angle: bool) -> np.ndarray:
    """``{start, stop, step}`` (stop exclusive) or a list of values: degrees for an angle, else lengths."""
    limits = ANGLE_DEG if angle else LENGTH
    if isinstance(spec, list):
        if not spec or len(spec) > MAX_POSITIONS:
            raise CaseError(f"{key}: expected 1 to {MAX_POSITIONS:,} values, got {len(spec)}")
        values = np.array([check_number(f"{key}[{i}]", v, limits) for i, v in enumerate(spec)])
    elif isinstance(spec, dict):
        check_keys(key, spec, ("start", "stop", "step"))
        for name in ("start", "stop", "step"):
            if name not in spec:
                raise CaseError(f"{key}.{name}: required key missing")
        start, stop, step = (check_number(f"{key}.{n}", spec[n], limits) for n in ("start", "stop", "step"))
        if step == 0 or abs(stop - start) > abs(step) * MAX_POSITIONS:
            raise CaseError(f"{key}.step: expected a non-zero step giving at most {MAX_POSITIONS:,} "
                            "positions, "
                            f"got {step!r}")
        count = math.ceil((stop - start) / step - 1e-9)
        if count <= 0:
            raise CaseError(f"{key}: start={start!r}, stop={stop!r}, step={step!r} gives no position "
                            "(stop is exclusive; step must point from start to stop)")
        values = start + step * np.arange(count)
    else:
        raise CaseError(f"{key}: expected {{start, stop, step}} or an array of numbers, got {show(spec)}")
    return np.radians(values) if angle else values


def _drive(d: Any, joints: tuple[Joint, ...]) -> Drive:
    if not isinstance(d, dict):
        raise CaseError(f"drive: expected a table, got {show(d)}")
    check_keys("drive", d, DRIVE_KEYS)
    for key in ("joint", "positions", "speed"):
        if key not in d:
            raise CaseError(f"drive.{key}: required key missing")
    joint = _joint_index("drive.joint", d["joint"], len(joints))
    kind = joints[joint].type
    if kind not in ("R", "P", "C"):
        raise CaseError(f"drive.joint: joint[{joint + 1}] is {kind}; the driven joint is an R, P or C")
    coordinate = "s" if kind == "P" else "theta"
    effort = d.get("effort")
    try:
        return Drive(joint, coordinate, _positions("drive.positions", d["positions"], coordinate == "theta"),
                     check_number("drive.speed", d["speed"], RATE),
                     check_number("drive.accel", d.get("accel", 0.0), RATE),
                     check_number("drive.axial_shift", d.get("axial_shift", 0.0), LENGTH),
                     check_number("drive.axial_amplitude", d.get("axial_amplitude", 0.0), LENGTH),
                     check_number("drive.axial_cycles", d.get("axial_cycles", 0.0), CYCLES),
                     None if effort is None else check_number("drive.effort", effort, EFFORT))
    except CaseError:
        raise
    except ValueError as err:
        raise CaseError(f"drive.{err}") from None


def _joint_index(key: str, value: Any, n: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= n:
        raise CaseError(f"{key}: expected a joint number 1..{n}, got {show(value)}")
    return value - 1


def _body(k: int, b: dict, length: float) -> BodyInertia:
    """``[[body]]`` number ``k`` (0-based), link ``k + 1`` of length ``length`` (its joint's ``a``): ``mass``
    and one of ``inertia`` (about the centre of mass), ``radius`` (a uniform solid cylinder along the link
    frame's x from the joint to the next axis; ``com`` default its middle ``[a/2, 0, 0]``) or ``side`` (a
    uniform solid cube; ``com`` default the link frame's origin)."""
    where = f"body[{k + 1}]"
    check_keys(where, b, BODY_KEYS)
    if "mass" not in b:
        raise CaseError(f"{where}.mass: required key missing")
    shapes = [key for key in ("inertia", "radius", "side") if key in b]
    if len(shapes) != 1:
        raise CaseError(f"{where}: give exactly one of inertia (3 moments or 3x3), radius (a solid cylinder) "
                        f"or side (a solid cube), got {', '.join(shapes) or 'none'}")
    mass = check_number(f"{where}.mass", b["mass"], POSITIVE_MASS)
    if shapes == ["radius"]:
        radius = check_number(f"{where}.radius", b["radius"], POSITIVE_LENGTH)
        inertia = solid_cylinder_x(mass, abs(length), radius)
        middle = np.array([length / 2.0, 0.0, 0.0])
    elif shapes == ["side"]:
        inertia = solid_cube(mass, check_number(f"{where}.side", b["side"], POSITIVE_LENGTH))
        middle = np.zeros(3)
    else:
        inertia, middle = inertia_tensor(f"{where}.inertia", b["inertia"]), np.zeros(3)
    com = check_vector(f"{where}.com", b["com"], LENGTH) if "com" in b else middle
    try:
        return BodyInertia(mass, com, inertia)
    except CaseError:
        raise
    except ValueError as err:
        raise CaseError(f"{where}.{err}") from None


def _load(k: int, row: dict, joints: tuple[Joint, ...]) -> Load:
    where = f"load[{k + 1}]"
    check_keys(where, row, LOAD_KEYS)
    if "joint" not in row:
        raise CaseError(f"{where}.joint: required key missing")
    joint = _joint_index(f"{where}.joint", row["joint"], len(joints))
    coordinate = row.get("coordinate", "s" if joints[joint].type == "P" else "theta")
    if coordinate not in ("theta", "s"):
        raise CaseError(f"{where}.coordinate: expected 'theta' (a torque) or 's' (a force), "
                        f"got {show(coordinate)}")
    value = row.get("value")
    return Load(joint, coordinate, None if value is None else check_number(f"{where}.value", value, EFFORT))


def loop_from_dict(data: dict) -> LoopMechanism:
    """The :class:`LoopMechanism` of a parsed file (a dict of its tables), mobility checked.

    Raises
    ------
    CaseError
        One line naming the key, the value and what is valid.
    """
    if not isinstance(data, dict):
        raise CaseError(f"expected a table of tables, got {show(data)}")
    check_keys("", data, TOP_KEYS)
    mech = data.get("mechanism")
    if not isinstance(mech, dict) or mech.get("kind") != "loop":
        kind = mech.get("kind") if isinstance(mech, dict) else None
        raise CaseError(f"mechanism.kind: expected \"loop\", got {show(kind)}")
    check_keys("mechanism", mech, ("kind",))
    name = check_text("name", data.get("name", "loop"), MAX_CASE_NAME)
    joints = tuple(_joint(k, row) for k, row in enumerate(_rows(data, "joint")))
    if len(joints) < 2:
        raise CaseError(f"joint: a loop needs at least 2 [[joint]] rows, got {len(joints)}")
    drive = _drive(data.get("drive"), joints)
    rows = _rows(data, "body")
    bodies = tuple(_body(k, b, joints[min(k, len(joints) - 1)].a) for k, b in enumerate(rows))
    if len(bodies) != len(joints) - 1:
        raise CaseError(f"body: expected one [[body]] per moving link ({len(joints) - 1}), got {len(bodies)}")
    loads = tuple(_load(k, row, joints) for k, row in enumerate(_rows(data, "load")))
    gravity = check_vector("gravity", data["gravity"], ACCELERATION) if "gravity" in data else np.zeros(3)
    try:
        mechanism = LoopMechanism(name, joints, drive, bodies, loads, gravity)
        check_mobility(mechanism)
    except CaseError:
        raise
    except ValueError as err:
        raise CaseError(str(err)) from None
    return mechanism
