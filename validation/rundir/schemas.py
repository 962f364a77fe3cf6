"""The formats of a run folder's files, checked before use: a small schema language (:func:`conform`) and
the schemas of ``manifest.json``, ``run.json`` and ``cases/<id>.json``; paths inside a folder
(:func:`member`).  A violation is one line naming the file and the field (:class:`RunDirError`).
The rules that use them: :mod:`dualmech.validation.rundir`.
"""

from __future__ import annotations

from pathlib import Path, PurePosixPath
from typing import Any, Callable

import numpy as np

from dualmech.core.table import NUMERIC_COLUMNS, STATUSES
from dualmech.models.inputs import show
from dualmech.models.kinds import SLIDER_CRANK, kind_of

MANIFEST_FORMAT = "dualmech-manifest/1"
RUN_FORMAT = "dualmech-run/1"
CASE_FORMAT = "dualmech-case/2"


class RunDirError(ValueError):
    """A run folder, or a file in it, that cannot be used; the message is one line."""


NUMBER = (int, float)


class Check:
    """A schema node: ``test(value)`` says whether ``value`` is valid; ``what`` describes a valid one."""

    def __init__(self, test: Callable[[Any], bool], what: str) -> None:
        self.test, self.what = test, what


class MapOf:
    """A schema node: a JSON object whose values all match ``values`` (its keys are strings)."""

    def __init__(self, values: Any) -> None:
        self.values = values


class Nullable:
    """A schema node: ``null`` or a value matching ``schema``."""

    def __init__(self, schema: Any) -> None:
        self.schema = schema


_TYPE_WORDS = {str: "a string", int: "an integer", float: "a number", bool: "true or false",
               dict: "an object", list: "a list", type(None): "null"}


def _describe(schema: Any) -> str:
    if isinstance(schema, Check):
        return schema.what
    if isinstance(schema, Nullable):
        return f"null or {_describe(schema.schema)}"
    if isinstance(schema, (dict, MapOf)):
        return "an object"
    if isinstance(schema, list):
        return "a list"
    if schema == NUMBER:
        return "a number"
    types = schema if isinstance(schema, tuple) else (schema,)
    return " or ".join(_TYPE_WORDS.get(t, t.__name__) for t in types)


def _is(value: Any, types: type | tuple) -> bool:
    types = types if isinstance(types, tuple) else (types,)
    if isinstance(value, bool) and bool not in types:  # JSON's true is not a number
        return False
    return isinstance(value, types)


def conform(value: Any, schema: Any, file: str | Path, field: str = "") -> Any:
    """``value`` if it matches ``schema``, else a one-line :class:`RunDirError` naming ``file`` and the field.

    A schema is a type or tuple of types; a ``dict`` of keys to schemas (a key ending in ``?`` is
    optional; other keys are allowed); a one-item ``list`` (every item matches it); :class:`MapOf`,
    :class:`Nullable` or :class:`Check`.
    """
    where = field or "(top level)"
    ok: bool
    if isinstance(schema, Nullable):
        return value if value is None else conform(value, schema.schema, file, field)
    if isinstance(schema, Check):
        ok = schema.test(value)
    elif isinstance(schema, dict):
        ok = isinstance(value, dict)
        if ok:
            for key, sub in schema.items():
                name = key.rstrip("?")
                inner = f"{field}.{name}" if field else name
                if name in value:
                    conform(value[name], sub, file, inner)
                elif not key.endswith("?"):
                    raise RunDirError(f"{file}: {inner}: missing (expected {_describe(sub)})")
    elif isinstance(schema, MapOf):
        ok = isinstance(value, dict)
        if ok:
            for key, item in value.items():
                conform(item, schema.values, file, f"{field}.{key}" if field else str(key))
    elif isinstance(schema, list):
        ok = isinstance(value, list)
        if ok:
            for i, item in enumerate(value):
                conform(item, schema[0], file, f"{field}[{i}]")
    else:
        ok = _is(value, schema)
    if not ok:
        raise RunDirError(f"{file}: {where}: expected {_describe(schema)}, got {show(value)}")
    return value


def member(name: Any, file: str | Path = "", field: str = "path") -> PurePosixPath:
    """``name`` as a relative path of plain names inside a folder, else a one-line :class:`RunDirError`.

    Valid: a non-empty string of ``/``-separated names, none of them empty, ``.`` or ``..``, without a
    backslash or NUL; not absolute.
    """
    parts = name.split("/") if isinstance(name, str) else []
    if not parts or any(p in ("", ".", "..") or "\\" in p or "\0" in p for p in parts):
        where = f"{file}: " if file else ""
        raise RunDirError(f"{where}{field}: {show(name)} is not a path inside the folder (expected "
                          "relative names joined by '/', without '..', '.' or an empty name)")
    return PurePosixPath(*parts)


def _is_number_list(value: Any) -> bool:
    if not isinstance(value, list):
        return False
    try:
        return np.asarray(value, dtype=float).ndim == 1
    except (TypeError, ValueError):
        return False


NUMBER_LIST = Check(_is_number_list, "a list of numbers")
STATUS_LIST = Check(lambda v: isinstance(v, list) and set(map(type, v)) <= {str} and set(v) <= set(STATUSES),
                    f"a list of status words ({', '.join(STATUSES)})")
PATH = Check(lambda v: isinstance(v, str), "a path inside the folder")

#: ``manifest.json``: the files dualmech wrote in the folder (checked further by :func:`member`).
MANIFEST_SCHEMA = {"format": Check(lambda v: v == MANIFEST_FORMAT, repr(MANIFEST_FORMAT)), "files": [PATH]}

#: The ``matrix`` of ``run.json`` (:meth:`~dualmech.validation.matrix.Matrix.to_dict`).
MATRIX_SCHEMA = {
    "name": str, "description": str, "source": str, "base?": str, "reference": str, "engines": [str],
    "quantities": [str], "modes": [str], "labels": MapOf(str),
    "cases": [{"id": str, "raw": dict, "mode": str, "values": dict, "sweeps": [str], "labels": MapOf(str),
               "is_base": bool, "expect?": Nullable(str), "engines?": [str]}],
    "sweeps": [{"name": str, "label": str, "keys": [str], "case_ids": MapOf([str])}],
    "tolerances": MapOf(MapOf({"name": str, "value": NUMBER, "reason": str})),
}
#: ``run.json`` (:func:`dualmech.validation.run.runner.run_matrix`).
RUN_SCHEMA = {
    "format": Check(lambda v: v == RUN_FORMAT, repr(RUN_FORMAT)), "matrix": MATRIX_SCHEMA,
    "started": str, "seconds?": NUMBER, "jobs": int, "scheduler": Nullable(str),
    "machine": MapOf((str, int, float, type(None))), "versions": MapOf(str), "registry": MapOf(str),
    "resumed": bool, "ran?": int, "skipped?": int,
}
#: One engine's stored table in a case file (:func:`~dualmech.validation.rundir.tables.table_to_dict`): a
#: slider crank's holds every one of its columns (:func:`check_case_file`), another kind's its own.
TABLE_SCHEMA = {"engine": str, "case": str, "columns": MapOf(NUMBER_LIST), "status": STATUS_LIST,
                "meta?": dict}
#: ``cases/<id>.json`` (:class:`dualmech.validation.run.runner.CaseFileText`).
CASE_SCHEMA = {
    "format": str, "id": str, "fingerprint": str, "raw": dict,
    "engines": MapOf({"engine": str, "error?": Nullable(str), "table?": Nullable(TABLE_SCHEMA),
                      "seconds?": NUMBER, "fingerprint?": Nullable(dict), "spec?": str, "host?": str,
                      "versions?": MapOf(str), "traceback?": str}),
}


def check_case_file(data: Any, file: str | Path, case_id: str) -> dict:
    """A case file's content (:data:`CASE_SCHEMA`) for case ``case_id``: every engine has a table or an
    error, a slider crank's table every column of :data:`~dualmech.core.table.NUMERIC_COLUMNS`, and every
    column of a table as many rows as its status; else a one-line :class:`RunDirError`."""
    conform(data, CASE_SCHEMA, file)
    needed = NUMERIC_COLUMNS if kind_of(data["raw"]) == SLIDER_CRANK else ()
    if data["id"] != case_id:
        raise RunDirError(f"{file}: id: {show(data['id'])}; expected {case_id!r} (the file's name)")
    for engine, entry in data["engines"].items():
        where = f"engines.{engine}"
        if entry["engine"] != engine:
            raise RunDirError(f"{file}: {where}.engine: {show(entry['engine'])}; expected {engine!r}")
        table = entry.get("table")
        if not entry.get("error") and table is None:
            raise RunDirError(f"{file}: {where}: neither a table nor an error")
        if table is not None:
            missing = next((c for c in needed if c not in table["columns"]), None)
            if missing is not None:
                raise RunDirError(f"{file}: {where}.table.columns.{missing}: missing (expected a list of "
                                  "numbers)")
            n = len(table["status"])
            bad = next((c for c in table["columns"] if len(table["columns"][c]) != n), None)
            if bad is not None:
                raise RunDirError(f"{file}: {where}.table.columns.{bad}: {len(table['columns'][bad])} rows; "
                                  f"expected {n} (as many as its status)")
    return data
