"""Shaking-force balancing of the slider crank (Sinatra–Angeles, "Dynamic balancing", eq. 44–75).

The frame feels the *shaking force* and *shaking moment*: minus the wrench the
ground applies to the moving links, here ``-(j1 + j4)`` with the joint-4 moment
carried from ``P3`` to ``O``.  The sum of all ground reactions is
:math:`\\sum_b m_b a_b - m g` and its moment about ``O`` is
:math:`\\sum_b \\dot H_{b,O} - \\sum_b c_b\\times m_b g`, whatever the drive torque or
slider load (both are parts of the ground's action), so

.. math:: f_{shake} = m g - m\\ddot c, \\qquad m c = \\sum_b m_b c_b

vanishes (but for the static weight) iff the mass centre ``c`` of the moving
links is stationary (eq. 53–55).

**Balancing conditions, derived.**  With the normalized mass-centre
coordinates of eq. (73), :math:`r_1 = \\xi_1 r_{12} + \\eta_1 E r_{12}` (crank, from
the pivot) and :math:`r_2 = \\xi_2 r_{23} + \\eta_2 E r_{23}` (rod, from the crank
pin), and :math:`\\mu_i = m_i/m_3`, eq. (62) reads
:math:`A r_{12} + B\\, r_\\theta r_{23} = 0` for every crank angle, with
:math:`A = (1 + \\mu_2 + \\mu_1\\xi_1)\\mathbf 1 + \\mu_1\\eta_1 E` and
:math:`B = (1 + \\mu_2\\xi_2)\\mathbf 1 + \\mu_2\\eta_2 E`.  At the two dead
centres :math:`r_s = 0`, so :math:`r_{12} + r_\\theta r_{23} = 0` and
:math:`(A - B) r_{12} = 0`, hence ``A = B`` (eq. 67–68 are necessary, not only
convenient); then :math:`A(r_{12} + r_\\theta r_{23}) = -r_s A j = 0` at any other
angle gives ``A = 0`` (eq. 71–72).  So ``A = B = 0``:

.. math:: \\xi_1 = -\\frac{1 + \\mu_2}{\\mu_1},\\quad \\eta_1 = 0,\\qquad
          \\xi_2 = -\\frac{1}{\\mu_2},\\quad \\eta_2 = 0.

The paper prints :math:`\\xi_2 = +1/\\mu_2` (eq. 75), which contradicts its own
eq. (67) and (71): eq. (67) with (71) gives :math:`\\mu_2\\xi_2 = \\mu_1\\xi_1 + \\mu_2 = -1`.
Physically: the rod's mass centre lies a distance :math:`a_2/\\mu_2` *behind*
the crank pin, so that rod and slider together have their mass centre at the
pin, and the crank's lies :math:`a_1(1+\\mu_2)/\\mu_1` behind the pivot, so that
the whole linkage has it on the crank axis.

**In space** (the generalized slider crank) the same argument holds with the
rod's mass centre on its axis, :math:`c_2 = P_2 + \\xi_2(P_3 - P_2)`, and the
slider translating: with these :math:`\\xi_1, \\xi_2` the combined mass centre of
rod and slider is :math:`P_2` (+ a constant), and the whole linkage's is on the
crank axis at height :math:`S_1` (+ a constant).  The offsets ``a4``,
``alpha4`` and a constant ``S1`` therefore change nothing in the force
balance; an axial motion :math:`S_1(\\theta)` leaves an axial shaking force
:math:`-m\\ddot S_1` that no mass placement on the moving links can cancel.
The shaking moment is not balanced by mass redistribution (the paper's
introduction); with offsets it gains components about x and y.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dualmech.core.motion import CrankState
from dualmech.core.status import Status
from dualmech.models.case import Case, with_loads
from dualmech.models.slider_crank.analysis import analyze


@dataclass(frozen=True)
class BalancingPoint:
    """Normalized mass-centre coordinates of crank and rod (Sinatra–Angeles eq. 73).

    ``xi1, eta1``: crank mass centre in units of :math:`a_1`, along the crank
    (toward the pin) and at +90° to it; ``xi2, eta2``: rod mass centre from the
    crank pin in units of :math:`a_2`, along the rod (toward the slider pin) and
    across it.  In the body frames of ``docs/conventions.md``:
    ``crank.com = (xi1 a1, eta1 a1, *)`` and ``rod.com = (xi2 a2, 0, 0)``.
    """

    xi1: float
    eta1: float
    xi2: float
    eta2: float


def _ratio(name: str, value: float) -> float:
    if isinstance(value, bool) or not np.isfinite(value) or value <= 0:
        raise ValueError(f"{name}: expected a positive mass ratio, got {value!r}")
    return float(value)


def balancing_point(mu1: float, mu2: float) -> BalancingPoint:
    """Force-balancing coordinates for :math:`\\mu_1 = m_1/m_3`, :math:`\\mu_2 = m_2/m_3`
    (eq. 74–75, derived).

    .. math:: \\xi_1 = -(1+\\mu_2)/\\mu_1,\\; \\xi_2 = -1/\\mu_2,\\; \\eta_1 = \\eta_2 = 0

    (eq. 75 prints :math:`\\xi_2 = +1/\\mu_2`; see the module docstring).
    """
    mu1, mu2 = _ratio("mu1", mu1), _ratio("mu2", mu2)
    return BalancingPoint(-(1.0 + mu2) / mu1, 0.0, -1.0 / mu2, 0.0)


def mass_ratios(case: Case) -> tuple[float, float]:
    """:math:`(\\mu_1, \\mu_2) = (m_1/m_3, m_2/m_3)` of a case (eq. 59)."""
    b = case.bodies
    return b.crank.mass / b.slider.mass, b.rod.mass / b.slider.mass


def design_point(case: Case) -> BalancingPoint:
    """The normalized mass-centre coordinates of a case's crank and rod."""
    a1, a2 = case.geometry.crank_length, case.geometry.rod_length
    c1, c2 = case.bodies.crank.com, case.bodies.rod.com
    return BalancingPoint(c1[0] / a1, c1[1] / a1, c2[0] / a2, c2[1] / a2)


def balanced_case(case: Case, mu1: float | None = None, mu2: float | None = None) -> Case:
    """``case`` with crank and rod mass centres at the balancing point (explicit ``[bodies.*]``).

    Parameters
    ----------
    case : Case
    mu1, mu2 : float, optional
        Mass ratios to design for; default the case's own.  A given ratio sets
        the crank (rod) mass to :math:`\\mu m_3` and scales its central inertia
        by the same factor; otherwise mass and central inertia are kept.  Only
        the mass centres move (the crank's axial offset is kept): the central
        inertias stand for the counterweighted links as given.
    """
    own1, own2 = mass_ratios(case)
    mu1 = own1 if mu1 is None else _ratio("mu1", mu1)
    mu2 = own2 if mu2 is None else _ratio("mu2", mu2)
    point = balancing_point(mu1, mu2)
    b, g = case.bodies, case.geometry
    m3 = b.slider.mass
    m1, m2 = mu1 * m3, mu2 * m3
    updates = {
        "name": f"{case.name}-balanced",
        "bodies.crank.mass": m1,
        "bodies.crank.com": [point.xi1 * g.crank_length, point.eta1 * g.crank_length, float(b.crank.com[2])],
        "bodies.crank.inertia": (b.crank.inertia * (m1 / b.crank.mass)).tolist(),
        "bodies.rod.mass": m2,
        "bodies.rod.com": [point.xi2 * g.rod_length, 0.0, 0.0],
        "bodies.rod.inertia": (b.rod.inertia * (m2 / b.rod.mass)).tolist(),
    }
    return case.with_values(updates)


@dataclass(frozen=True)
class Shaking:
    """Shaking force and moment at ``n`` crank positions (world axes).

    ``force`` ``(n, 3)``: force of the moving links on the frame; ``moment``
    ``(n, 3)``: their moment on the frame about the world origin O;
    ``theta`` ``(n,)`` crank angle (rad); ``status`` the in-house status words.
    """

    theta: np.ndarray
    force: np.ndarray
    moment: np.ndarray
    status: np.ndarray


def shaking(case: Case, crank: CrankState | None = None) -> Shaking:
    """Shaking force and moment of ``case`` over its crank positions, from the in-house reactions.

    The reactions are solved with the slider load given (0): the sums are the
    same in either load mode (module docstring), and slider-load mode is regular
    at dead centres.
    """
    regular = with_loads(case, drive_torque=None, slider_force=0.0)
    an = analyze(regular, crank)
    r = an.reactions
    given = (an.status == Status.OK)[:, None]  # reactions of positions that do not assemble are not answers
    with np.errstate(invalid="ignore"):  # rows without an answer carry NaN (inf - inf too): not results
        force = np.where(given, -(r.j1_force + r.j4_force), np.nan)
        moment = np.where(given, -(r.j1_moment + r.j4_moment + np.cross(an.p3, r.j4_force)), np.nan)
    return Shaking(an.crank.theta, force, moment, an.status)


def shaking_force_polar(case_before: Case, case_after: Case, path: str | Path) -> Path:
    """Polar plot of the shaking force over the cycle, before and after balancing; saved as PNG.

    Each curve is the tip of the shaking force's component normal to the crank
    axis (angle from world x, magnitude), at the case's crank positions, speed
    and acceleration; the legend gives each design's peak :math:`|f|` (all three
    components).  Returns the path written.
    """
    forces = tuple(assembled_force(shaking(c)) for c in (case_before, case_after))
    return draw_shaking_force_polar(forces, case_before.name, case_before.units, path)


def assembled_force(s: Shaking) -> np.ndarray:
    """The shaking force ``(m, 3)`` at the ``m`` positions of ``s`` whose status is ``ok``."""
    return s.force[s.status == Status.OK]


def draw_shaking_force_polar(forces: tuple[np.ndarray, np.ndarray], name: str, units: str,
                             path: str | Path) -> Path:
    """Draw :func:`shaking_force_polar` from given shaking forces ``(m, 3)``: original, then balanced.

    ``name`` and ``units``: the case's, for the title.  Returns the path written.
    """
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6.0, 6.0))
    ax = fig.add_subplot(projection="polar")
    for f, label, style in zip(forces, ("original", "balanced"), ("-", "--")):
        peak = float(np.linalg.norm(f, axis=1).max())
        ang = np.arctan2(f[:, 1], f[:, 0])
        ax.plot(ang, np.hypot(f[:, 0], f[:, 1]), style, lw=1.5, label=f"{label}: peak |f| = {peak:.3g}")
    ax.set_title(f"shaking force on the frame, {name}\n({units}, x-y components)", fontsize=10)
    ax.legend(loc="lower left", bbox_to_anchor=(0.0, -0.15), fontsize=9)
    path = Path(path)
    fig.savefig(path, dpi=120, bbox_inches="tight")
    return path
