"""The result table every engine writes: one row per crank position.

Every column is defined in ``docs/conventions.md`` ("Output columns"); this
module holds their names and order, the status words, and CSV output.  The
in-house solver, Pinocchio and MuJoCo all return a :class:`ResultTable`, so
comparison code never needs to know which engine produced one.
"""

from __future__ import annotations

import csv
import io
import threading
from dataclasses import dataclass, field
from importlib import import_module
from pathlib import Path
from typing import Any

import numpy as np

from dualmech.core.files import replacing, write_text_durable
from dualmech.core.status import STATUSES  # (also re-exported: the status words)

KINEMATIC_COLUMNS: tuple[str, ...] = ("theta1_deg", "S1", "S4", "S4_dot", "S4_ddot")
REACTION_COLUMNS: tuple[str, ...] = (
    "j1_fx", "j1_fy", "j1_fz", "j1_mx", "j1_my", "j1_mz",
    "j2_fx", "j2_fy", "j2_fz",
    "j3_fx", "j3_fy", "j3_fz", "j3_mx", "j3_my", "j3_mz",
    "j4_fx", "j4_fy", "j4_fz", "j4_mx", "j4_my", "j4_mz",
    "slider_load", "drive_torque",
)
DIAGNOSTIC_COLUMNS: tuple[str, ...] = ("transmission", "residual", "closure_condition")
NUMERIC_COLUMNS: tuple[str, ...] = KINEMATIC_COLUMNS + REACTION_COLUMNS + DIAGNOSTIC_COLUMNS
COLUMNS: tuple[str, ...] = NUMERIC_COLUMNS + ("status",)

FORCE_COLUMNS: tuple[str, ...] = tuple(
    c for c in REACTION_COLUMNS if "_f" in c or c == "slider_load"
)
MOMENT_COLUMNS: tuple[str, ...] = tuple(
    c for c in REACTION_COLUMNS if "_m" in c or c == "drive_torque"
)



@dataclass(frozen=True)
class ColumnTable:
    """Named ``(n,)`` columns of one engine's answer for one case, with one status word per row: what
    :class:`ResultTable` (the slider crank) and the other linkages' ``LinkageTable`` share."""

    engine: str
    case: str
    columns: dict[str, np.ndarray]
    status: np.ndarray
    meta: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        n = self.status.shape[0]
        for name, col in self.columns.items():
            if col.shape != (n,):
                raise ValueError(f"columns[{name!r}]: expected shape ({n},), got {col.shape}")

    def __len__(self) -> int:
        return self.status.shape[0]

    def __getitem__(self, name: str) -> np.ndarray:
        return self.status if name == "status" else self.columns[name]


@dataclass(frozen=True)
class ResultTable(ColumnTable):
    """Columns of one engine's answer for one slider-crank case.

    Attributes
    ----------
    engine : str
        ``"dualmech"``, ``"pinocchio"``, ``"mujoco"``, ``"mujoco-sim"`` or ``"exudyn"``.
    case : str
        The case name.
    columns : dict[str, numpy.ndarray]
        Every name of :data:`NUMERIC_COLUMNS`, each of shape ``(n,)``, float.
        Reactions are NaN where ``status`` is not ``ok``.
    status : numpy.ndarray of str, shape (n,)
        One word of :data:`STATUSES` per position.
    meta : dict
        Engine-specific facts (versions, iterations, timings) for reports.
    """

    def __post_init__(self) -> None:
        missing = [c for c in NUMERIC_COLUMNS if c not in self.columns]
        if missing:
            raise ValueError(f"columns: missing {missing}")
        super().__post_init__()

    def to_numpy(self) -> np.ndarray:
        """The table as one numpy structured array, shape ``(n,)``, fields :data:`COLUMNS` in order.

        The numeric fields are ``float64`` in the units of ``docs/conventions.md``; ``status`` is a
        fixed-width unicode field.  ``arr["S4"]`` is a column, ``arr[i]`` a row.
        """
        data = self._column_dict()
        out = np.empty(len(self), dtype=[(c, a.dtype) for c, a in data.items()])
        for c, a in data.items():  # one assignment per column, not per row
            out[c] = a
        return out

    def to_pandas(self) -> Any:
        """A ``pandas.DataFrame`` of :data:`COLUMNS` (``n`` rows, float64 and ``status`` str).

        pandas is a dependency, imported here only (at first use); if absent, a one-line ImportError.
        """
        return _optional("pandas", "to_pandas").DataFrame(self._column_dict())

    def to_polars(self) -> Any:
        """A ``polars.DataFrame`` of :data:`COLUMNS` (``n`` rows, Float64 and ``status`` Utf8).

        polars is optional (not a dependency): imported here only; if absent, a one-line ImportError.
        """
        return _optional("polars", "to_polars").DataFrame(self._column_dict())

    def _column_dict(self) -> dict[str, np.ndarray]:
        """:data:`COLUMNS` -> ``(n,)`` arrays, float64 and ``status`` as str."""
        data = {c: np.asarray(self.columns[c], dtype=np.float64) for c in NUMERIC_COLUMNS}
        return data | {"status": np.asarray(self.status, dtype=str)}

    def to_csv(self, path: str | Path | None = None) -> str:
        """Write the table as CSV (all :data:`COLUMNS`, full precision); return the text."""
        return write_csv({c: self.columns[c] for c in NUMERIC_COLUMNS}, self.status, path)


def _optional(package: str, method: str) -> Any:
    """Import optional ``package`` for ``ResultTable.<method>``, or a one-line ImportError naming it."""
    try:
        return import_module(package)
    except ImportError:
        raise ImportError(f"ResultTable.{method}: needs {package}, which is not installed "
                          f"(pip install {package})") from None


def write_csv(columns: dict[str, np.ndarray], status: np.ndarray, path: str | Path | None = None) -> str:
    """CSV text of ``columns`` (each ``(n,)``, full precision by ``repr``) then ``status`` ``(n,)``.

    The one CSV writer of dualmech's outputs (result tables, simulations); the header is the
    column names in order, then ``status``.  Written to ``path`` if given, atomically (beside, fsynced,
    renamed: :func:`~dualmech.core.files.write_text_durable`: an interrupted or failed write leaves the
    old file as it was); the text is returned.

    The bytes are those of the ``csv`` module writing ``repr(float(value))`` row by row (the shortest text
    that reads back to the same double), made column by column: each distinct bit pattern of a column
    formatted once (zeros, NaN and the constant columns of a planar case are much of a table), the rows
    joined in C (:func:`_float_words`, :func:`_csv_words`).
    """
    cells = [_float_words(np.ascontiguousarray(col, dtype=np.float64)) for col in columns.values()]
    cells.append(_csv_words(np.asarray(status).tolist()))
    text = "\n".join([",".join(_csv_words([*columns, "status"])), *map(",".join, zip(*cells))]) + "\n"
    if path is not None:
        write_text_durable(path, text)
    return text


def _float_words(column: np.ndarray) -> list[str]:
    """``repr`` of every value of the float64 ``column`` ``(n,)``, each distinct bit pattern formatted once
    (by bits, not by value: ``-0.0`` is not ``0.0``)."""
    bits, inverse = np.unique(column.view(np.int64), return_inverse=True)
    words = np.array(list(map(float.__repr__, bits.view(np.float64).tolist())), dtype=object)
    return words[inverse.reshape(-1)].tolist()


def _csv_words(words: list) -> list[str]:
    """Each of ``words`` as the ``csv`` module writes it as a field (quoted where it holds a comma, a quote
    or a line break), each distinct word through the module once."""
    fields = {}
    for word in set(words):
        buf = io.StringIO()
        csv.writer(buf, lineterminator="\n").writerow([word, ""])
        fields[word] = buf.getvalue()[:-2]  # without the empty last field's ",\n"
    return list(map(fields.__getitem__, words))


def read_csv(path: str | Path, engine: str = "", case: str = "") -> ResultTable:
    """Read a table written by :meth:`ResultTable.to_csv`."""
    with Path(path).open() as fh:
        rows = list(csv.DictReader(fh))
    columns = {c: np.array([float(r[c]) for r in rows]) for c in NUMERIC_COLUMNS}
    status = np.array([r["status"] for r in rows], dtype=object)
    return ResultTable(engine, case, columns, status)


#: Each status word's position in :data:`STATUSES` (:func:`status_codes`).
_CODES: dict[str, int] = {word: i for i, word in enumerate(STATUSES)}


def status_codes(words: np.ndarray) -> np.ndarray:
    """Positions of status words in :data:`STATUSES`, ``int8`` ``(n,)`` (the Parquet dictionary indices).

    One dictionary look-up per word (6 ms for 2·10⁵ words; ``np.unique`` sorted them in 70 ms)."""
    words = np.asarray(words, dtype=object).reshape(-1)
    try:
        return np.fromiter(map(_CODES.__getitem__, words), np.int8, words.size)
    except (KeyError, TypeError):
        unknown = next(w for w in words if not isinstance(w, str) or w not in _CODES)
        raise ValueError(f"status: {unknown!r} is not a status word (valid: {', '.join(STATUSES)})") from None


def _float_columns(columns: dict[str, np.ndarray], names: tuple[str, ...], n: int) -> list[np.ndarray]:
    """The ``names`` of ``columns`` as contiguous float64 arrays ``(n,)`` (copied only if they are not
    already)."""
    data = [np.ascontiguousarray(columns[c], dtype=np.float64) for c in names]
    for name, col in zip(names, data):
        if col.shape != (n,):
            raise ValueError(f"columns[{name!r}]: expected shape ({n},), got {col.shape}")
    return data


#: Values the Parquet writer encodes at a time (pyarrow's default 1,024): its per-batch work (page-size
#: checks, statistics updates) is 6 % of a write at the default, and a page may now exceed the 1 MiB
#: page size by up to one batch (512 KiB), which readers do not mind.
WRITE_BATCH_ROWS = 65_536


class ParquetWriter:
    """Stream result rows into a Parquet file, one row group per :meth:`write` (pyarrow).

    The columns are ``names`` (default the slider crank's :data:`NUMERIC_COLUMNS`, the contract of
    :meth:`ResultTable.to_csv`; another kind's table names its own) then ``status``: the numeric ones as
    float64 (plain encoding: a dictionary of distinct floats costs time and does not shrink
    the file), ``status`` dictionary-encoded over :data:`STATUSES`; snappy, with min/max statistics.
    Use as a context manager; memory is bounded by one row group.  A contiguous float64 column (as the
    kernel gives them: rows of one ``(31, n)`` array) is handed to pyarrow as it is, without a copy;
    any other is copied first.  :meth:`write` and :meth:`close` may be called from different threads:
    a close waits for a write in progress.
    """

    def __init__(self, path: str | Path, names: tuple[str, ...] = NUMERIC_COLUMNS) -> None:
        import pyarrow as pa
        import pyarrow.parquet as pq

        self._pa = pa
        self._names = tuple(names)
        self._dictionary = pa.array(STATUSES, type=pa.string())
        fields = [pa.field(c, pa.float64()) for c in self._names]
        self.schema = pa.schema(fields + [pa.field("status", pa.dictionary(pa.int8(), pa.string()))])
        self._writer = pq.ParquetWriter(
            str(path), self.schema, compression="snappy", use_dictionary=["status"],
            write_batch_size=WRITE_BATCH_ROWS,
        )
        self._lock = threading.Lock()

    def write(self, columns: dict[str, np.ndarray], codes: np.ndarray) -> None:
        """Append rows: every one of the writer's column names ``(n,)``, status codes ``(n,)``
        (:func:`status_codes`)."""
        pa = self._pa
        with self._lock:
            rows = _float_columns(columns, self._names, np.asarray(codes).shape[0])
            status = pa.DictionaryArray.from_arrays(pa.array(codes, type=pa.int8()), self._dictionary)
            arrays = [pa.array(row) for row in rows] + [status]  # contiguous float64: no copy
            self._writer.write_table(pa.Table.from_arrays(arrays, schema=self.schema))

    def close(self) -> None:
        with self._lock:
            self._writer.close()

    def __enter__(self) -> "ParquetWriter":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def write_parquet(table: ColumnTable, path: str | Path) -> None:
    """Write ``table`` as Parquet (one row group; :class:`ParquetWriter` for streams), atomically (beside,
    fsynced, renamed: :func:`~dualmech.core.files.replacing`): a slider crank's
    :data:`NUMERIC_COLUMNS`, another kind's every column in its order, then ``status``."""
    names = NUMERIC_COLUMNS if isinstance(table, ResultTable) else tuple(table.columns)
    with replacing(path) as (tmp, _), ParquetWriter(tmp, names) as writer:
        writer.write(table.columns, status_codes(table.status))


def read_parquet(path: str | Path, engine: str = "", case: str = "") -> ResultTable:
    """Read a table written by :class:`ParquetWriter` (the whole file)."""
    import pyarrow.parquet as pq

    data = pq.read_table(str(path))
    columns = {c: data.column(c).to_numpy() for c in NUMERIC_COLUMNS}
    status = np.array(data.column("status").to_pylist(), dtype=object)
    return ResultTable(engine, case, columns, status)
