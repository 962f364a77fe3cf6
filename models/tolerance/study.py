"""A tolerance study's parts: sample designs in chunks, solve them batched, and stream the rows.

Designs are independent; chunks of :data:`~dualmech.models.tolerance.sampling.CHUNK_DESIGNS`
are tasks (:func:`solve_chunk`, picklable), run by :mod:`dualmech.validation.tolerance.study` in
this process, a process pool or on a Dask cluster, which also stores them, judges and summarises.
Each chunk's designs are solved together as the compiled kernel's arrays, in blocks of bounded memory,
and reduced per design (:mod:`~dualmech.models.tolerance.designs`).  A stored chunk
(:func:`chunk_arrays`) carries the study's fingerprint and its index, and is read back only if they and
every array's shape match (:func:`chunk_part`): a damaged chunk or one of another study is solved again.
As the chunks finish they are streamed, in design order, into ``samples.csv`` (and ``samples.parquet``
when pyarrow is installed, one row group per chunk) by :class:`SampleStream`, while the next chunks are
solved; the study then summarises them into ``DIR/summary.json``.
"""

from __future__ import annotations

import csv
import hashlib
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Mapping

import numpy as np

from dualmech.models.tolerance.outputs import COUNTS
from dualmech.models.tolerance.plan import StudyCase, plan_of, record_of, study_case
from dualmech.models.tolerance.sampling import chunk_bounds, n_chunks, sample_chunk
from dualmech.models.tolerance.spec import Spec, spec_from_dict

#: Format tag of ``study.json``.
STUDY_FORMAT = "dualmech-tolerance/1"
#: Methods: Monte Carlo, linear propagation of the exact sensitivities, or both.
METHODS: tuple[str, ...] = ("mc", "linear", "both")
#: Most designs in one study (10^7 x 360 positions is a day on today's solver; streams in bounded memory).
MAX_DESIGNS = 10_000_000


@dataclass(frozen=True)
class StudyInput:
    """What a study is: the nominal case (of any kind), the SPEC, how many designs and the seed."""

    case: StudyCase
    spec: Spec
    n: int
    seed: int

    def identity(self) -> dict:
        """JSON-ready identity (``study.json``); a resumed study must have the same."""
        return {"format": STUDY_FORMAT, "case": self.case.raw, "spec": self.spec.to_dict(), "n": self.n,
                "seed": self.seed}

    def __post_init__(self) -> None:
        """A key the case's kind cannot vary, or the case does not state: one line naming the valid ones
        (:class:`~dualmech.models.tolerance.spec.SpecError`), before any folder is touched."""
        plan_of(self.case).nominal_values(self.case, self.spec)

    def outputs(self) -> tuple[str, ...]:
        """The outputs of a design, in order (the case's kind's)."""
        return plan_of(self.case).outputs(record_of(self.case))

    def fingerprint(self) -> str:
        """SHA-256 (16 hex digits) of :meth:`identity`: what every stored chunk of this study carries."""
        text = json.dumps(self.identity(), sort_keys=True, allow_nan=True, default=str)
        return hashlib.sha256(text.encode()).hexdigest()[:16]


def solve_chunk(case_raw: dict, spec_dict: dict, n: int, seed: int, index: int) -> dict:
    """Task: sample chunk ``index``, solve its designs together as arrays, return its rows.

    ``case_raw`` is the case table (of any kind: :func:`~dualmech.models.tolerance.plan.study_case`).
    Returns ``{"index", "x" (m, k), "outputs": {name: (m,)}}``.  Picklable arguments only
    (runs in pool workers and on Dask workers).
    """
    case, spec = study_case(case_raw), spec_from_dict(spec_dict)
    plan = plan_of(case)
    x = sample_chunk(spec, plan.nominal_values(case, spec), n, seed, index)
    return {"index": index, "x": x, "outputs": plan.analyse(case, spec, x, chunk_bounds(n, index)[0])}


def chunk_name(index: int) -> str:
    """A stored chunk's file, relative to the study folder."""
    return f"chunks/chunk-{index:06d}.npz"


def chunk_arrays(study: StudyInput, entry: dict) -> dict[str, np.ndarray]:
    """What a finished chunk (a :func:`solve_chunk` result) stores: ``x``, ``status``, ``out_<name>`` per
    output, and the study's ``fingerprint`` and the chunk's ``index`` (:func:`chunk_part` checks them)."""
    arrays = {f"out_{k}": np.asarray(v) for k, v in entry["outputs"].items() if k != "status"}
    return {"fingerprint": np.asarray(study.fingerprint()), "index": np.asarray(entry["index"]),
            "x": np.asarray(entry["x"]), "status": np.asarray(entry["outputs"]["status"], dtype=str),
            **arrays}


def chunk_part(study: StudyInput, index: int, data: Mapping[str, np.ndarray]
               ) -> tuple[np.ndarray, dict[str, np.ndarray]] | None:
    """Chunk ``index``'s key values ``(m, k)`` and outputs ``(m,)`` from its stored arrays
    (:func:`chunk_arrays`); ``None`` if they are of another study or chunk, or any is missing or of
    another shape or kind (the chunk is then solved again)."""
    lo, hi = chunk_bounds(study.n, index)
    names = ["status", *COUNTS, *study.outputs()]
    wanted = {"fingerprint", "index", "x", *(f"out_{k}" for k in names if k != "status")}
    if not wanted <= set(data):
        return None
    if str(data["fingerprint"]) != study.fingerprint() or data["index"].shape != () \
            or int(data["index"]) != index:
        return None
    x = data["x"]
    if x.shape != (hi - lo, len(study.spec.keys)) or x.dtype.kind != "f":
        return None
    outputs = {k: data[f"out_{k}"] for k in names if k != "status"}
    outputs["status"] = data["status"].astype(object)
    if any(v.shape != (hi - lo,) for v in outputs.values()) or data["status"].dtype.kind != "U":
        return None
    return x, outputs


def check_size(study: StudyInput) -> None:
    """A one-line ValueError unless the study's design count is 1 to :data:`MAX_DESIGNS`."""
    if study.n < 1 or study.n > MAX_DESIGNS:
        raise ValueError(f"n: expected 1 to {MAX_DESIGNS:,} designs, got {study.n!r}")


def columns(spec: Spec, outputs: tuple[str, ...]) -> list[str]:
    """The columns of ``samples.csv`` (``docs/conventions.md``, "Tolerance analysis")."""
    return ["design", *spec.keys, "status", *COUNTS, *outputs]


class SampleStream:
    """Chunks, in whatever order they finish, into ``samples.csv`` and ``samples.parquet`` in design order.

    :meth:`add` takes a finished chunk; every chunk whose predecessors are all in is written at once
    (so the files grow while the next chunks are solved), a chunk stored by an earlier run
    (``resumed``) read by ``load(index)`` when its turn comes.  The files are written to ``csv_path`` and
    ``parquet_path`` (``None``: no Parquet), the temporary files of the caller, who renames them once
    :meth:`finish` returned every design's key values ``(n, k)`` and outputs ``(n,)``; :meth:`abort`
    closes them.  Parquet has one row group per chunk, dictionary encoding for the status words only.
    """

    def __init__(self, study: StudyInput, resumed: set[int], csv_path: Path, parquet_path: Path | None,
                 load: Callable[[int], tuple[np.ndarray, dict[str, np.ndarray]]]) -> None:
        self.study, self.resumed, self.load = study, resumed, load
        self.names = columns(study.spec, study.outputs())
        self.pending: dict[int, tuple[np.ndarray, dict[str, np.ndarray]]] = {}
        self.parts: list[tuple[np.ndarray, dict[str, np.ndarray]]] = []
        self._csv = Path(csv_path).open("w", newline="")
        self._rows = csv.writer(self._csv, lineterminator="\n")
        self._rows.writerow(self.names)
        self._parquet = None if parquet_path is None else _parquet_writer(parquet_path, self.names)

    def add(self, index: int, x: np.ndarray, outputs: dict[str, np.ndarray]) -> None:
        """Take chunk ``index`` (a :func:`solve_chunk` result's parts); write every chunk now in order."""
        self.pending[index] = (x, outputs)
        self._drain(stored=self.resumed)

    def _drain(self, stored: set[int] | None) -> None:
        """Write chunks in order while the next is pending or stored (``None``: every chunk is stored)."""
        while len(self.parts) < n_chunks(self.study.n):
            c = len(self.parts)
            if c in self.pending:
                part = self.pending.pop(c)
            elif stored is None or c in stored:
                part = self.load(c)
            else:
                return
            self._write(chunk_bounds(self.study.n, c)[0], *part)
            self.parts.append(part)

    def _write(self, first: int, x: np.ndarray, res: dict[str, np.ndarray]) -> None:
        cols = {"design": np.arange(first, first + x.shape[0]), **dict(zip(self.study.spec.keys, x.T)), **res}
        self._rows.writerows(zip(*(_cells(cols[c]) for c in self.names)))
        if self._parquet is not None:
            self._parquet.write_table(_arrow_table(cols, self.names))

    def finish(self) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """Write the chunks not yet written (``load``), close the files; (x, outputs) of every design."""
        self._drain(stored=None)
        self.abort()
        xs, outs = zip(*self.parts)
        return np.concatenate(xs), {k: np.concatenate([o[k] for o in outs]) for k in outs[0]}

    def abort(self) -> None:
        """Close the files (the caller removes them)."""
        self._csv.close()
        if self._parquet is not None:
            self._parquet.close()


def parquet_available() -> bool:
    """Whether pyarrow is installed (``samples.parquet`` is written beside ``samples.csv``)."""
    try:
        import pyarrow.parquet  # noqa: F401
    except ImportError:
        return False
    return True


def _cells(column: np.ndarray) -> list[str]:
    """A column's CSV cells: floats by ``repr`` (shortest round trip), integers and words as text."""
    values = np.asarray(column).tolist()
    return list(map(repr if np.asarray(column).dtype.kind == "f" else str, values))


def _parquet_writer(path: Path, names: list[str]):
    import pyarrow as pa
    import pyarrow.parquet as pq

    types = {"design": pa.int64(), "status": pa.string(), "dead_centres": pa.int64(),
             "failed_positions": pa.int64(), "branch_jumps": pa.int64()}
    schema = pa.schema([(c, types.get(c, pa.float64())) for c in names])
    return pq.ParquetWriter(str(path), schema, use_dictionary=["status"])


def _arrow_table(cols: dict, names: list[str]):
    import pyarrow as pa

    return pa.table({c: np.asarray(cols[c], dtype=str if c == "status" else None) for c in names})


def finite_json(obj: object) -> object:
    """``obj`` with every non-finite float as ``None`` (strict JSON)."""
    if isinstance(obj, dict):
        return {k: finite_json(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [finite_json(v) for v in obj]
    if isinstance(obj, (float, np.floating)):
        return float(obj) if np.isfinite(obj) else None
    if isinstance(obj, np.integer):
        return int(obj)
    return obj
