"""A tolerance study's parts: sample designs in chunks, solve them batched, store and stream the rows.

Designs are independent; chunks of :data:`~dualmech.models.tolerance.sampling.CHUNK_DESIGNS`
are tasks (:func:`solve_chunk`, picklable), run by :mod:`dualmech.validation.tolerance_study` in
this process, a process pool or on a Dask cluster, which also judges and summarises.  Each chunk's
designs are solved together as the compiled kernel's arrays, in blocks of bounded memory, and
reduced per design (:mod:`~dualmech.models.tolerance.designs`).  A finished chunk is stored at once as
``DIR/chunks/chunk-NNNNNN.npz`` (written to a temporary name, then renamed), so an interrupted
study resumes where it stopped; ``DIR/study.json`` names the case, SPEC, ``n`` and seed, and a
folder holding another study is refused.  As the chunks finish they are streamed, in design order,
into ``DIR/samples.csv`` (and ``DIR/samples.parquet`` when pyarrow is installed, one row group
per chunk) by :class:`SampleStream`, while the next chunks are solved; the study then summarises
them into ``DIR/summary.json``.
"""

from __future__ import annotations

import csv
import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dualmech.models.case import Case, case_from_dict
from dualmech.models.tolerance.designs import analyse_designs, design_arrays
from dualmech.models.tolerance.outputs import COUNTS, output_names
from dualmech.models.tolerance.sampling import chunk_bounds, n_chunks, sample_chunk
from dualmech.models.tolerance.spec import Spec, nominal_values, spec_from_dict

#: Format tag of ``study.json``.
STUDY_FORMAT = "dualmech-tolerance/1"
#: Methods: Monte Carlo, linear propagation of the exact sensitivities, or both.
METHODS: tuple[str, ...] = ("mc", "linear", "both")
#: Most designs in one study (10^7 x 360 positions is a day on today's solver; streams in bounded memory).
MAX_DESIGNS = 10_000_000


@dataclass(frozen=True)
class StudyInput:
    """What a study is: the nominal case, the SPEC, how many designs and the seed."""

    case: Case
    spec: Spec
    n: int
    seed: int

    def identity(self) -> dict:
        """JSON-ready identity (``study.json``); a resumed study must have the same."""
        return {"format": STUDY_FORMAT, "case": self.case.raw, "spec": self.spec.to_dict(), "n": self.n,
                "seed": self.seed}


def solve_chunk(case_raw: dict, spec_dict: dict, n: int, seed: int, index: int) -> dict:
    """Task: sample chunk ``index``, solve its designs together as arrays, return its rows.

    Returns ``{"index", "x" (m, k), "outputs": {name: (m,)}}``.  Picklable arguments only
    (runs in pool workers and on Dask workers).
    """
    case, spec = case_from_dict(case_raw), spec_from_dict(spec_dict)
    x = sample_chunk(spec, nominal_values(case, spec), n, seed, index)
    designs = design_arrays(case, spec, x, chunk_bounds(n, index)[0])
    return {"index": index, "x": x, "outputs": analyse_designs(designs, case.loads.mode)}


def _chunk_path(outdir: Path, index: int) -> Path:
    return outdir / "chunks" / f"chunk-{index:06d}.npz"


def store_chunk(outdir: Path, entry: dict) -> None:
    """Store one finished chunk (a :func:`solve_chunk` result) atomically: ``DIR/chunks/chunk-NNNNNN.npz``."""
    path = _chunk_path(outdir, entry["index"])
    tmp = path.with_name(path.name + ".tmp.npz")
    arrays = {f"out_{k}": np.asarray(v) for k, v in entry["outputs"].items() if k != "status"}
    np.savez(tmp, x=entry["x"], status=np.asarray(entry["outputs"]["status"], dtype=str), **arrays)
    os.replace(tmp, path)


def _load(outdir: Path, index: int) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    with np.load(_chunk_path(outdir, index)) as data:
        out = {k[4:]: data[k] for k in data.files if k.startswith("out_")}
        out["status"] = data["status"].astype(object)
        return data["x"], out


def prepare(outdir: Path, study: StudyInput) -> list[int]:
    """Create (or reopen) the study folder; the chunks still to run."""
    if study.n < 1 or study.n > MAX_DESIGNS:
        raise ValueError(f"n: expected 1 to {MAX_DESIGNS:,} designs, got {study.n!r}")
    (outdir / "chunks").mkdir(parents=True, exist_ok=True)
    meta = outdir / "study.json"
    identity = json.loads(json.dumps(study.identity()))
    if meta.exists():
        if json.loads(meta.read_text()) != identity:
            raise ValueError(f"output: {str(outdir)!r} holds another study (case, SPEC, n or seed differ); "
                             "use an empty folder")
    elif any(outdir.iterdir()) and sorted(p.name for p in outdir.iterdir()) != ["chunks"]:
        raise ValueError(f"output: {str(outdir)!r} is not empty and holds no tolerance study; "
                         "use an empty folder")
    meta.write_text(json.dumps(identity, indent=1, sort_keys=True))
    return [c for c in range(n_chunks(study.n)) if not _chunk_path(outdir, c).exists()]


def columns(spec: Spec, mode: str) -> list[str]:
    """The columns of ``samples.csv`` (``docs/conventions.md``, "Tolerance analysis")."""
    return ["design", *spec.keys, "status", *COUNTS, *output_names(mode)]


class SampleStream:
    """Chunks, in whatever order they finish, into ``samples.csv`` and ``samples.parquet`` in design order.

    :meth:`add` takes a finished chunk; every chunk whose predecessors are all in is written at once
    (so the files grow while the next chunks are solved), a chunk stored by an earlier run
    (``resumed``) read from ``DIR/chunks/`` when its turn comes.  The files are written under
    temporary names and renamed by :meth:`finish`, which returns every design's key values ``(n, k)``
    and outputs ``(n,)``; :meth:`abort` removes them.  Parquet (when pyarrow is installed) has one
    row group per chunk, dictionary encoding for the status words only.
    """

    def __init__(self, outdir: Path, study: StudyInput, resumed: set[int]) -> None:
        self.outdir, self.study, self.resumed = outdir, study, resumed
        self.names = columns(study.spec, study.case.loads.mode)
        self.pending: dict[int, tuple[np.ndarray, dict[str, np.ndarray]]] = {}
        self.parts: list[tuple[np.ndarray, dict[str, np.ndarray]]] = []
        self._csv = (outdir / "samples.csv.tmp").open("w", newline="")
        self._rows = csv.writer(self._csv, lineterminator="\n")
        self._rows.writerow(self.names)
        self._parquet = _parquet_writer(outdir / "samples.parquet.tmp", self.names)

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
                part = _load(self.outdir, c)
            else:
                return
            self._write(chunk_bounds(self.study.n, c)[0], *part)
            self.parts.append(part)

    def _write(self, first: int, x: np.ndarray, res: dict[str, np.ndarray]) -> None:
        cols = {"design": np.arange(first, first + x.shape[0]), **dict(zip(self.study.spec.keys, x.T)), **res}
        self._rows.writerows(zip(*(_cells(cols[c]) for c in self.names)))
        if self._parquet is not None:
            self._parquet.write_table(_arrow_table(cols, self.names))

    def finish(self) -> tuple[list[str], np.ndarray, dict[str, np.ndarray]]:
        """Write the chunks not yet written (from ``DIR/chunks/``), rename the files; (files, x, outputs)."""
        self._drain(stored=None)
        written = ["samples.csv"]
        self._csv.close()
        os.replace(self.outdir / "samples.csv.tmp", self.outdir / "samples.csv")
        if self._parquet is not None:
            self._parquet.close()
            os.replace(self.outdir / "samples.parquet.tmp", self.outdir / "samples.parquet")
            written.append("samples.parquet")
        xs, outs = zip(*self.parts)
        return written, np.concatenate(xs), {k: np.concatenate([o[k] for o in outs]) for k in outs[0]}

    def abort(self) -> None:
        """Close and remove the unfinished files."""
        self._csv.close()
        if self._parquet is not None:
            self._parquet.close()
        for name in ("samples.csv.tmp", "samples.parquet.tmp"):
            (self.outdir / name).unlink(missing_ok=True)


def _cells(column: np.ndarray) -> list[str]:
    """A column's CSV cells: floats by ``repr`` (shortest round trip), integers and words as text."""
    values = np.asarray(column).tolist()
    return list(map(repr if np.asarray(column).dtype.kind == "f" else str, values))


def _parquet_writer(path: Path, names: list[str]):
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        return None
    types = {"design": pa.int64(), "status": pa.string(), "dead_centres": pa.int64(),
             "failed_positions": pa.int64()}
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
