"""The Python API's argument checks: what :mod:`dualmech.verbs` (the package face's verbs) accepts,
as the command line does, each refusal a one-line ``TypeError`` or ``ValueError`` naming the argument."""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from dualmech.models.case import Case
from dualmech.models.inputs import show
from dualmech.validation.engines import ENGINES

if TYPE_CHECKING:
    from dualmech.models.tolerance.plan import StudyCase
    from dualmech.models.tolerance.spec import Spec


def as_case(case: Case | str | os.PathLike | dict, argument: str = "case") -> StudyCase:
    """``case`` as a tolerance study's case (:func:`~dualmech.models.tolerance.plan.study_case`): a
    slider-crank :class:`Case` or a :class:`~dualmech.models.tolerance.plan.TableCase` itself, or a case
    file, preset name or case table of any kind; anything else is a one-line ``TypeError`` naming
    ``argument``, another kind's checked record (without the table a SPEC addresses) a one-line
    ``CaseError``."""
    from dualmech.models.kinds import is_record
    from dualmech.models.tolerance.plan import TableCase, study_case

    if isinstance(case, TableCase):
        return case
    if not isinstance(case, (Case, str, os.PathLike, dict)) and not is_record(case):
        raise TypeError(f"{argument}: expected a dualmech.Case, a case file, a preset name or a case table "
                        f"(dict), got {show(case)}")
    return study_case(case)


def as_spec(spec: Spec | str | os.PathLike | dict) -> Spec:
    """``spec`` as a tolerance :class:`~dualmech.models.tolerance.spec.Spec`: itself, a SPEC file or its
    table; anything else is a one-line ``TypeError``."""
    from dualmech.models.tolerance.spec import Spec, load_spec, spec_from_dict

    if isinstance(spec, (str, os.PathLike)):
        return load_spec(spec)
    if isinstance(spec, dict):
        return spec_from_dict(spec)
    if not isinstance(spec, Spec):
        raise TypeError(f"spec: expected a tolerance SPEC (a file, a table or a Spec), got {show(spec)}")
    return spec


#: Most worker processes a run, a report or a study may ask for: far above any machine this runs on, and
#: below what the operating system refuses (2^31 - 1 jobs raised an OverflowError deep in multiprocessing).
MAX_JOBS = 1024


def whole_number(argument: str, value: Any, least: int, most: int | None = None) -> int:
    """``value`` as an ``int`` from ``least`` to ``most`` (no bound if ``None``): a one-line ``TypeError`` for
    a non-integer (a bool, a float or a string included), a ``ValueError`` outside the range."""
    valid = f">= {least}" if most is None else f"from {least} to {most}"
    if isinstance(value, bool) or not isinstance(value, int):
        raise TypeError(f"{argument}: expected a whole number {valid}, got {show(value)}")
    if value < least or most is not None and value > most:
        raise ValueError(f"{argument}: expected a whole number {valid}, got {value!r}")
    return value


def engine_names(engines: Sequence[str] | str) -> tuple[str, ...]:
    """``engines`` as a tuple of registered names; a comma-separated string is split, as the command line's
    ``--engines`` is.  One-line ``TypeError``/``ValueError`` naming the first bad entry."""
    names = tuple(e.strip() for e in engines.split(",") if e.strip()) if isinstance(engines, str) else engines
    if not isinstance(names, Sequence) or not all(isinstance(e, str) for e in names):
        raise TypeError(f"engines: expected engine names (a list of str, or one comma-separated str), "
                        f"got {show(engines)}")
    for name in names:
        if name not in ENGINES:
            raise ValueError(f"engines: {name!r} is not an engine (valid: {', '.join(ENGINES)})")
    return tuple(names)
