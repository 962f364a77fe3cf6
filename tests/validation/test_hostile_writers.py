"""Every writer follows the run folder's rules and writes whole files (issue 31): the tolerance study's
folder, lock and chunks; ``solve -o`` on a full disk and under Ctrl-C; baselines checked before the run.
"""

from __future__ import annotations

import errno
import json
import os
import resource
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from dualmech.cli import main
from dualmech.validation import durable
from dualmech.validation.compare import compare_run
from dualmech.validation.compare.baseline import baseline_summary, compare_baseline, read_baseline
from dualmech.validation.tolerance.study import run_study

from ..models.tolerance.test_study import _study
from .conftest import fake_results
from .test_validate import ROOT

#: Seconds a command may take here (start-up, a solve of 10^5 positions; a hang would never end).
COMMAND_LIMIT_S = 300
SPEC = '[tolerances]\n"geometry.slider_offset" = { dist = "uniform", low = 20.0, high = 60.0 }\n'
OLD = "the old table, which must survive\n"


def _lines(result) -> list[str]:
    return [ln for ln in result.output.splitlines() if ln.strip()]


def _spec(tmp_path: Path) -> Path:
    path = tmp_path / "spec.toml"
    path.write_text(SPEC)
    return path


def _holding(folder: Path) -> subprocess.Popen:
    """Another process holding ``folder``'s lock (returns once it holds it)."""
    holder = subprocess.Popen(
        [sys.executable, "-c", "import time; from dualmech.validation.rundir import locked\n"
         f"with locked({str(folder)!r}):\n print('held', flush=True); time.sleep(120)"],
        stdout=subprocess.PIPE, text=True, cwd=ROOT)
    assert holder.stdout.readline().strip() == "held"
    return holder


# ----------------------------------------------------------------------------- tolerance studies

def test_a_linear_study_refuses_a_folder_that_is_not_dualmechs(tmp_path):
    """Why: ``tolerance --method linear -o DIR`` overwrote a user's summary.json and report.md."""
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "summary.json").write_text('{"my": "numbers"}')
    (mine / "report.md").write_text("my report")
    before = {p.name: p.read_bytes() for p in mine.iterdir()}
    spec = str(_spec(tmp_path))
    result = CliRunner().invoke(main, ["tolerance", "thesis/ideal", "--spec", spec, "--method", "linear",
                                       "-o", str(mine), "--judge-samples", "0"])
    assert result.exit_code == 2 and len(_lines(result)) == 1, result.output
    assert "not empty and not a dualmech run" in result.output
    assert {p.name: p.read_bytes() for p in mine.iterdir()} == before


def test_a_second_study_into_the_same_folder_is_refused_by_the_lock(tmp_path):
    """Why: two studies ran at once in one folder; one died with a raw ``[Errno 2] ... samples.csv.tmp``."""
    folder = tmp_path / "study"
    holder = _holding(folder)
    try:
        result = CliRunner().invoke(main, ["tolerance", "thesis/ideal", "--spec", str(_spec(tmp_path)), "-n",
                                           "20", "-o", str(folder), "--judge-samples", "0"])
    finally:
        holder.kill()
        holder.wait()
    assert result.exit_code == 2 and len(_lines(result)) == 1, result.output
    assert "in use by another dualmech run" in result.output
    assert not (folder / "samples.csv").exists() and not (folder / "study.json").exists()


def test_a_truncated_chunk_is_solved_again(tmp_path):
    """Why: a truncated chunk file crashed the resume (``BadZipFile``)."""
    study = _study()
    run_study(study, "mc", tmp_path, judge_samples=0)
    whole = (tmp_path / "samples.csv").read_bytes()
    chunk = tmp_path / "chunks" / "chunk-000000.npz"
    chunk.write_bytes(chunk.read_bytes()[: chunk.stat().st_size // 2])
    summary, _, _ = run_study(study, "mc", tmp_path, judge_samples=0)
    assert summary["timing"]["chunks_run"] == 1
    assert (tmp_path / "samples.csv").read_bytes() == whole


def test_a_chunk_of_another_study_is_solved_again_not_mixed_in(tmp_path):
    """Why: a chunk copied from another study was accepted and its designs mixed into samples.csv."""
    run_study(_study(seed=8), "mc", tmp_path / "a", judge_samples=0)
    run_study(_study(seed=9), "mc", tmp_path / "b", judge_samples=0)
    whole = (tmp_path / "a" / "samples.csv").read_bytes()
    shutil.copyfile(tmp_path / "b/chunks/chunk-000001.npz", tmp_path / "a/chunks/chunk-000001.npz")
    summary, _, _ = run_study(_study(seed=8), "mc", tmp_path / "a", judge_samples=0)
    assert summary["timing"]["chunks_run"] == 1
    assert (tmp_path / "a" / "samples.csv").read_bytes() == whole


def test_a_chunk_with_a_wrong_shape_is_solved_again(tmp_path):
    study = _study()
    run_study(study, "mc", tmp_path, judge_samples=0)
    whole = (tmp_path / "samples.csv").read_bytes()
    chunk = tmp_path / "chunks" / "chunk-000000.npz"
    with np.load(chunk) as data:
        arrays = {k: data[k] for k in data.files}
    arrays["x"] = arrays["x"][:-1]
    with chunk.open("wb") as fh:
        np.savez(fh, **arrays)
    summary, _, _ = run_study(study, "mc", tmp_path, judge_samples=0)
    assert summary["timing"]["chunks_run"] == 1
    assert (tmp_path / "samples.csv").read_bytes() == whole


# ----------------------------------------------------------------------------- solve -o: whole or not at all

def _case_file(tmp_path: Path, positions: int) -> Path:
    """The thesis's ideal case on ``positions`` crank angles over one turn."""
    text = (ROOT / "models/cases/thesis/ideal.toml").read_text()
    step = 360.0 / positions
    text = text.replace("angles_deg = { start = 0.0, stop = 360.0, step = 1.0 }",
                        f"angles_deg = {{ start = 0.0, stop = {360.0 - step!r}, step = {step!r} }}")
    path = tmp_path / "long.toml"
    path.write_text(text)
    return path


def _small_disk(limit: int):
    """For a child process: files may grow to ``limit`` bytes only (a full disk: writes fail with EFBIG)."""
    def apply() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    return apply


def _run(args: list[str], **kwargs) -> subprocess.CompletedProcess:
    path = os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])
    return subprocess.run([sys.executable, "-m", "dualmech.cli", *args], cwd=ROOT, capture_output=True,
                          text=True, timeout=COMMAND_LIMIT_S, env=dict(os.environ, PYTHONPATH=path), **kwargs)


@pytest.mark.parametrize("positions", [360, 100_010], ids=["table", "streamed"])
def test_solve_onto_a_full_disk_keeps_the_old_file(tmp_path, positions):
    """Why: ``solve -o out.csv`` onto a full disk destroyed the old table and left a partial one."""
    case = "thesis/ideal" if positions == 360 else str(_case_file(tmp_path, positions))
    folder = tmp_path / "out"
    folder.mkdir()
    out = folder / "out.csv"
    out.write_text(OLD)
    proc = _run(["solve", case, "-o", str(out)], preexec_fn=_small_disk(16_384))
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert proc.returncode == 2 and len(lines) == 1, proc.stderr
    assert out.read_text() == OLD
    assert [p.name for p in folder.iterdir()] == ["out.csv"]  # no partial file left beside it


def test_ctrl_c_during_a_long_csv_solve_keeps_the_old_file_and_no_partial(tmp_path):
    """Why: Ctrl-C during a large CSV solve left 200,000 rows with a cut last line, marked nowhere."""
    case = _case_file(tmp_path, 200_000)
    folder = tmp_path / "out"
    folder.mkdir()
    out = folder / "out.csv"
    out.write_text(OLD)
    path = os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])
    script = ("import signal; signal.signal(signal.SIGINT, signal.default_int_handler); "
              "from dualmech.cli import main; main()")
    proc = subprocess.Popen([sys.executable, "-c", script, "solve", str(case), "-o", str(out)], cwd=ROOT,
                            env=dict(os.environ, PYTHONPATH=path), stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + COMMAND_LIMIT_S
    try:
        while time.monotonic() < deadline and proc.poll() is None and not _grown(folder, 1_000_000):
            time.sleep(0.01)
        assert proc.poll() is None, "the solve ended before it could be interrupted"
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=60)
    finally:
        proc.kill()
    assert out.read_text() == OLD
    assert [p.name for p in folder.iterdir()] == ["out.csv"]


def _grown(folder: Path, size: int) -> bool:
    """Whether a file in ``folder`` holds more than ``size`` bytes (the solve is writing)."""
    for p in folder.iterdir():
        try:
            if p.stat().st_size > size:
                return True
        except FileNotFoundError:  # renamed or removed meanwhile
            pass
    return False


def test_a_failed_write_leaves_the_old_file_and_no_partial(tmp_path, monkeypatch):
    """ENOSPC in the middle of a write (as on a full disk): the old file stays, the partial one goes."""
    out = tmp_path / "summary.json"
    out.write_text(OLD)
    written = []

    def full(fd: int, data) -> int:
        if written:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        written.append(len(data[:4096]))
        return os.write(fd, data[:4096])

    monkeypatch.setattr(durable.os, "write", full)
    with pytest.raises(OSError, match="No space left"):
        durable.write_text_durable(out, "x" * 100_000)
    assert out.read_text() == OLD and [p.name for p in tmp_path.iterdir()] == ["summary.json"]


# ----------------------------------------------------------------------------- baselines

@pytest.fixture()
def baseline(matrix) -> dict:
    results = fake_results(matrix)
    return baseline_summary(matrix, compare_run(matrix, results), results)


@pytest.mark.parametrize("drop, field", [("cases", "cases"), ("passed", "passed"), ("matrix", "matrix")])
def test_a_baseline_without_a_needed_field_is_refused_when_read(tmp_path, baseline, drop, field):
    """Why: a baseline without ``cases`` or ``passed`` was found broken only after the whole run."""
    if drop == "passed":
        case = next(iter(baseline["cases"].values()))
        next(iter(next(iter(case["checks"].values())).values())).pop("passed")
    else:
        baseline.pop(drop)
    path = tmp_path / "baseline.json"
    path.write_text(json.dumps(baseline))
    with pytest.raises(ValueError, match=f"baseline: .*{field}.*missing") as err:
        read_baseline(path, "small")
    assert "\n" not in str(err.value)


def test_a_baseline_of_another_matrix_is_refused_not_no_regression(tmp_path, baseline):
    """Why: a baseline of another matrix reported "no regression"."""
    path = tmp_path / "baseline.json"
    path.write_text(json.dumps(dict(baseline, matrix="thesis-1991")))
    with pytest.raises(ValueError, match="for matrix 'thesis-1991', not 'small'"):
        read_baseline(path, "small")
    regressions = compare_baseline(baseline, dict(baseline, matrix="thesis-1991"))
    assert len(regressions) == 1 and "another matrix" in str(regressions[0])


def test_validate_refuses_a_broken_baseline_before_running(small, tmp_path, baseline):
    path = tmp_path / "baseline.json"
    baseline.pop("cases")
    path.write_text(json.dumps(baseline))
    out = tmp_path / "run"
    result = CliRunner().invoke(main, ["validate", str(small), "-o", str(out), "--baseline", str(path)])
    assert result.exit_code == 2 and len(_lines(result)) == 1, result.output
    assert "cases" in result.output and not out.exists()


def test_a_baseline_that_is_a_fifo_is_refused_without_a_hang(tmp_path):
    path = tmp_path / "baseline.json"
    os.mkfifo(path)
    with pytest.raises(ValueError, match="FIFO"):
        read_baseline(path)
