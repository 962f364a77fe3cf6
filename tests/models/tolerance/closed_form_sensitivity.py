"""Test oracle: the tolerance study's sensitivities restated in closed form (complex step).

Before the study's sensitivities went through the solver's own code
(``models/tolerance/sensitivity.py``), they were this: the slider crank's kinematics in closed form
(``g(S4, p) = |F - S4 k4 - P2|^2 - a2^2``, one complex Newton step for ``S4``, the rates from its
derivatives, the rod's zero spin), the case's mass properties, D'Alembert and the closed-form
elimination of ``core/reactions.py``, all evaluated on complex numbers ``x + i h x'``.  It shares no
code with the solver's loop, screws or Newton step, so agreement to round-off says both derivations
of the same derivative are right (``tests/models/tolerance/test_sensitivity.py``).  Ball joints only
(the rod's zero-spin gauge); the outputs' positions are the solver's peaks.
"""

from __future__ import annotations

import math

import numpy as np

from dualmech.core.inertia import solid_cube, solid_cylinder_x
from dualmech.core.table import ResultTable
from dualmech.models.case import Case
from dualmech.models.tolerance.outputs import FORCES, MOMENTS, SOLVED_LOAD, output_names, peak_positions
from dualmech.models.tolerance.spec import Spec, nominal_values

#: Imaginary step ``h`` (as the study's).
STEP = 1e-100


class _Params:
    """Case numbers by dotted key; the varied key of the current direction carries ``+ i h``."""

    def __init__(self, case: Case, spec: Spec, direction: int | None) -> None:
        self.raw = case.raw
        self.values = dict(zip(spec.keys, nominal_values(case, spec).astype(complex)))
        if direction is not None:
            self.values[spec.keys[direction]] += 1j * STEP

    def __call__(self, key: str, default: float | None = None) -> complex:
        if key in self.values:
            return self.values[key]
        node = self.raw
        for part in key.split("."):
            node = node.get(part) if isinstance(node, dict) else None
        return complex(default if node is None else node)

    def given(self, key: str) -> bool:
        """The case file states ``key`` (or the SPEC varies it)."""
        node = self.raw
        for part in key.split("."):
            node = node.get(part) if isinstance(node, dict) else None
        return node is not None or key in self.values


def _body(p: _Params, name: str) -> tuple[complex, np.ndarray, np.ndarray]:
    """Mass, body-frame centre of mass and central inertia of one body (``models/case.py``, ``_body``)."""
    b = p.raw.get("bodies", {})
    length = {"crank": p("geometry.crank_length"), "rod": p("geometry.rod_length")}.get(name)
    shape_key = {"crank": "crank_radius", "rod": "rod_radius", "slider": "slider_side"}[name]
    rho = p("bodies.density") if "density" in b else (
        p("bodies.weight_density") / p("bodies.gravity_constant") if "weight_density" in b else None)
    default = None
    if shape_key in b and rho is not None:
        size = p(f"bodies.{shape_key}")
        if length is None:
            m0 = rho * size**3
            default = (m0, np.zeros(3, complex), solid_cube(m0, size).astype(complex))
        else:
            m0 = rho * math.pi * size**2 * length
            default = (m0, np.array([length / 2, 0, 0]), solid_cylinder_x(m0, length, size).astype(complex))
    explicit = b.get(name, {})
    mass = p(f"bodies.{name}.mass") if p.given(f"bodies.{name}.mass") else default[0]
    com = np.array(explicit["com"], complex) if "com" in explicit else default[1]
    if "inertia" in explicit:
        i = np.array(explicit["inertia"], complex)
        inertia = i if i.ndim == 2 else np.diag(i)
    else:
        inertia = default[2] * (mass / default[0])
    return mass, com, inertia


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.stack([a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1],
                     a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
                     a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]], axis=-1)


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return (a * b).sum(axis=-1)


def _kinematics(p: _Params, theta: np.ndarray, s4: np.ndarray) -> dict[str, np.ndarray]:
    """Crank pin, slider pin and their rates at crank angles ``theta`` ``(P,)`` rad (eqs. 27-28b)."""
    a1, a2, a4 = p("geometry.crank_length"), p("geometry.rod_length"), p("geometry.slider_offset")
    alpha = p("geometry.slider_twist_deg") * (math.pi / 180.0)
    w, wd = 2.0 * math.pi * p("motion.crank_rpm") / 60.0, p("motion.crank_accel", 0.0)
    amp, cyc = p("motion.axial_amplitude", 0.0), p("motion.axial_cycles", 0.0)
    c, s, ph = np.cos(theta), np.sin(theta), cyc * theta
    s1 = p("geometry.crank_axial_shift") + amp * np.sin(ph)
    s1d = amp * cyc * np.cos(ph) * w
    s1dd = amp * cyc * (np.cos(ph) * wd - cyc * np.sin(ph) * w**2)
    p2 = np.stack([a1 * c, a1 * s, s1], -1)
    p2d = np.stack([-a1 * s * w, a1 * c * w, s1d], -1)
    p2dd = np.stack([-a1 * c * w**2 - a1 * s * wd, -a1 * s * w**2 + a1 * c * wd, s1dd], -1)
    f = np.array([-a4, 0.0, 0.0])
    k4 = np.array([0.0, np.sin(alpha), np.cos(alpha)])
    r = f - s4[:, None] * k4 - p2
    s4 = s4 - (_dot(r, r) - a2**2) / (-2.0 * _dot(r, k4))  # implicit function theorem (module docstring)
    r = f - s4[:, None] * k4 - p2
    s4d = -_dot(r, p2d) / _dot(r, k4)
    rd = -s4d[:, None] * k4 - p2d
    s4dd = (_dot(rd, rd) - _dot(r, p2dd)) / _dot(r, k4)
    rdd = -s4dd[:, None] * k4 - p2dd
    return {"p2": p2, "p2d": p2d, "p2dd": p2dd, "p3": f - s4[:, None] * k4, "k4": k4, "s4": s4, "s4dd": s4dd,
            "r": r, "rd": rd, "rdd": rdd, "s1": s1, "s1dd": s1dd, "theta": theta, "w": w, "wd": wd}


def _crank_frame(theta: np.ndarray) -> np.ndarray:
    """``Rz(theta)`` ``(P, 3, 3)``."""
    rz = np.zeros(theta.shape + (3, 3), complex)
    c, s = np.cos(theta), np.sin(theta)
    rz[:, 0, 0], rz[:, 0, 1], rz[:, 1, 0], rz[:, 1, 1], rz[:, 2, 2] = c, -s, s, c, 1.0
    return rz


def _motions(p: _Params, k: dict[str, np.ndarray]) -> list[tuple]:
    """Per body: mass, centre of mass ``G``, its acceleration, world inertia, omega, omega_dot (P rows)."""
    n, z = k["theta"].shape[0], np.array([0.0, 0.0, 1.0])
    rr = _dot(k["r"], k["r"])[:, None]
    u, udd = k["r"] / np.sqrt(rr), k["rdd"] / np.sqrt(rr)
    out = []
    m, com, inertia = _body(p, "crank")
    rz = _crank_frame(k["theta"])
    rho = np.einsum("nij,j->ni", rz, com)
    w1, wd1 = np.zeros((n, 3), complex) + z * k["w"], np.zeros((n, 3), complex) + z * k["wd"]
    acc = z * k["s1dd"][:, None] + _cross(wd1, rho) + _cross(w1, _cross(w1, rho))
    out.append((m, z * k["s1"][:, None] + rho, acc, rz @ inertia @ np.swapaxes(rz, 1, 2), w1, wd1))
    m, com, inertia = _body(p, "rod")  # axisymmetric, centre of mass on the axis (models/case.py)
    iw = inertia[1, 1] * np.eye(3) + (inertia[0, 0] - inertia[1, 1]) * np.einsum("ni,nj->nij", u, u)
    out.append((m, k["p2"] + com[0] * u, k["p2dd"] + com[0] * udd, iw,
                _cross(k["r"], k["rd"]) / rr, _cross(k["r"], k["rdd"]) / rr))  # zero spin
    m, com, inertia = _body(p, "slider")
    zero = np.zeros((n, 3), complex)
    out.append((m, k["p3"] + com, -k["s4dd"][:, None] * k["k4"], np.broadcast_to(inertia, (n, 3, 3)),
                zero, zero))
    return out


def _need(p: _Params, k: dict[str, np.ndarray]) -> list[tuple[np.ndarray, np.ndarray]]:
    """What the joints must supply to each body, force and moment about O (D'Alembert, eq. 62-64)."""
    gravity = np.array(p.raw.get("loads", {}).get("gravity", [0.0, 0.0, 0.0]), complex)
    out = []
    for m, g, acc, iw, om, omd in _motions(p, k):
        spin = np.einsum("nij,nj->ni", iw, om)
        ang = np.einsum("nij,nj->ni", iw, omd) + _cross(om, spin) + _cross(g, m * acc)
        out.append((m * acc - m * gravity, ang - _cross(g, m * gravity)))
    return out


def _reactions(p: _Params, k: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The reaction vectors of ``docs/conventions.md`` by the elimination of ``solve_reactions``."""
    need = _need(p, k)
    p2, p3, k4 = k["p2"], k["p3"], k["k4"]
    d = p3 - p2
    a2 = np.sqrt(_dot(d, d))[:, None]
    u = d / a2
    j3_perp = _cross(u, need[1][1] - _cross(p2, need[1][0])) / a2
    j2_perp = need[1][0] + j3_perp
    if p.given("loads.drive_torque"):
        lam = (p("loads.drive_torque") - need[0][1][:, 2] - _cross(p2, j2_perp)[:, 2]) / _cross(p2, u)[:, 2]
    else:
        lam = (_dot(need[2][0] - j3_perp, k4) - p("loads.slider_force")) / _dot(u, k4)
    j3 = j3_perp + lam[:, None] * u
    j2 = need[1][0] + j3
    j4f = need[2][0] - j3
    j1m = need[0][1] + _cross(p2, j2)
    return {"j1_f": need[0][0] + j2, "j1_m": j1m, "j2_f": j2, "j3_f": j3, "j4_f": j4f,
            "j4_m": need[2][1] - _cross(p3, j3) - _cross(p3, j4f),
            "slider_load": _dot(j4f, k4), "drive_torque": j1m[:, 2]}


def _outputs(p: _Params, table: ResultTable, where: dict[str, tuple[np.ndarray, ...]], mode: str) -> dict:
    """Every output of the design at its positions ``where`` (complex: value + i h derivative)."""
    rows = np.unique(np.concatenate([np.concatenate(w) for w in where.values()]))
    rows = rows[rows >= 0]
    k = _kinematics(p, np.radians(table["theta1_deg"][rows]), table["S4"][rows].astype(complex))
    react = _reactions(p, k)
    at = {int(r): i for i, r in enumerate(rows)}
    out: dict[str, complex] = {}
    hi, lo = (int(w[0]) for w in where["stroke"])
    out["stroke"] = k["s4"][at[hi]] - k["s4"][at[lo]] if min(hi, lo) >= 0 else complex("nan")
    for name, prefix in FORCES + MOMENTS:
        i = int(where[name][0][0])
        out[name] = np.sqrt(_dot(react[prefix][at[i]], react[prefix][at[i]])) if i >= 0 else complex("nan")
    name, column = SOLVED_LOAD[mode]
    i = int(where[name][0][0])
    value = react[column][at[i]] if i >= 0 else complex("nan")
    out[name] = value * np.sign(value.real)
    return out


def closed_form_sensitivities(case: Case, spec: Spec, table: ResultTable) -> dict[str, dict[str, float]]:
    """``values[output][key]``: d output / d key at the nominal ``case``, at the peaks of the solver's
    ``table``."""
    mode = case.loads.mode
    where = {name: tuple(w[:1] for w in idx) for name, idx in peak_positions([table], mode).items()}
    values: dict[str, dict[str, float]] = {n: {} for n in output_names(mode)}
    for d, key in enumerate(spec.keys):
        out = _outputs(_Params(case, spec, d), table, where, mode)
        for name in values:
            values[name][key] = float(out[name].imag / STEP)
    return values
