"""A result table as a run folder's case file stores it (``cases/<id>.json``, :data:`~.schemas.TABLE_SCHEMA`):
its columns as JSON numbers (floats round-trip exactly, NaN as ``NaN``), its status words and its meta."""

from __future__ import annotations

import json

import numpy as np

from dualmech.core.table import NUMERIC_COLUMNS, ColumnTable, ResultTable
from dualmech.models.kinds import SLIDER_CRANK
from dualmech.models.tables import LinkageTable
from dualmech.validation.durable import json_text


def table_to_dict(table: ColumnTable) -> dict:
    """JSON-ready form of a table (floats round-trip exactly; NaN is written as ``NaN``): a slider crank's
    :data:`~dualmech.core.table.NUMERIC_COLUMNS`, another kind's every column in its order."""
    names = NUMERIC_COLUMNS if isinstance(table, ResultTable) else tuple(table.columns)
    return {
        "engine": table.engine,
        "case": table.case,
        "columns": {c: np.asarray(table.columns[c], dtype=float).tolist() for c in names},
        "status": [str(s) for s in table.status],
        "meta": json.loads(json_text(dict(table.meta))),
    }


def table_from_dict(d: dict, kind: str = SLIDER_CRANK) -> ColumnTable:
    """Inverse of :func:`table_to_dict`, for a case of ``kind``."""
    status = np.asarray(d["status"], dtype=object)
    meta = dict(d.get("meta", {}))
    if kind == SLIDER_CRANK:
        columns = {c: np.asarray(d["columns"][c], dtype=float) for c in NUMERIC_COLUMNS}
        return ResultTable(d["engine"], d["case"], columns, status, meta)
    columns = {c: np.asarray(v, dtype=float) for c, v in d["columns"].items()}
    return LinkageTable(d["engine"], d["case"], columns, status, meta)


def entry_result(entry: dict, kind: str = SLIDER_CRANK) -> ColumnTable | str:
    """A stored engine entry of a case of ``kind`` as a table, or its error text."""
    return entry["error"] if entry.get("error") else table_from_dict(entry["table"], kind)
