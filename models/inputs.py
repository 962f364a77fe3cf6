"""Input checks of a case file: the stated range of every number, and one-line errors.

Every number of a case (and of the commands that take one) is checked against a stated
:class:`Range` before it is used (``docs/conventions.md``, "Input ranges", gives the table
and the reasons).  Errors are :class:`CaseError` (a ``ValueError``) with a one-line message
that names the key, the value received and what would be valid; :func:`show` cuts a value to
a short ``repr`` for such a message.
"""

from __future__ import annotations

import math
import reprlib
import unicodedata
from dataclasses import dataclass
from typing import Any, Callable, Collection, Mapping

import numpy as np


class CaseError(ValueError):
    """A case file or case value that cannot be used; the message is one line."""


# ----------------------------------------------------------------------------- limits

#: Largest magnitude of any dimensional number of a case (lengths, masses, densities, forces,
#: torques, accelerations, inertias), in the case's own consistent units; quantities that must
#: be positive are also at least ``1 / SCALE``.  Why 1e15: the largest quantity the solver
#: forms is a moment of an inertia force, density x length^5 x speed^2; with a density from
#: weight_density / gravity_constant (<= SCALE^2), lengths <= SCALE and the speed below
#: MAX_CRANK_RPM (1.05e6 rad/s) it stays below 1e15^7 x 1.1e12 ~ 1e117, so its square (norms,
#: least squares) stays below 1e234, 74 decades under the float maximum 1.8e308; the smallest,
#: 1e-105, squares to 1e-210, far above the smallest normal float 2.2e-308.  Physically the
#: range covers every mechanism in every known unit system with decades to spare (an aerogel
#: in t/mm^3 is 1e-12, a 10 km lever in mm is 1e7).
SCALE = 1e15
#: Largest ratio of the mechanism's largest length (a1, a2, |a4|, |S1|, axial amplitude) to
#: the crank or rod length: a link 1e12 times smaller than the mechanism is below the rounding
#: of its positions (1e4 x 2.2e-16 ~ 1e-12 of the size; the closure's SVD failed at 1e16).
MAX_LENGTH_RATIO = 1e12
#: Largest crank speed magnitude, rpm (time is always seconds): the fastest rotors built
#: (MEMS turbines, ~1e6 rpm) with a factor 10 to spare.
MAX_CRANK_RPM = 1e7
#: Largest crank angular acceleration magnitude, rad/s^2: reaching MAX_CRANK_RPM
#: (1.05e6 rad/s) from rest in 0.1 ms.
MAX_CRANK_ACCEL = 1e10
#: Largest number of axial cycles per crank revolution (alpha of eq. 27): a 1000-lobe cam.
MAX_AXIAL_CYCLES = 1e3
#: Largest magnitude of an angle given in degrees: the rounding of such an angle
#: (1e6 x 2.2e-16 = 2e-10 deg) stays below the solver's closure tolerance.
MAX_ANGLE_DEG = 1e6
#: Most crank positions in one case (``motion.angles_deg``); the engines stream them in chunks.
MAX_POSITIONS = 10_000_000
#: Longest case name, characters (names appear in one-line messages and report titles; names
#: derived by ``Case.with_values`` list every changed key, and are cut to this length).
MAX_CASE_NAME = 1000


class _ShortRepr(reprlib.Repr):
    """``repr`` cut to a few elements, safe for integers too long to print."""

    def __init__(self) -> None:
        super().__init__()
        self.maxlevel, self.maxlist, self.maxtuple, self.maxdict = 3, 6, 6, 6
        self.maxstring, self.maxother, self.maxlong = 60, 60, 30

    def repr_int(self, x: int, level: int) -> str:
        if x.bit_length() > 90:  # above ~27 digits: say how long, never build the digits
            return f"<an integer of about {int(x.bit_length() * math.log10(2)) + 1} digits>"
        return super().repr_int(x, level)


_SHORT = _ShortRepr()


def show(value: Any) -> str:
    """A short one-line ``repr`` of ``value`` for error messages (at most ~120 characters)."""
    text = " ".join(_SHORT.repr(value).split())
    return text if len(text) <= 120 else text[:117] + "..."


@dataclass(frozen=True)
class Range:
    """A closed interval of valid values for one kind of input, and how to name it in errors."""

    low: float
    high: float
    what: str  # e.g. "a positive length"

    def describe(self) -> str:
        """E.g. ``"a positive length from 1e-15 to 1e+15"``."""
        return f"{self.what} from {self.low:g} to {self.high:g}"

    def check(self, key: str, value: Any) -> float:
        """``value`` as a float, or a one-line :class:`CaseError` naming ``key``, the value and the range.

        Integers are compared exactly before any conversion, so a huge integer is
        refused instead of overflowing to ``inf``; ``bool`` is not a number here.
        """
        numeric = (int, float, np.integer, np.floating)
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, numeric):
            raise CaseError(f"{key}: expected a finite number ({self.describe()}), got {show(value)}")
        if isinstance(value, (int, np.integer)):
            ok = self.low <= value <= self.high
        else:
            ok = math.isfinite(value) and self.low <= value <= self.high
        if not ok:
            finite = "" if isinstance(value, (int, np.integer)) or math.isfinite(value) else "finite "
            raise CaseError(f"{key}: expected a {finite}number, {self.describe()}, got {show(value)}")
        return float(value)


LENGTH = Range(-SCALE, SCALE, "a length (case units)")
POSITIVE_LENGTH = Range(1.0 / SCALE, SCALE, "a positive length (case units)")
POSITIVE_MASS = Range(1.0 / SCALE, SCALE, "a positive mass (case units)")
POSITIVE_DENSITY = Range(1.0 / SCALE, SCALE, "a positive mass or weight per volume (case units)")
POSITIVE_ACCELERATION = Range(1.0 / SCALE, SCALE, "a positive acceleration (case units)")
ACCELERATION = Range(-SCALE, SCALE, "an acceleration (case units)")
INERTIA = Range(-SCALE, SCALE, "a moment of inertia (case units)")
FORCE = Range(-SCALE, SCALE, "a force (case units)")
TORQUE = Range(-SCALE, SCALE, "a torque (case units)")
ANGLE_DEG = Range(-MAX_ANGLE_DEG, MAX_ANGLE_DEG, "an angle in degrees")
CRANK_RPM = Range(-MAX_CRANK_RPM, MAX_CRANK_RPM, "a crank speed in rpm")
CRANK_ACCEL = Range(-MAX_CRANK_ACCEL, MAX_CRANK_ACCEL, "a crank acceleration in rad/s^2")
AXIAL_CYCLES = Range(-MAX_AXIAL_CYCLES, MAX_AXIAL_CYCLES, "axial cycles per crank revolution")


def key_text(key: Any) -> str:
    """A TOML key as it may appear in a one-line message: as is if short and plain, else quoted and cut."""
    if isinstance(key, str) and len(key) <= 60 and all(c.isalnum() or c in "._-+=" for c in key):
        return key
    return show(key)


def check_keys(section: str, table: Mapping[Any, Any], valid: Collection[str],
               error: type[ValueError] = CaseError) -> None:
    """Refuse the first key of ``table`` not in ``valid``: one line naming it and every valid key, sorted.

    ``section`` is the dotted path of ``table`` (``"bodies.crank"``): the message reads
    ``<section>.<key>: unknown key (valid: a, b)``; for the top level of a file (``section = ""``)
    ``<key>: unknown key (valid top-level keys: a, b)``.  ``error``: the :class:`ValueError` subclass
    raised (the caller's own, e.g. a matrix or SPEC error).
    """
    for key in table:
        if key not in valid:
            where = f"{section}.{key_text(key)}" if section else key_text(key)
            kind = "valid" if section else "valid top-level keys"
            raise error(f"{where}: unknown key ({kind}: {', '.join(sorted(valid))})")


def check_number(key: str, value: Any, limits: Range) -> float:
    """``value`` as a float within ``limits``, else a one-line :class:`CaseError` naming ``key``."""
    return limits.check(key, value)


#: How a case's numeric parts read a scalar of the case file: ``(key, value, limits) -> number``.
#: :func:`check_number` for a case; the tolerance study's sensitivities read the checked number plus
#: an imaginary step on one key (:func:`dualmech.models.case.case_numbers`).
NumberReader = Callable[[str, Any, Range], float]


def check_text(key: str, value: Any, max_chars: int) -> str:
    """A one-line printable string of at most ``max_chars`` characters, else a :class:`CaseError`."""
    if not isinstance(value, str):
        raise CaseError(f"{key}: expected a string, got {show(value)}")
    bad = next((c for c in value if unicodedata.category(c)[0] == "C"), None)
    if bad is not None:
        raise CaseError(f"{key}: control or non-printing character {bad!r} in {show(value)}; "
                        "expected one line of printable text")
    if len(value) > max_chars:
        raise CaseError(f"{key}: {len(value)} characters; at most {max_chars}")
    return value


def check_vector(key: str, value: Any, limits: Range) -> np.ndarray:
    """``value`` as a ``(3,)`` array of numbers within ``limits``, else a one-line :class:`CaseError`."""
    if not isinstance(value, list) or len(value) != 3:
        raise CaseError(f"{key}: expected an array of 3 numbers, got {show(value)}")
    return np.array([check_number(f"{key}[{i}]", v, limits) for i, v in enumerate(value)])
