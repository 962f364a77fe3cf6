"""Every matrix source, read by its format: :func:`load_matrix`."""

from __future__ import annotations

from pathlib import Path

from dualmech.models.case import Case
from dualmech.validation.matrix.cases import is_listed_source, load_listed_matrix
from dualmech.validation.matrix.data import Matrix
from dualmech.validation.matrix.parse import read_matrix


def load_matrix(source: str | Path | Case | None = None) -> Matrix:
    """The expanded matrix of ``source``, of any format and any kind of case.

    Parameters
    ----------
    source : str, pathlib.Path, Case or None
        A matrix file or a bundled matrix's name (default ``thesis-1991``), or one design: a case file, a
        bundled case of any kind or a :class:`~dualmech.models.case.Case` (then judged by every engine that
        solves it).  Listed cases (``cases = [...]``), a base of a kind other than the slider crank and one
        case of such a kind are read by :mod:`~dualmech.validation.matrix.cases`; the slider crank's format
        by :func:`~dualmech.validation.matrix.parse.read_matrix`.

    Raises
    ------
    MatrixError, CaseError
        One line naming the key, the value and what would be valid.
    """
    if source is not None and not isinstance(source, Case) and is_listed_source(source):
        return load_listed_matrix(source)
    return read_matrix(source)
