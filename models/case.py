"""Case files: one TOML file describes one generalized slider crank and its motion.

The keys and their meanings are listed in ``docs/conventions.md`` ("Case
files").  :func:`load_case` reads a file or a bundled preset and returns a
frozen :class:`Case`; every engine (in-house, Pinocchio, MuJoCo) builds its
model from this one record, so masses and inertias are computed once
(:mod:`dualmech.models.bodies`); the record's parts and their derived geometry are
in :mod:`dualmech.models.mechanism`.

Errors are :class:`~dualmech.models.inputs.CaseError` (a ``ValueError``) with a one-line
message that names the key, the value received and what would be valid.  Every number is
checked against a stated :class:`~dualmech.models.inputs.Range` before it is used
(:mod:`dualmech.models.inputs`; ``docs/conventions.md``, "Input ranges", gives the table and
the reasons).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from dualmech.core.motion import CrankMotion, CrankState
from dualmech.models.case_format import (
    KNOWN_UNITS,
    case_numbers,
    check_kind,
    check_top_keys,
    deep_copy,
    parse_tables,
)
from dualmech.models.inputs import MAX_CASE_NAME, CaseError, show
from dualmech.models.mechanism import Bodies, Geometry, Joints, Loads
from dualmech.models.toml_input import read_toml

__all__ = ["KNOWN_UNITS", "Case", "CaseError", "case_from_dict", "case_numbers", "load_case", "preset_names",
           "preset_path", "with_loads"]

#: |cos alpha4| below which the slider line lies in the crank plane (twist 90 or 270 deg): the cosine of
#: a twist given in degrees is rounded to ~1e-16, so 1e-12 only admits the planar twists themselves.
PLANAR_TWIST_COSINE = 1e-12


@dataclass(frozen=True, init=False)
class Case:
    """One slider-crank case: geometry, motion, bodies and loads, validated.

    Built from the tables of a case file, given as keyword arguments (the same keys, ranges and one-line
    errors as the TOML reader; ``docs/conventions.md``, "Case files")::

        case = Case("my-design", units="m-kg-s",
                    geometry={"crank_length": 0.05, "rod_length": 0.2, "slider_offset": 0.01,
                              "slider_twist_deg": 270, "crank_axial_shift": 0},
                    motion={"crank_rpm": 600}, loads={"drive_torque": 2.0})

    or by :func:`load_case` (a file or preset) and :func:`case_from_dict` (a parsed table).  A changed
    copy is :meth:`with_values` (``dataclasses.replace`` is refused: it could not keep :attr:`raw`, from
    which every engine and sweep rebuilds the case, consistent with the parts).

    Parameters
    ----------
    name : str
        The case's name (it becomes a file name in a run folder).
    units : str
        The unit-system label (:data:`KNOWN_UNITS`); nothing is converted.
    geometry, motion, loads : dict
        The ``[geometry]``, ``[motion]`` and ``[loads]`` tables.
    bodies, joints, simulation, mechanism : dict, optional
        The optional tables of the same names.
    description : str, optional
        Free text.

    Raises
    ------
    CaseError
        A ``ValueError`` of one line naming the key, the value and what would be valid.
    """

    name: str
    units: str
    geometry: Geometry
    motion: CrankMotion
    bodies: Bodies
    loads: Loads
    raw: dict  # the parsed TOML, after defaults; used to derive swept cases
    joints: Joints = Joints()
    #: ``[simulation] steps_per_degree``: the MuJoCo simulation judge's time step, in steps per degree of
    #: the fastest prescribed phase (``None``: its documented default, models/mjcf_settings.py).
    simulation_steps: int | None = None

    def __init__(self, name: str = "design", *, geometry: dict | None = None, motion: dict | None = None,
                 loads: dict | None = None, units: str = "consistent", bodies: dict | None = None,
                 joints: dict | None = None,
                 simulation: dict | None = None, mechanism: dict | None = None,
                 description: str | None = None, **record: Any) -> None:
        if record:
            raise TypeError(f"Case: unexpected argument {', '.join(sorted(record))}; a changed case is "
                            "case.with_values({'geometry.crank_length': ...}) (dataclasses.replace cannot "
                            "keep a case's tables consistent)")
        given = {"name": name, "units": units, "description": description, "mechanism": mechanism,
                 "geometry": geometry, "motion": motion, "bodies": bodies, "loads": loads, "joints": joints,
                 "simulation": simulation}
        for field, value in parse_tables({k: v for k, v in given.items() if v is not None}).items():
            object.__setattr__(self, field, value)

    def crank_state(self, theta: np.ndarray, theta_dot: np.ndarray | float,
                    theta_ddot: np.ndarray | float) -> CrankState:
        """The crank state of a motion :math:`\\theta_1(t)` given per position (rad, rad/s, rad/s^2; ``(n,)``
        or scalars), :math:`S_1` following it by the case's axial law
        (:meth:`~dualmech.core.motion.CrankMotion.at`)."""
        return self.motion.at(self.geometry.crank_axial_shift, theta, theta_dot, theta_ddot)

    def own_crank_states(self, angles_deg: np.ndarray | None = None) -> CrankState:
        """The crank states of the case's own motion (speed, acceleration and axial law) at its angles, or
        at ``angles_deg``."""
        return self.motion.state(self.geometry.crank_axial_shift, angles_deg)

    @property
    def is_planar(self) -> bool:
        """``S1 = 0`` at every position and the slider line in the crank plane (``cos alpha4 = 0``)."""
        g, m = self.geometry, self.motion
        return (g.crank_axial_shift == 0.0 and m.axial_amplitude == 0.0
                and abs(math.cos(g.slider_twist)) < PLANAR_TWIST_COSINE)

    def with_values(self, updates: dict[str, Any]) -> "Case":
        """Return a new case with dotted keys replaced, e.g. ``{"geometry.slider_offset": 10}``."""
        if not isinstance(updates, dict) or not all(isinstance(k, str) for k in updates):
            raise TypeError(f"updates: expected a dict of dotted keys such as "
                            f"{{'geometry.rod_length': 50.0}}, got {show(updates)}")
        raw = deep_copy(self.raw)
        for dotted, value in updates.items():
            node = raw
            *parents, leaf = dotted.split(".")
            for p in parents:
                node = node.setdefault(p, {})
                if not isinstance(node, dict):
                    raise CaseError(f"{dotted}: {p!r} is not a table")
            node[leaf] = value
        if "name" not in updates:
            raw["name"] = (self.name + "".join(f"|{k}={v}" for k, v in updates.items()))[:MAX_CASE_NAME]
        return case_from_dict(raw)

    def with_parts(self, **parts: Any) -> "Case":
        """A copy with some of its parts (``geometry``, ``motion``, ``bodies``, ``loads``) replaced as given,
        unchecked, :attr:`raw` kept: for the solver's own derived cases (the same case at other crank angles,
        numbers carrying a complex step), solved in this process.  A user's changed design is
        :meth:`with_values`, which checks it."""
        copy = object.__new__(Case)
        object.__setattr__(copy, "__dict__", {**self.__dict__, **parts})
        return copy


# ----------------------------------------------------------------------------- public

def case_from_dict(data: dict) -> Case:
    """Validate a parsed case table (the TOML file's tables as a ``dict``) and build the :class:`Case`.

    Raises
    ------
    CaseError
        One line naming the key, the value and what would be valid.
    """
    if not isinstance(data, dict):
        raise CaseError(f"case: expected a table, got {show(data)}")
    check_kind(data)
    check_top_keys(data)
    if "name" not in data:
        raise CaseError("name: required key missing")
    return Case(**data)


def preset_names() -> list[str]:
    """Names of the bundled presets, ``"<group>/<stem>"`` (e.g. ``"thesis/ideal"``)."""
    root = resources.files("dualmech.models") / "cases"
    names = []
    for group in sorted(p for p in root.iterdir() if p.is_dir()):
        names += [f"{group.name}/{f.name[:-5]}" for f in sorted(group.iterdir(), key=lambda f: f.name)
                  if f.name.endswith(".toml")]
    return names


def preset_path(name: str) -> Path:
    """File of a bundled preset; ``name`` is ``"thesis/ideal"`` or a unique stem ``"ideal"``."""
    names = preset_names()
    matches = [n for n in names if n == name or n.split("/", 1)[1] == name]
    if len(matches) != 1:
        raise CaseError(f"case: {show(name)} is neither a file nor a bundled slider crank (presets: "
                        f"{', '.join(names)}; another kind's bundled case, of dualmech cases, is read by "
                        "dualmech.solve and the other verbs)")
    group, stem = matches[0].split("/", 1)
    return Path(str(resources.files("dualmech.models") / "cases" / group / f"{stem}.toml"))


def load_case(source: str | Path) -> Case:
    """Read a case from a TOML file, or from a bundled preset name.

    Parameters
    ----------
    source : str or pathlib.Path
        A path to a ``.toml`` file, or a preset name as listed by :func:`preset_names`.
    """
    if not isinstance(source, (str, os.PathLike)):
        raise TypeError(f"source: expected a case file path or a preset name (dualmech cases lists them), "
                        f"got {show(source)}")
    path = Path(source)
    if not path.is_file():
        path = preset_path(str(source))
    return case_from_dict(read_toml(path, CaseError))


def with_loads(case: Case, **updates: Any) -> Case:
    """Copy of ``case`` with keys of its ``[loads]`` table replaced (``None`` removes one), e.g. switching
    torque/force mode: ``with_loads(case, drive_torque=None, slider_force=0.0)``."""
    loads = {**case.raw.get("loads", {}), **updates}
    if "gravity" in updates:
        loads["gravity"] = np.asarray(updates["gravity"], dtype=float).tolist()
    return case_from_dict({**case.raw, "loads": {k: v for k, v in loads.items() if v is not None}})
