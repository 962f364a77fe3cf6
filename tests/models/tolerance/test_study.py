"""A tolerance study end to end (models/tolerance/study.py): reproducible for any --jobs, resumable, also when
stopped with chunks in flight."""

import copy
import json

import numpy as np
import pytest

from dualmech.models.case import case_from_dict, load_case
from dualmech.models.slider_crank.analysis import solve_case
from dualmech.models.tolerance.outputs import DesignStatus, design_outputs, output_names
from dualmech.models.tolerance.sampling import CHUNK_DESIGNS
from dualmech.models.tolerance.sensitivity import output_group
from dualmech.models.tolerance.spec import design_case, spec_from_dict
from dualmech.models.tolerance.study import SampleStream, StudyInput, columns
from dualmech.validation.tolerance import study as tolerance_study
from dualmech.validation.tolerance.study import run_study

N = CHUNK_DESIGNS + 9  # two chunks, the second short
#: A design's outputs in a batch against the design solved alone, relative to its output group's peak: the
#: numpy batch is bitwise the same; the compiled single-case path agrees with it to ~1e-14 (measured 2.4e-15).
BATCH_VS_ALONE = 1e-12


def _study(n=N, seed=8):
    raw = copy.deepcopy(load_case("a4-10-s1-3.5").raw)
    raw["motion"]["angles_deg"] = {"start": 0.0, "stop": 360.0, "step": 6.0}
    spec = spec_from_dict({"tolerances": {
        "geometry.slider_offset": {"dist": "uniform", "low": 20.0, "high": 60.0},  # a4 30..70: a2 - a1 = 38
        "geometry.crank_axial_shift": {"dist": "normal", "sd": 3.0}}})
    return StudyInput(case_from_dict(raw), spec, n, seed)


def _without_timing(path):
    s = json.loads(path.read_text())
    s.pop("timing")
    return s


def test_same_seed_same_samples_and_summary_for_one_or_two_jobs(tmp_path):
    study = _study()
    run_study(study, "both", tmp_path / "one", jobs=1, judge_samples=0)
    run_study(study, "both", tmp_path / "two", jobs=2, judge_samples=0)
    assert (tmp_path / "one/samples.csv").read_bytes() == (tmp_path / "two/samples.csv").read_bytes()
    assert _without_timing(tmp_path / "one/summary.json") == _without_timing(tmp_path / "two/summary.json")
    other, _, _ = run_study(_study(seed=9), "mc", tmp_path / "other", judge_samples=0)
    assert other["outputs"] != _without_timing(tmp_path / "one/summary.json")["outputs"]


def test_rows_are_the_designs_solved_one_by_one(tmp_path):
    study = _study()
    summary, x, samples = run_study(study, "mc", tmp_path, judge_samples=0)
    lines = (tmp_path / "samples.csv").read_text().splitlines()
    assert lines[0].split(",") == columns(study.spec, study.outputs()) and len(lines) == N + 1
    statuses = set(samples["status"])
    assert statuses == {DesignStatus.OK, DesignStatus.PARTIAL, DesignStatus.NO_ASSEMBLY}
    assert 0 < summary["yield"]["value"] < 1
    for i in (0, N - 1):  # a design in each chunk, re-solved alone
        alone = design_outputs([solve_case(design_case(study.case, study.spec, x[i], "alone"))], "torque")
        for name in output_names("torque"):
            scale = max(abs(alone[n][0]) for n in output_group(name, "torque"))
            np.testing.assert_allclose(samples[name][i], alone[name][0], rtol=BATCH_VS_ALONE,
                                       atol=BATCH_VS_ALONE * scale, err_msg=name)
        assert samples["status"][i] == alone["status"][0]
    import pyarrow.parquet as pq

    table = pq.read_table(tmp_path / "samples.parquet")
    assert table.column_names == columns(study.spec, study.outputs()) and table.num_rows == N


def test_an_interrupted_study_resumes_with_the_same_rows(tmp_path):
    study = _study()
    run_study(study, "mc", tmp_path, judge_samples=0)
    before = (tmp_path / "samples.csv").read_bytes()
    (tmp_path / "chunks/chunk-000001.npz").unlink()  # as if stopped before the second chunk was stored
    summary, _, _ = run_study(study, "mc", tmp_path, judge_samples=0)
    assert summary["timing"]["chunks_run"] == 1 and summary["timing"]["chunks_resumed"] == 1
    assert (tmp_path / "samples.csv").read_bytes() == before


def test_a_folder_of_another_study_or_of_something_else_is_refused(tmp_path):
    run_study(_study(n=20), "mc", tmp_path / "a", judge_samples=0)
    with pytest.raises(ValueError, match="holds another study"):
        run_study(_study(n=21), "mc", tmp_path / "a", judge_samples=0)
    (tmp_path / "b").mkdir()
    (tmp_path / "b/notes.txt").write_text("mine")
    with pytest.raises(ValueError, match="not empty"):
        run_study(_study(n=20), "mc", tmp_path / "b", judge_samples=0)


def test_a_dask_cluster_gives_the_same_samples_and_summary(tmp_path):
    distributed = pytest.importorskip("distributed")
    study = _study(n=40)
    run_study(study, "both", tmp_path / "local", jobs=1, judge_samples=0)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        run_study(study, "both", tmp_path / "dask", scheduler=cluster.scheduler_address, judge_samples=0)
    assert (tmp_path / "local/samples.csv").read_bytes() == (tmp_path / "dask/samples.csv").read_bytes()
    assert _without_timing(tmp_path / "local/summary.json") == _without_timing(tmp_path / "dask/summary.json")


class _Stop(Exception):
    """Stands for an interruption (Ctrl-C) while the study writes a chunk."""


def _interrupted(tmp_path, monkeypatch, study):
    """Run ``study`` in this process, stopped while chunk 1 goes to the samples files: the chunks stored."""
    real_add = SampleStream.add

    def add(self, index, x, outputs):
        if index == 1:
            raise _Stop
        real_add(self, index, x, outputs)

    with monkeypatch.context() as m:
        m.setattr(SampleStream, "add", add)
        with pytest.raises(_Stop):
            run_study(study, "mc", tmp_path, judge_samples=0)
    assert not list(tmp_path.glob("samples.*"))  # the unfinished files were removed, none renamed
    return {int(p.stem.split("-")[1]) for p in (tmp_path / "chunks").glob("chunk-*.npz")}


def test_chunks_in_flight_when_stopped_are_kept_and_the_study_resumes_the_same(tmp_path, monkeypatch):
    """Chunks run two at a time in this process: stopped at chunk 1, chunk 2 (solving meanwhile) is stored
    too, and the resumed study writes the same rows as one never stopped."""
    study = _study(n=6 * CHUNK_DESIGNS)
    assert _interrupted(tmp_path / "stopped", monkeypatch, study) >= {0, 1, 2}
    summary, _, _ = run_study(study, "mc", tmp_path / "stopped", judge_samples=0)
    assert summary["timing"]["chunks_resumed"] >= 3
    run_study(study, "mc", tmp_path / "whole", judge_samples=0)
    assert (tmp_path / "stopped/samples.csv").read_bytes() == (tmp_path / "whole/samples.csv").read_bytes()
    stopped, whole = (_without_timing(tmp_path / f"{d}/summary.json") for d in ("stopped", "whole"))
    assert stopped == whole


def test_the_in_flight_check_sees_chunks_dropped_when_stopped(tmp_path, monkeypatch):
    """Deliberate fault: the chunks that finished while the study was stopping are not handed back."""
    real = tolerance_study.in_process
    monkeypatch.setattr(tolerance_study, "in_process", lambda calls, leftovers: real(calls, []))
    assert not _interrupted(tmp_path, monkeypatch, _study(n=6 * CHUNK_DESIGNS)) >= {0, 1, 2}
