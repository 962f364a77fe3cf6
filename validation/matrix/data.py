"""An expanded validation matrix: its cases, sweeps and resolved tolerances, and the checks on its names.

:class:`Matrix` is what a run stores (``run.json``, :meth:`Matrix.to_dict` / :func:`matrix_from_dict`);
:mod:`~dualmech.validation.matrix.parse` builds it from a matrix file.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field, replace
from typing import Any

from dualmech.core.table import KINEMATIC_COLUMNS, REACTION_COLUMNS
from dualmech.models.case import Case, case_from_dict
from dualmech.models.inputs import show
from dualmech.models.kinds import SLIDER_CRANK, kind_of
from dualmech.validation.engines import ENGINES

#: Columns a matrix may compare, in report order. ``residual`` is each engine's own
#: closure residual and is reported, not compared; ``theta1_deg`` is the abscissa.
COMPARABLE: tuple[str, ...] = (
    tuple(c for c in KINEMATIC_COLUMNS if c != "theta1_deg") + ("transmission",) + REACTION_COLUMNS
)

#: Declared expectations a sweep may state (``expect = ...``), with what each means.
EXPECTATIONS: dict[str, str] = {"no_assembly": "every case assembles at no crank position, on every engine"}
#: Most cases one matrix may expand to (modes x sweep points): each runs on every engine,
#: and 1,000 cases of 360 positions take ~8 min on the slowest judge (MuJoCo simulation,
#: 1.3 ms per position, docs/performance.md) on one core.
MAX_MATRIX_CASES = 1000
#: Most crank positions of one case in a validation run: every engine's whole table of a case is
#: held, stored and compared at once (~30 columns x 4 engines x 8 bytes x this, well under 1 GiB
#: with Python's overheads); longer studies stream through ``dualmech solve`` in chunks.
MAX_VALIDATE_POSITIONS = 20_000
#: Longest name that becomes a file or folder name (matrix name, case ids), characters.
MAX_NAME_CHARS = 100
#: Longest description or sweep label, characters (one line of a report).
MAX_TEXT_CHARS = 2000
#: A name safe as one file or folder name on any system: starts with a letter or digit.
_FILE_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9.=+_-]*")
#: Base-case names of the thesis's worked example (its printed findings are about these).
THESIS_PRESETS: tuple[str, ...] = ("thesis/",)


class MatrixError(ValueError):
    """A matrix file or value that cannot be used; the message is one line."""


def check_file_name(key: str, name: Any) -> str:
    """``name`` if it is safe as one file or folder name, else a one-line :class:`MatrixError`.

    Safe: a non-empty string of at most :data:`MAX_NAME_CHARS` letters, digits and
    ``. _ + - =``, starting with a letter or digit, without ``..``.  So no path
    separator, no absolute path, no parent folder, no NUL or control character, no
    hidden file, nothing an option parser could take for an option.
    """
    if not isinstance(name, str) or not name:
        raise MatrixError(f"{key}: expected a non-empty name, got {show(name)}")
    bad = next((c for c in name if not (c.isascii() and (c.isalnum() or c in ".=+_-"))), None)
    why = (
        f"{len(name)} characters, more than {MAX_NAME_CHARS}"
        if len(name) > MAX_NAME_CHARS
        else f"{bad!r} is not allowed"
        if bad is not None
        else "'..' is not allowed"
        if ".." in name
        else "it must start with a letter or digit"
        if not _FILE_NAME.fullmatch(name)
        else ""
    )
    if why:
        raise MatrixError(
            f"{key}: {show(name)} cannot be a file or folder name: {why} (use letters, digits "
            f"and . _ + - =, at most {MAX_NAME_CHARS} characters)"
        )
    return name


def check_engines(engines: tuple[str, ...], reference: str) -> None:
    for e in engines:
        if e not in ENGINES:
            raise MatrixError(f"engines: {show(e)} is not an engine (valid: {', '.join(ENGINES)})")
    if reference not in engines:
        raise MatrixError(f"reference: {show(reference)} must be one of the engines {list(engines)}")
    if len(engines) < 2:
        raise MatrixError(f"engines: {list(engines)} has no judge beside the reference {reference!r}")


def check_expect(key: str, value: Any) -> str | None:
    """A declared expectation: ``None`` or a key of :data:`EXPECTATIONS`."""
    if value is not None and (not isinstance(value, str) or value not in EXPECTATIONS):
        raise MatrixError(
            f"{key}: {show(value)} is not an expectation (valid: "
            + "; ".join(f"{k!r}: {v}" for k, v in EXPECTATIONS.items())
            + ")"
        )
    return value


@dataclass(frozen=True)
class MatrixCase:
    """One concrete case of a matrix.

    Attributes
    ----------
    id : str
        Unique, file-name safe identifier, e.g. ``"torque_a4=10_S1=3.5"``.
    raw : dict
        The case table (as :func:`~dualmech.models.case.case_from_dict` takes it).
    mode : str
        Load mode name (``"torque"``, ``"force"``, or the base case's own mode).
    values : dict[str, Any]
        The dotted keys that differ from the base case, and their values.
    sweeps : tuple[str, ...]
        Names of the sweeps this case belongs to.
    labels : dict[str, str]
        Legend text per sweep name (only the keys that sweep varies, e.g. ``"a4=10"``;
        the base label for the base case).
    is_base : bool
        Whether this is the base case (in its load mode).
    expect : str or None
        The declared expectation of its sweep (a key of :data:`EXPECTATIONS`, e.g.
        ``"no_assembly"``), or ``None``: the case is expected to assemble.
    engines : tuple of str
        The engines that solve this case (a linkage's simulation solves only some; the matrix runs those of
        its own, :meth:`Matrix.engines_of`); empty: all.
    """

    id: str
    raw: dict
    mode: str
    values: dict[str, Any]
    sweeps: tuple[str, ...]
    labels: dict[str, str]
    is_base: bool
    expect: str | None = None
    engines: tuple[str, ...] = ()

    @property
    def is_slider_crank(self) -> bool:
        """Whether the case is a slider crank (:func:`~dualmech.models.kinds.kind_of` of its table), whose
        gate, columns and report sections are the slider crank's; every other kind's run by its table spec."""
        return kind_of(self.raw) == SLIDER_CRANK

    def case(self) -> Case:
        """Build the :class:`~dualmech.models.case.Case`."""
        return case_from_dict(self.raw)


@dataclass(frozen=True)
class Sweep:
    """A named family of cases drawn together (e.g. the a4 sweep), per load mode."""

    name: str
    label: str
    keys: tuple[str, ...]  # the dotted keys it varies
    case_ids: dict[str, tuple[str, ...]]  # load mode -> case ids, base case first


@dataclass(frozen=True)
class ResolvedTolerance:
    """The tolerance applied to one (judge, quantity): its table name, value and reason."""

    name: str
    value: float
    reason: str


@dataclass(frozen=True)
class Matrix:
    """An expanded validation matrix (see the module docstring for the file format)."""

    name: str
    description: str
    source: str
    reference: str
    engines: tuple[str, ...]
    quantities: tuple[str, ...]
    modes: tuple[str, ...]
    cases: tuple[MatrixCase, ...]
    sweeps: tuple[Sweep, ...]
    labels: dict[str, str]
    tolerances: dict[str, dict[str, ResolvedTolerance]] = field(repr=False)  # judge -> quantity -> tol
    base: str = ""  # the base case as the file names it (a preset name or a case file)

    @property
    def of_thesis(self) -> bool:
        """Whether the base case is one of the thesis's presets (its findings then apply)."""
        return self.base.startswith(THESIS_PRESETS)

    @property
    def judges(self) -> tuple[str, ...]:
        """Engines compared against the reference."""
        return tuple(e for e in self.engines if e != self.reference)

    def engines_of(self, case: MatrixCase) -> tuple[str, ...]:
        """The engines that run ``case``: its own (:attr:`MatrixCase.engines`) or every one of the matrix."""
        return tuple(e for e in self.engines if e in case.engines) if case.engines else self.engines

    def tolerance(self, engine: str, quantity: str) -> ResolvedTolerance:
        """Tolerance for ``quantity`` (a column or ``"stroke"``) of judge ``engine``."""
        try:
            return self.tolerances[engine][quantity]
        except KeyError:
            raise MatrixError(f"tolerance: no entry for engine {engine!r}, quantity {quantity!r}") from None

    def case_by_id(self, case_id: str) -> MatrixCase:
        """The case named ``case_id``."""
        for c in self.cases:
            if c.id == case_id:
                return c
        raise MatrixError(f"case: {case_id!r} is not in matrix {self.name!r}")

    def with_engines(self, engines: tuple[str, ...]) -> "Matrix":
        """The same matrix run on ``engines`` (must include the reference; each judge with its tolerances,
        which the matrix keeps for every engine it may run: :attr:`tolerances` may hold more)."""
        engines = tuple(dict.fromkeys(engines))
        check_engines(engines, self.reference)
        missing = [e for e in engines if e != self.reference and not self.tolerances.get(e)]
        if missing:
            raise MatrixError(f"engines: {missing[0]!r} has no tolerances in matrix {self.name!r}")
        return replace(self, engines=engines)

    def to_dict(self) -> dict:
        """JSON-ready form; :func:`matrix_from_dict` reads it back (used by stored runs)."""
        return {
            "name": self.name,
            "description": self.description,
            "source": self.source,
            "base": self.base,
            "reference": self.reference,
            "engines": list(self.engines),
            "quantities": list(self.quantities),
            "modes": list(self.modes),
            "labels": dict(self.labels),
            "cases": [
                {
                    "id": c.id,
                    "raw": c.raw,
                    "mode": c.mode,
                    "values": c.values,
                    "sweeps": list(c.sweeps),
                    "labels": c.labels,
                    "is_base": c.is_base,
                    "expect": c.expect,
                    **({"engines": list(self.engines_of(c))} if c.engines else {}),
                }
                for c in self.cases
            ],
            "sweeps": [
                {
                    "name": s.name,
                    "label": s.label,
                    "keys": list(s.keys),
                    "case_ids": {m: list(ids) for m, ids in s.case_ids.items()},
                }
                for s in self.sweeps
            ],
            "tolerances": {
                e: {q: {"name": t.name, "value": t.value, "reason": t.reason} for q, t in qs.items()}
                for e, qs in self.tolerances.items()
            },
        }


def matrix_from_dict(d: dict) -> Matrix:
    """Inverse of :meth:`Matrix.to_dict`.

    The names that become file or folder names, the engines and the quantities are checked again (a
    stored run may have been edited; its types are checked by
    :data:`~dualmech.validation.rundir.MATRIX_SCHEMA`); a stored run without ``expect`` (older) reads as
    ``None``.
    """
    check_file_name("name", d["name"])
    check_engines(tuple(d["engines"]), d["reference"])
    unknown = [q for q in d["quantities"] if q not in COMPARABLE]
    if unknown:
        raise MatrixError(f"quantities: {show(unknown[0])} is not a comparable column (valid: "
                          f"{', '.join(COMPARABLE)})")
    for c in d["cases"]:
        check_file_name("case id", c["id"])
        check_expect(f"case {c['id']}.expect", c.get("expect"))
        alien = [e for e in c.get("engines", ()) if e not in d["engines"]]
        if alien:
            raise MatrixError(f"case {c['id']}.engines: {show(alien[0])} is not one of the matrix's engines "
                              f"({', '.join(d['engines'])})")
    return Matrix(
        name=d["name"],
        description=d["description"],
        source=d["source"],
        base=d.get("base", ""),
        reference=d["reference"],
        engines=tuple(d["engines"]),
        quantities=tuple(d["quantities"]),
        modes=tuple(d["modes"]),
        cases=tuple(
            MatrixCase(
                c["id"],
                c["raw"],
                c["mode"],
                c["values"],
                tuple(c["sweeps"]),
                dict(c["labels"]),
                c["is_base"],
                c.get("expect"),
                tuple(c.get("engines", ())),
            )
            for c in d["cases"]
        ),
        sweeps=tuple(
            Sweep(
                s["name"], s["label"], tuple(s["keys"]), {m: tuple(ids) for m, ids in s["case_ids"].items()}
            )
            for s in d["sweeps"]
        ),
        labels=dict(d["labels"]),
        tolerances={
            e: {q: ResolvedTolerance(t["name"], float(t["value"]), t["reason"]) for q, t in qs.items()}
            for e, qs in d["tolerances"].items()
        },
    )
