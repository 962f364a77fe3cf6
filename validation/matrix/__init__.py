"""Validation matrices: which cases, which engines, which quantities, which tolerances.

:mod:`.parse` reads a matrix file (its format is described there), :mod:`.expand` turns its sweeps
into concrete cases, :mod:`.tolerances` resolves each judge's tolerances, and :mod:`.data` holds the
expanded :class:`Matrix` that a run stores.
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
from dualmech.validation.matrix.parse import design_matrix, load_matrix, parse_matrix
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
