"""dualmech's numpy-only floor: dual-number algebra, link-joint loop, closure, rates and the result table.

Public names (the rest are internal module paths, free to move):

- :class:`ResultTable`, :data:`COLUMNS`, :data:`NUMERIC_COLUMNS` (:mod:`dualmech.core.table`): what
  every engine returns, one row per crank position; ``.to_numpy()``, ``.to_pandas()``, ``.to_polars()``.
- :class:`Status`, :data:`STATUSES` (:mod:`dualmech.core.status`): the status word of each row.

Importing this package imports numpy only.  The Python API's entry points are
:func:`dualmech.models.load_case`, :func:`dualmech.models.solve` and :func:`dualmech.validation.validate`.
"""

from dualmech.core.status import STATUSES, Status
from dualmech.core.table import COLUMNS, NUMERIC_COLUMNS, ResultTable

__all__ = ["COLUMNS", "NUMERIC_COLUMNS", "STATUSES", "ResultTable", "Status"]
