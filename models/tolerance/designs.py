"""Sampled designs as the compiled kernel's arrays, solved in blocks of bounded memory, reduced per design.

A chunk of sampled designs (``x`` ``(m, k)``, the varied keys' values) is never turned into a
table per design.  Its geometry ``(m, 4)``, body and load arrays (the layout of
:func:`~dualmech.models.slider_crank.kernel.case_arrays`) and crank states go straight to
:func:`~dualmech.models.slider_crank.kernel.start_positions`, in blocks of whole designs at
up to :data:`~dualmech.models.slider_crank.kernel.CHUNK_POSITIONS` positions (a design with more
positions than that is split along its positions), one output buffer reused; each block is
folded into the per-design outputs by :class:`~dualmech.models.tolerance.outputs.DesignReduction`.

Two ways to the arrays, chosen by the keys the SPEC varies:

* **Arrays only** when every varied key is one of :data:`ARRAY_KEYS` (the slider axis, the
  crank's axial shift, the given load: none of them enters the bodies or the crank's rates).
  The nominal case's body arrays and crank state are shared; the sampled values are written
  into their columns.  Validation stays the case loader's
  (:func:`~dualmech.models.case.case_from_dict`, no range restated here): it loads the
  corners of the box the chunk's values span (``2^k`` designs, ``k`` varied keys).  The loader's
  checks on these keys with the other keys fixed are intervals of each key (its ``Range`` and
  the proportions bound ``|length| <= MAX_LENGTH_RATIO x min(a1, a2)``), so the set they accept
  is convex and a box whose corners load holds only loadable designs.  If a corner fails, every
  design of the chunk is loaded in turn and the first that fails is named (the loader's message).
* **Through the case loader** otherwise (a length, a body property or the crank speed varies):
  each design is built by :func:`~dualmech.models.tolerance.spec.design_case` (~0.35 ms a design),
  its arrays by ``case_arrays``, its crank state by its own motion.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Callable

import numpy as np

from dualmech.core.motion import CrankState
from dualmech.models.case import Case, CaseError
from dualmech.models.slider_crank.kernel import (
    CHUNK_POSITIONS,
    OUT_COLUMNS,
    case_arrays,
    chain_aligned,
    start_positions,
)
from dualmech.models.tolerance.outputs import DesignReduction, needed_columns
from dualmech.models.tolerance.spec import Spec, design_case

#: Keys written straight into the kernel's arrays: (array, column) they set.
ARRAY_KEYS: dict[str, tuple[str, int]] = {
    "geometry.slider_offset": ("geo", 2),
    "geometry.slider_twist_deg": ("geo", 3),
    "geometry.crank_axial_shift": ("shift", 0),
    "loads.drive_torque": ("given", 4),
    "loads.slider_force": ("given", 5),
}
_CRANK_FIELDS = ("theta", "s", "theta_dot", "s_dot", "theta_ddot", "s_ddot")
#: Designs folded into the outputs at a time: their rows of the kernel's buffer (~16 x 360 x 31 x 8 bytes)
#: stay in the CPU's cache across the ~25 column operations of the reduction (40 % faster than all at once).
REDUCE_DESIGNS = 16


@dataclass(frozen=True)
class DesignArrays:
    """``m`` designs as the kernel's arrays.

    ``geo`` ``(m, 4)`` (a1, a2, a4, alpha4 [rad]); ``bodies`` the per-design body and load arrays of
    :func:`~dualmech.models.slider_crank.kernel.case_arrays`; ``angles_deg`` ``(p,)`` the crank
    angles every design is analysed at; ``crank(designs, lo, hi)`` the crank states ``(6, d (hi - lo))``
    of designs ``designs`` (a slice) at positions ``lo .. hi - 1``, design-major.
    """

    geo: np.ndarray
    bodies: tuple
    angles_deg: np.ndarray
    crank: Callable[[slice, int, int], np.ndarray]

    def __len__(self) -> int:
        return self.geo.shape[0]


def design_name(index: int) -> str:
    """Name of sampled design ``index`` (its row in ``samples.csv``)."""
    return f"design-{index:07d}"


def _named(first: int, index: int, err: CaseError) -> CaseError:
    return CaseError(f"{design_name(first + index)} (sampled from the SPEC): {err}")


def _load_all(case: Case, spec: Spec, x: np.ndarray, first: int) -> list[Case]:
    """Every design through the case loader; the first refused is a :class:`CaseError` naming it."""
    designs = []
    for i, row in enumerate(x):
        try:
            designs.append(design_case(case, spec, row, "design"))
        except CaseError as err:
            raise _named(first, i, err) from None
    return designs


def _check_corners(case: Case, spec: Spec, x: np.ndarray, first: int) -> None:
    """Load the corners of the box of ``x`` (module docstring); if one fails, load every design."""
    sides = [np.unique([lo, hi]) for lo, hi in zip(x.min(axis=0), x.max(axis=0))]
    try:
        for corner in itertools.product(*sides):
            design_case(case, spec, np.array(corner), "corner")
    except CaseError:
        _load_all(case, spec, x, first)


def _stack(states: list[CrankState]) -> np.ndarray:
    return np.stack([np.concatenate([getattr(s, f) for s in states]) for f in _CRANK_FIELDS])


def design_arrays(case: Case, spec: Spec, x: np.ndarray, first: int = 0) -> DesignArrays:
    """The designs ``x`` ``(m, k)`` (values of ``spec.keys``, key units) of ``case`` as kernel arrays.

    ``first`` is the index of the first design in the study (it names a design the loader refuses).
    Raises :class:`~dualmech.models.case.CaseError` naming the design and the key.
    """
    m = x.shape[0]
    angles = np.asarray(case.motion.angles_deg, dtype=float)
    if not all(key in ARRAY_KEYS for key in spec.keys):
        designs = _load_all(case, spec, x, first)
        geo, bodies = case_arrays(designs)

        def crank_of_cases(rows: slice, lo: int, hi: int) -> np.ndarray:
            states = [d.own_crank_states(angles[lo:hi]) for d in designs[rows]]
            return _stack(states)

        return DesignArrays(geo, bodies, angles, crank_of_cases)
    _check_corners(case, spec, x, first)
    geo, nominal = case_arrays([case])
    geo = np.repeat(geo, m, axis=0)
    bodies = [np.repeat(b, m, axis=0) for b in nominal]
    shift = np.full(m, case.geometry.crank_axial_shift)
    for j, key in enumerate(spec.keys):
        where, col = ARRAY_KEYS[key]
        if where == "geo":
            geo[:, col] = np.radians(x[:, j]) if key.endswith("_deg") else x[:, j]
        elif where == "given":
            bodies[col][:] = x[:, j]
        else:
            shift[:] = x[:, j]
    base = _stack([case.motion.state(0.0)])  # S1 = shift + the axial motion (models/case.py, motion)

    def crank_of_shifts(rows: slice, lo: int, hi: int) -> np.ndarray:
        block = np.repeat(base[:, None, lo:hi], len(shift[rows]), axis=1)
        block[1] = shift[rows, None] + base[1, lo:hi]
        return block.reshape(6, -1)

    return DesignArrays(geo, tuple(bodies), angles, crank_of_shifts)


def analyse_designs(designs: DesignArrays, mode: str,
                    chunk_positions: int = CHUNK_POSITIONS) -> dict[str, np.ndarray]:
    """Every output of every design (:func:`~dualmech.models.tolerance.outputs.design_outputs`), ``(m,)``.

    Blocks of whole designs, or of one design's positions, of at most ``chunk_positions``
    positions, into one reused buffer: memory is bounded by the block, not the design count.
    """
    m, p = len(designs), designs.angles_deg.size
    per_block = max(1, chunk_positions // max(p, 1))
    step = min(p, chain_aligned(chunk_positions))  # a split begins a chain of warm starts
    buffer = np.empty((len(OUT_COLUMNS), min(per_block * p, max(step, 1))))
    reduction = DesignReduction(m, mode)
    names = needed_columns(mode)
    for d0 in range(0, m, per_block):
        rows = slice(d0, min(m, d0 + per_block))
        d = rows.stop - rows.start
        geo = np.ascontiguousarray(designs.geo[rows])
        bodies = tuple(np.ascontiguousarray(b[rows]) for b in designs.bodies)
        for lo in range(0, p, step):
            hi = min(p, lo + step)
            case_of = np.repeat(np.arange(d, dtype=np.int64), hi - lo)
            index = np.tile(np.arange(lo, hi), d)
            chunk = start_positions(designs.crank(rows, lo, hi), case_of, geo, bodies, buffer, index).result()
            columns = {c: chunk.columns[c].reshape(d, hi - lo) for c in names}
            codes = chunk.status.reshape(d, hi - lo)
            for r0 in range(0, d, REDUCE_DESIGNS):
                part = slice(r0, r0 + REDUCE_DESIGNS)
                reduction.add(rows.start + r0, {c: v[part] for c, v in columns.items()}, codes[part])
    return reduction.result()
