"""Mass properties of the three moving bodies of a case (the ``[bodies]`` table), computed once.

Each body is a default shape of a stated size and mass per volume (the crank and the rod
solid cylinders along their body x axis, the slider a solid cube), then any explicit
``mass``, ``com`` or ``inertia`` of ``[bodies.<name>]`` (``docs/conventions.md``, "Case
files").  Every engine reads these :class:`~dualmech.core.inertia.BodyInertia`.
"""

from __future__ import annotations

import math

import numpy as np

from dualmech.core.dual import scalar_type
from dualmech.core.inertia import BodyInertia, solid_cube, solid_cylinder_x
from dualmech.models.inputs import (
    INERTIA,
    LENGTH,
    POSITIVE_ACCELERATION,
    POSITIVE_DENSITY,
    POSITIVE_LENGTH,
    POSITIVE_MASS,
    CaseError,
    NumberReader,
    check_keys,
    check_number,
    check_vector,
    show,
)
from dualmech.models.mechanism import Bodies, Geometry

_BODY_KEYS = {"mass", "com", "inertia"}


def _tensor(key: str, value: object) -> np.ndarray:
    if isinstance(value, list) and len(value) == 3 and all(isinstance(v, list) for v in value):
        rows = [check_vector(f"{key}[{i}]", row, INERTIA) for i, row in enumerate(value)]
        return np.array(rows)
    if isinstance(value, list) and len(value) == 3:
        return np.diag(check_vector(key, value, INERTIA))
    raise CaseError(f"{key}: expected 3 principal moments or a 3x3 array, got {show(value)}")


def _mass_per_volume(b: dict, number: NumberReader) -> float | None:
    has_density = "density" in b
    has_weight = "weight_density" in b or "gravity_constant" in b
    if has_density and has_weight:
        raise CaseError(
            "bodies.density: give either density or weight_density with gravity_constant, not both"
        )
    if has_density:
        return number("bodies.density", b["density"], POSITIVE_DENSITY)
    if has_weight:
        for key in ("weight_density", "gravity_constant"):
            if key not in b:
                raise CaseError(f"bodies.{key}: required with the other weight-based key")
        w = number("bodies.weight_density", b["weight_density"], POSITIVE_DENSITY)
        g = number("bodies.gravity_constant", b["gravity_constant"], POSITIVE_ACCELERATION)
        return w / g
    return None


def _body(name: str, b: dict, geom: Geometry, rho: float | None, number: NumberReader) -> BodyInertia:
    """Mass properties of one body: the default shape, then any explicit overrides."""
    explicit = b.get(name, {})
    check_keys(f"bodies.{name}", explicit, _BODY_KEYS)
    shape_key = {"crank": "crank_radius", "rod": "rod_radius", "slider": "slider_side"}[name]
    default = None
    if shape_key in b and rho is not None:
        size = number(f"bodies.{shape_key}", b[shape_key], POSITIVE_LENGTH)
        if name == "crank":
            m = rho * math.pi * size**2 * geom.crank_length
            default = (m, [geom.crank_length / 2, 0, 0], solid_cylinder_x(m, geom.crank_length, size))
        elif name == "rod":
            m = rho * math.pi * size**2 * geom.rod_length
            default = (m, [geom.rod_length / 2, 0, 0], solid_cylinder_x(m, geom.rod_length, size))
        else:
            m = rho * size**3
            default = (m, [0, 0, 0], solid_cube(m, size))
    elif shape_key in b:
        check_number(f"bodies.{shape_key}", b[shape_key], POSITIVE_LENGTH)
    missing = [k for k in ("mass", "com", "inertia") if k not in explicit]
    if default is None and missing:
        raise CaseError(
            f"bodies.{name}: no mass properties: give bodies.{shape_key} with a density "
            f"(density, or weight_density and gravity_constant), or bodies.{name}.{missing[0]}"
        )
    mass = (
        number(f"bodies.{name}.mass", explicit["mass"], POSITIVE_MASS)
        if "mass" in explicit
        else default[0]
    )
    com = (check_vector(f"bodies.{name}.com", explicit["com"], LENGTH) if "com" in explicit
           else np.array(default[1], scalar_type(*default[1])))
    inertia = _tensor(f"bodies.{name}.inertia", explicit["inertia"]) if "inertia" in explicit else default[2]
    if "inertia" not in explicit and "mass" in explicit and default is not None:
        inertia = inertia * (mass / default[0])  # same shape, new mass
    try:
        body = BodyInertia(mass, com, inertia)
    except ValueError as err:
        raise CaseError(f"bodies.{name}.{err}") from None
    if name == "rod":
        check_rod_axisymmetric(body)
    return body


def check_rod_axisymmetric(rod: BodyInertia) -> None:
    """Two ball joints leave the rod's spin free: its mass must not care about that spin."""
    scale = float(np.abs(rod.inertia).max())  # relative tests: the verdict must not depend on the unit system
    off_axis = np.hypot(*np.abs(rod.com[1:]))  # abs: a complex step (models/case.py, case_numbers)
    if off_axis > 1e-12 * float(np.linalg.norm(rod.com)):
        raise CaseError(
            f"bodies.rod.com: {rod.com.tolist()} is off the rod axis; two ball joints leave the "
            "rod's spin free, so its centre of mass must lie on the body x axis ([x, 0, 0])"
        )
    i = rod.inertia
    if abs(i[0, 1]) + abs(i[0, 2]) + abs(i[1, 2]) > 1e-12 * scale or abs(i[1, 1] - i[2, 2]) > 1e-12 * scale:
        raise CaseError(
            f"bodies.rod.inertia: {i.tolist()} is not axisymmetric about the rod axis; two ball "
            "joints leave the rod's spin free, so it must be diag(I_axial, I_t, I_t)"
        )


def bodies_from_table(b: dict, geom: Geometry, number: NumberReader = check_number) -> Bodies:
    """The :class:`Bodies` of a ``[bodies]`` table (checked), for the case's geometry.

    ``number`` reads each scalar (:data:`~dualmech.models.inputs.NumberReader`).
    """
    rho = _mass_per_volume(b, number)
    return Bodies(*(_body(name, b, geom, rho, number) for name in ("crank", "rod", "slider")))
