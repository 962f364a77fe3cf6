"""Single-loop linkages as rows of a link-joint parameter table (thesis Table 1).

Row ``i`` of the table carries frame {i} to frame {i+1} by

.. math:: \\hat T_i = Z(\\theta_i + \\varepsilon S_i)\\, Y(\\eta_i)\\, X(\\alpha_i + \\varepsilon a_i)

(thesis eq. 1-4), and the loop closes when
:math:`\\hat T_1 \\hat T_2 \\cdots \\hat T_n = \\hat I` (eq. 5).  Each of
:math:`\\theta, S, \\eta, \\alpha, a` is a constant, a prescribed input, a
per-position parameter (a constant that differs between the cases of a batch)
or an unknown.  A *spherical* row replaces :math:`Z(\\theta)Y(\\eta)` by a free rotation
matrix ``R`` (three unknowns): the thesis's Z-Y angles of a ball joint (eq. 2-3)
are singular at some poses and cannot represent the rod's spin, a rotation
state cannot fail there.

Each input or unknown contributes an *elementary screw*: the line of the axis
it turns about (or, times :math:`\\varepsilon`, the direction it slides
along), in world coordinates.  These are the operators of eq. (8)-(17):
:math:`\\hat H_i = \\hat P \\hat Q \\hat P^T` is the cross-product matrix of the
screw :math:`\\hat P \\hat e`.

The batch axis is the leading axis ``n`` of every array (crank positions and
cases together).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from dualmech.core.dual import (
    Dual,
    from_pose,
    identity,
    norm,
    origin,
    rot_x,
    rot_y,
    rot_z,
    scalar_type,
    skew,
    vee,
)

_FIELDS = ("theta", "s", "eta", "alpha", "a")


@dataclass(frozen=True)
class Var:
    """A slot of the table filled per position: a prescribed ``input`` (it moves, so it has a
    rate and a screw), a ``param`` (constant in time, e.g. a link length that differs
    between batched cases) or an ``unknown``."""

    kind: str  # "input", "param" or "unknown"
    name: str

    def __post_init__(self) -> None:
        if self.kind not in ("input", "param", "unknown"):
            raise ValueError(f"Var.kind: expected 'input', 'param' or 'unknown', got {self.kind!r}")


def inp(name: str) -> Var:
    """A prescribed input variable (its values are given per position)."""
    return Var("input", name)


def par(name: str) -> Var:
    """A per-position constant (no rate): its values are given with the inputs."""
    return Var("param", name)


def unk(name: str) -> Var:
    """An unknown joint variable (solved for)."""
    return Var("unknown", name)


@dataclass(frozen=True)
class Row:
    """One row of the link-joint table; each field is a float constant or a :class:`Var`.

    ``spherical=True`` makes the joint a ball: ``theta``, ``s`` and ``eta`` must be 0
    and the joint rotation is a free rotation state with three unknowns.
    """

    name: str
    theta: float | Var = 0.0
    s: float | Var = 0.0
    eta: float | Var = 0.0
    alpha: float | Var = 0.0
    a: float | Var = 0.0
    spherical: bool = False

    def __post_init__(self) -> None:
        if self.spherical and any(getattr(self, f) != 0.0 for f in ("theta", "s", "eta")):
            raise ValueError(f"row {self.name}: a spherical row has theta = s = eta = 0")


@dataclass(frozen=True)
class Loop:
    """A closed chain of table rows, frame {1} = ground.

    Attributes
    ----------
    rows : tuple of Row
    spin_gauges : tuple of int
        Indices of spherical rows whose link (the one the row carries) ends in
        another spherical row, so it could spin freely about the line joining the
        two ball centres.  The gauge fixes that spin: the link's angular velocity
        and acceleration have no component along that line.
    length_scale : str
        Name of the parameter (or input) whose value makes the dual
        (translational) residual dimensionless at each position.
    """

    rows: tuple[Row, ...]
    spin_gauges: tuple[int, ...] = ()
    length_scale: str = ""
    unknowns: tuple[str, ...] = field(init=False)
    inputs: tuple[str, ...] = field(init=False)
    spherical_rows: tuple[int, ...] = field(init=False)

    def __post_init__(self) -> None:
        unknowns, inputs = [], []
        for row in self.rows:
            for f in _FIELDS:
                v = getattr(row, f)
                if isinstance(v, Var) and v.kind != "param":
                    (unknowns if v.kind == "unknown" else inputs).append(v.name)
        spherical = tuple(i for i, r in enumerate(self.rows) if r.spherical)
        for g in self.spin_gauges:
            if g not in spherical:
                raise ValueError(f"spin_gauges: row {g} is not spherical")
        object.__setattr__(self, "unknowns", tuple(unknowns))
        object.__setattr__(self, "inputs", tuple(inputs))
        object.__setattr__(self, "spherical_rows", spherical)

    @property
    def n_unknown(self) -> int:
        """Size of the tangent step: scalar unknowns + 3 per spherical row."""
        return len(self.unknowns) + 3 * len(self.spherical_rows)


@dataclass(frozen=True)
class LoopState:
    """Unknowns of a loop at ``n`` positions.

    ``scalars`` ``(n, len(loop.unknowns))`` in the order of ``loop.unknowns``;
    ``rotations`` ``(n, len(loop.spherical_rows), 3, 3)`` joint rotations of the
    spherical rows.
    """

    scalars: np.ndarray
    rotations: np.ndarray

    def take(self, index: np.ndarray | slice) -> "LoopState":
        return LoopState(self.scalars[index], self.rotations[index])

    def put(self, index: np.ndarray, other: "LoopState") -> "LoopState":
        """Copy with positions ``index`` replaced by ``other``."""
        s, r = self.scalars.copy(), self.rotations.copy()
        s[index], r[index] = other.scalars, other.rotations
        return LoopState(s, r)

    def retract(self, step: np.ndarray, loop: Loop) -> "LoopState":
        """Move by a tangent step ``(n, loop.n_unknown)``: scalars add, rotations turn.

        A spherical row's rotation turns as :math:`R \\leftarrow \\exp([\\delta]_\\times) R`
        (about the axes of the frame before the joint), which is the increment the
        screws of :func:`elementary_screws` describe.
        """
        k = len(loop.unknowns)
        scalars = self.scalars + step[:, :k]
        deltas = step[:, k:].reshape(step.shape[0], -1, 3)
        return LoopState(scalars, rodrigues(deltas) @ self.rotations)


def rodrigues(w: np.ndarray) -> np.ndarray:
    """Rotation matrix :math:`\\exp([w]_\\times)` for rotation vectors ``w`` ``(..., 3)``."""
    squared = np.add.reduce(w * w, axis=-1)[..., None, None]  # analytic in w (dual.scalar_type)
    small = np.abs(squared) < 1e-16
    safe = np.sqrt(np.where(small, 1.0, squared))
    a = np.where(small, 1.0 - squared / 6.0, np.sin(safe) / safe)
    b = np.where(small, 0.5 - squared / 24.0, (1.0 - np.cos(safe)) / safe**2)
    k = skew(w)
    return np.eye(3) + a * k + b * (k @ k)


def _value(v: float | Var, inputs: dict[str, np.ndarray], unknowns: dict[str, np.ndarray],
           n: int) -> np.ndarray:
    if isinstance(v, Var):
        return (unknowns if v.kind == "unknown" else inputs)[v.name]
    return np.full(n, float(v))


@dataclass(frozen=True)
class Screw:
    """An elementary screw of the chain at ``n`` positions.

    ``line`` is the dual vector of the motion per unit rate (a unit line for a
    rotation, :math:`\\varepsilon` times a unit direction for a slide); ``var`` is
    ``("input", name)``, ``("unknown", column)`` with its column in the tangent step;
    ``row`` is the table row; ``carrier`` is the number of screws before it in the
    chain whose motion carries it (screws of one spherical joint do not carry
    each other: their axes are fixed in the frame before the joint).
    """

    line: Dual
    var: tuple[str, str | int]
    row: int
    carrier: int


@dataclass(frozen=True)
class Chain:
    """The loop evaluated at ``n`` positions: frames, loop product and screws."""

    frames: list[Dual]  # frames[i] = T_1 ... T_i (frame {i+1} in world), i = 0..len(rows)-1
    closure: Dual  # B = T_1 ... T_n (thesis eq. 18)
    screws: list[Screw]
    scale: np.ndarray  # (n,) the loop's length scale at each position


def evaluate(loop: Loop, inputs: dict[str, np.ndarray], state: LoopState) -> Chain:
    """Frames, loop product and elementary screws of ``loop`` at every position.

    Parameters
    ----------
    inputs : dict of name -> ``(n,)`` array
        Values of the inputs and parameters.
    state : LoopState with ``n`` positions
    """
    n = state.scalars.shape[0]
    unknowns = {name: state.scalars[:, j] for j, name in enumerate(loop.unknowns)}
    prefix = identity((n,))
    frames, screws = [], []
    ball = 0
    for i, row in enumerate(loop.rows):
        first = len(screws)
        if row.spherical:
            for k in range(3):
                var = ("unknown", len(loop.unknowns) + 3 * ball + k)
                screws.append(Screw(prefix.column(k), var, i, first))
            rot = state.rotations[:, ball]
            prefix = Dual(prefix.re @ rot, prefix.du @ rot)
            ball += 1
        else:
            for field_name, slide in (("theta", False), ("s", True)):
                _add_screw(screws, getattr(row, field_name), prefix, 2, slide, i, first, loop)
            prefix = _turn(prefix, rot_z, row.theta, row.s, inputs, unknowns, n, first_row=i == 0)
            first = len(screws)
            _add_screw(screws, row.eta, prefix, 1, False, i, first, loop)
            prefix = _turn(prefix, rot_y, row.eta, 0.0, inputs, unknowns, n)
        first = len(screws)
        for field_name, slide in (("alpha", False), ("a", True)):
            _add_screw(screws, getattr(row, field_name), prefix, 0, slide, i, first, loop)
        prefix = _turn(prefix, rot_x, row.alpha, row.a, inputs, unknowns, n)
        frames.append(prefix)
    scale = inputs[loop.length_scale] if loop.length_scale else np.ones(n)
    return Chain(frames, prefix, screws, scale)


def _turn(prefix: Dual, builder, angle: float | Var, slide: float | Var, inputs, unknowns, n: int,
          first_row: bool = False) -> Dual:
    """``prefix @ builder(angle + eps slide)``, skipping the work that zero entries make needless.

    A constant zero angle makes the factor's primary part the identity, a constant
    zero slide makes its dual part vanish; the products then need 1 or 2 real 3x3
    products instead of 3 (the loop product dominates the solver's cost).
    """
    no_angle = not isinstance(angle, Var) and angle == 0.0
    no_slide = not isinstance(slide, Var) and slide == 0.0
    if no_angle and no_slide:
        return prefix
    factor = builder(Dual.of(_value(angle, inputs, unknowns, n), _value(slide, inputs, unknowns, n)))
    if first_row:
        return factor
    if no_slide:
        return Dual(prefix.re @ factor.re, prefix.du @ factor.re)
    if no_angle:
        return Dual(prefix.re, prefix.du + prefix.re @ factor.du)
    return prefix @ factor


def _add_screw(screws: list[Screw], v: float | Var, frame: Dual, axis: int, slide: bool,
               row: int, carrier: int, loop: Loop) -> None:
    if not isinstance(v, Var) or v.kind == "param":
        return
    line = frame.column(axis)
    if slide:
        line = Dual(np.zeros_like(line.re), line.re)
    var = ("input", v.name) if v.kind == "input" else ("unknown", loop.unknowns.index(v.name))
    screws.append(Screw(line, var, row, carrier))


def closure_error(chain: Chain, loop: Loop) -> np.ndarray:
    """Closure error :math:`\\hat e` with :math:`\\hat B \\approx \\exp([\\hat e]_\\times)`, ``(n, 6)``.

    Primary part: rotation error (rad); dual part: translation error divided by
    ``loop.length_scale``.  These are the skew parts of the thesis's
    :math:`\\hat B^T - \\hat I` entries (12), (13), (23) of eq. (20)-(21), taken
    symmetrically.
    """
    return np.concatenate([vee(chain.closure.re), vee(chain.closure.du) / chain.scale[:, None]], axis=-1)


def closure_residual(chain: Chain, loop: Loop) -> np.ndarray:
    """Size of :math:`\\hat B - \\hat I`, ``(n,)``: max-abs of the primary part and of the dual part over
    the length scale.

    Unlike :func:`closure_error` this also sees a loop product that is a rotation by
    :math:`\\pi` (zero skew part, not the identity) -- the spurious root that the
    thesis's diagonal terms of eq. (22) guard against.
    """
    b = chain.closure
    prim = np.abs(b.re - np.eye(3)).max(axis=(-1, -2))
    dual = np.abs(b.du).max(axis=(-1, -2)) / chain.scale
    return np.maximum(prim, dual)


def screw_jacobian(chain: Chain, loop: Loop) -> np.ndarray:
    """The unknowns' screws as columns, ``(n, 6, loop.n_unknown)``.

    Moving unknown ``j`` turns the loop product as :math:`d\\hat B = [\\hat s_j]_\\times \\hat B\\, dx_j`
    (eq. 11, with :math:`\\hat H_j = [\\hat s_j]_\\times` of eq. 12-17), so at closure
    (:math:`\\hat B = \\hat I`) the screws are the derivative of
    :func:`closure_error`; near closure the error is of the order of the residual,
    which keeps Newton quadratic.  Dual rows are divided by the length scale.
    """
    n = chain.closure.re.shape[0]
    jac = np.zeros((n, 6, loop.n_unknown), scalar_type(chain.closure.re, chain.closure.du))
    for s in chain.screws:
        if s.var[0] == "unknown":
            jac[:, :3, s.var[1]] = s.line.re
            jac[:, 3:, s.var[1]] = s.line.du / chain.scale[:, None]
    return jac


def gauge_rows(chain: Chain, loop: Loop) -> tuple[np.ndarray, np.ndarray]:
    """Spin-gauge equations: for each gauge, the link's rotation rate along its axis.

    Returns ``(rows, axes)``: ``rows`` ``(n, n_gauge, n_screws)`` holds
    :math:`u\\cdot s_j` for every screw ``j`` up to and including the gauged row (0
    after it), so ``rows @ rates`` is the link's angular velocity along ``u``;
    ``axes`` ``(n, n_gauge, 3)`` are the unit axes ``u`` (from the ball centre of the
    gauged row to the next one).
    """
    n = chain.closure.re.shape[0]
    kind = scalar_type(chain.closure.re, chain.closure.du)
    rows = np.zeros((n, len(loop.spin_gauges), len(chain.screws)), kind)
    axes = np.zeros((n, len(loop.spin_gauges), 3), kind)
    for g, r in enumerate(loop.spin_gauges):
        start = origin(chain.frames[r - 1]) if r > 0 else np.zeros((n, 3))
        end = origin(chain.frames[r])
        u = end - start
        u /= norm(u, keepdims=True)
        axes[:, g] = u
        for j, s in enumerate(chain.screws):
            if s.row <= r:
                rows[:, g, j] = np.einsum("ni,ni->n", u, s.line.re)
    return rows, axes


def frame_origins(chain: Chain) -> np.ndarray:
    """Origins of frames {2}..{n+1} in world coordinates, ``(n, len(rows), 3)``."""
    return np.stack([origin(f) for f in chain.frames], axis=1)


def pose(chain: Chain, i: int) -> tuple[np.ndarray, np.ndarray]:
    """Rotation ``(n, 3, 3)`` and origin ``(n, 3)`` of frame ``chain.frames[i]``."""
    f = chain.frames[i]
    return f.re, origin(f)


__all__ = [
    "Var", "inp", "par", "unk", "Row", "Loop", "LoopState", "Screw", "Chain", "evaluate", "closure_error",
    "closure_residual", "screw_jacobian", "gauge_rows", "frame_origins", "pose", "rodrigues", "from_pose",
]
