"""Validation matrices: which cases, which engines, which quantities, which tolerances.

:mod:`.sources` reads any matrix source by its format: :mod:`.parse` the slider crank's (its format is
described there; :mod:`.expand` turns its sweeps into concrete cases), :mod:`.cases` listed cases of any
kinds, mixed, and a base of another kind; :mod:`.tolerances` resolves each judge's tolerances, and
:mod:`.data` holds the expanded :class:`Matrix` that a run stores.
"""

from dualmech.validation.matrix.data import (
    COMPARABLE,
    MAX_VALIDATE_POSITIONS,
    Matrix,
    MatrixCase,
    MatrixError,
    ResolvedTolerance,
    Sweep,
    check_file_name,
    matrix_from_dict,
)
from dualmech.validation.matrix.parse import design_matrix, parse_matrix
from dualmech.validation.matrix.sources import load_matrix
from dualmech.validation.matrix.tolerances import GROUPS, resolve_tolerances

__all__ = [
    "COMPARABLE",
    "GROUPS",
    "MAX_VALIDATE_POSITIONS",
    "Matrix",
    "MatrixCase",
    "MatrixError",
    "ResolvedTolerance",
    "Sweep",
    "check_file_name",
    "design_matrix",
    "load_matrix",
    "matrix_from_dict",
    "parse_matrix",
    "resolve_tolerances",
]
