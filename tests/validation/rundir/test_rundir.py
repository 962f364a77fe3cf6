"""The run folder under attack: foreign folders, planted files, concurrent runs, interrupts, lost clusters
(issue 11)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from typing import Any

import pytest
from click.testing import CliRunner

from dualmech.cli import main
from dualmech.validation.matrix import load_matrix
from dualmech.validation.report.render import write_report
from dualmech.validation.run import executors
from dualmech.validation.run.executors import ClusterLost, check_address
from dualmech.validation.run.runner import load_entries, run_matrix
from dualmech.validation.rundir import RunDirError, created_files, locked
from tests.validation.test_validate import FAKE_REGISTRY, FAKES, ROOT


def _one_line_error(result) -> str:
    lines = [ln for ln in result.output.splitlines() if ln.strip()]
    assert len(lines) == 1, result.output
    return lines[0]


def test_a_foreign_non_empty_folder_is_refused(small, tmp_path):
    foreign = tmp_path / "photos"
    foreign.mkdir()
    (foreign / "holiday.jpg").write_bytes(b"\xff\xd8")
    result = CliRunner().invoke(main, ["validate", str(small), "-o", str(foreign), "--jobs", "1"])
    assert result.exit_code == 2
    assert "not empty and not a dualmech run" in _one_line_error(result)
    assert sorted(p.name for p in foreign.iterdir()) == ["holiday.jpg"]


def test_a_report_deletes_only_what_dualmech_wrote(small, tmp_path):
    """Why: a planted figures/photo.png in the output folder was deleted."""
    matrix = load_matrix(small)
    out = tmp_path / "run"
    run_matrix(matrix, out, jobs=1, registry=FAKE_REGISTRY)
    write_report(out, None, jobs=1)
    planted = out / "figures" / "photo.png"
    planted.write_bytes(b"not a figure of ours")
    stale = out / "figures" / "old-figure.png"
    stale.write_bytes(b"x")
    manifest = json.loads((out / "manifest.json").read_text())
    manifest["files"].append("figures/old-figure.png")  # as if an earlier report had drawn it
    (out / "manifest.json").write_text(json.dumps(manifest))
    write_report(out, None, jobs=1)
    assert planted.read_bytes() == b"not a figure of ours"
    assert not stale.exists()
    assert "figures/photo.png" not in created_files(out) and "report.html" in created_files(out)


def test_a_second_concurrent_run_is_refused(small, tmp_path):
    """The lock holds across processes (within one, it is taken again by nested calls: one writer)."""
    out = tmp_path / "run"
    holder = subprocess.Popen(
        [sys.executable, "-c", "import time; from dualmech.validation.rundir import locked\n"
         f"with locked({str(out)!r}):\n print('held', flush=True); time.sleep(60)"],
        stdout=subprocess.PIPE, text=True, cwd=ROOT)
    try:
        assert holder.stdout.readline().strip() == "held"
        with pytest.raises(RunDirError, match="in use by another dualmech run"):
            run_matrix(load_matrix(small), out, jobs=1, registry=FAKE_REGISTRY)
    finally:
        holder.kill()
        holder.wait()
    with locked(out):  # nested in one process: the holder keeps its lock
        run_matrix(load_matrix(small), out, jobs=1, registry=FAKE_REGISTRY)
    run_matrix(load_matrix(small), out, jobs=1, registry=FAKE_REGISTRY)  # free again once the holder is gone


@pytest.mark.parametrize(
    "address", ["", " ", "tcp://", "localhost", "tcp://127.0.0.1:99999", "http://x:1", "a b:1"]
)
def test_a_malformed_scheduler_address_is_refused(address):
    with pytest.raises(ValueError, match="scheduler: expected an address"):
        check_address(address)


def test_sigint_keeps_every_finished_result(small, tmp_path):
    """Why: SIGINT lost a few finished tasks.  Every task that finished before the interrupt is stored."""
    out, marks = tmp_path / "run", tmp_path / "marks"
    marks.mkdir()
    slow = {e: f"{FAKES}:solve_case_marked_{e}" for e in FAKE_REGISTRY}
    # SIGINT handled as at a terminal, even when this test runs as a background job (SIG_IGN inherited)
    script = (
        "import signal; signal.signal(signal.SIGINT, signal.default_int_handler); "
        "from dualmech.validation.matrix import load_matrix; from dualmech.validation.run.runner import "
        "run_matrix; "
        f"run_matrix(load_matrix({str(small)!r}), {str(out)!r}, jobs=2, registry={slow!r})"
    )
    env = dict(os.environ, MATRIX_FAKES_DELAY="0.25", MATRIX_FAKES_MARKS=str(marks), PYTHONPATH=str(ROOT))
    proc = subprocess.Popen([sys.executable, "-c", script], cwd=ROOT, env=env, stderr=subprocess.PIPE)
    deadline = time.time() + 60
    while time.time() < deadline and len(list(marks.iterdir())) < 4:
        time.sleep(0.02)
    proc.send_signal(signal.SIGINT)
    proc.wait(timeout=30)
    finished = {p.name for p in marks.iterdir()}
    stored = {f"{cid}--{e}" for cid, per in load_entries(out, load_matrix(small)).items() for e in per}
    assert 4 <= len(finished) < len(load_matrix(small).cases) * 3
    assert finished <= stored, sorted(finished - stored)


@pytest.mark.parametrize("what", ["scheduler", "workers"])
def test_a_lost_cluster_ends_the_run_with_one_line_and_keeps_results(small, tmp_path, monkeypatch, what):
    """Why: a killed Dask scheduler gave a 39-line traceback; losing every worker hung with no message."""
    distributed = pytest.importorskip("distributed")
    monkeypatch.setattr(executors, "DASK_POLL_S", 0.2)
    monkeypatch.setattr(executors, "DASK_NO_WORKER_S", 2.0)
    monkeypatch.setattr(executors, "DASK_RESULT_S", 2.0)
    monkeypatch.setenv("MATRIX_FAKES_DELAY", "0.4")
    slow = dict(FAKE_REGISTRY, dualmech=f"{FAKES}:solve_case_slow")
    out = tmp_path / "run"
    cluster = distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1",
                                       dashboard_address=None)
    with distributed.Client(cluster) as client:
        client.run(lambda root: sys.path.insert(0, root) if root not in sys.path else None, str(ROOT))
    pull_the_plug = cluster.close if what == "scheduler" else (lambda: cluster.scale(0))
    timer = threading.Timer(2.0, pull_the_plug)
    timer.start()
    start = time.monotonic()
    try:
        with pytest.raises(ClusterLost) as err:
            run_matrix(load_matrix(small), out, scheduler=cluster.scheduler_address, registry=slow)
    finally:
        timer.cancel()
        cluster.close()
    assert "\n" not in str(err.value) and "finished results are kept" in str(err.value)
    assert time.monotonic() - start < 40
    assert load_entries(out, load_matrix(small)), "nothing finished was kept"


class _FinishedFuture:
    """A Dask future reported finished whose result never arrives unless asked with a time limit (seen with
    distributed 2024.1 once its worker was gone: the lost-cluster test above hung in ``result()``)."""

    status = "finished"

    def __init__(self, value: Any, arrives: bool) -> None:
        self.value, self.arrives = value, arrives

    def result(self, timeout: float | None = None) -> Any:
        if timeout is None:
            raise AssertionError("result() without a time limit would wait forever")
        if not self.arrives:
            time.sleep(min(timeout, 0.2))
            raise TimeoutError
        return self.value


def test_results_kept_from_a_lost_cluster_are_fetched_within_a_time_limit():
    futures = [_FinishedFuture({"id": k}, arrives) for k, arrives in ((1, True), (2, False), (3, True))]
    start = time.monotonic()
    assert executors._fetched(futures, {futures[2]}, 1.0) == [{"id": 1}]
    assert time.monotonic() - start < 5.0
