"""A run folder received from someone else is untrusted input (issue 31): paths that leave it, links,
FIFOs, a planted lock, damaged run.json, case files and manifests.

Each attack is made on a copy of one finished run folder placed at ``tmp_path/outside/deep/run``; the
checks are those of the issue: nothing outside the run folder written or deleted, one line on stderr, exit
code 2 (bad input), and no hang (every command runs in a subprocess with a time limit).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from dualmech.validation.matrix import load_matrix
from dualmech.validation.report.render import write_report
from dualmech.validation.run.runner import run_matrix
from dualmech.validation.rundir import RunDirError, locked
from tests.validation.conftest import SMALL
from tests.validation.test_validate import FAKE_REGISTRY, ROOT

#: Seconds a refused command may take (start-up and imports; a hang on a FIFO would never end).
COMMAND_LIMIT_S = 120


@pytest.fixture(scope="module")
def pristine(tmp_path_factory) -> Path:
    """One finished run of the SMALL matrix with its report (stand-in engines)."""
    base = tmp_path_factory.mktemp("pristine")
    small = base / "small.toml"
    small.write_text(SMALL)
    out = base / "run"
    run_matrix(load_matrix(small), out, jobs=1, registry=FAKE_REGISTRY)
    write_report(out, None, jobs=1)
    return out


@pytest.fixture()
def run(pristine: Path, tmp_path: Path) -> Path:
    """A copy of :func:`pristine` three folders below ``tmp_path``."""
    dest = tmp_path / "outside" / "deep" / "run"
    shutil.copytree(pristine, dest, symlinks=True)
    return dest


def _outside(tmp_path: Path, run: Path) -> dict[str, bytes | str]:
    """Every entry under ``tmp_path`` but the run folder: path -> content (a link: its target)."""
    found: dict[str, bytes | str] = {}
    for p in sorted(tmp_path.rglob("*")):
        if p == run or run in p.parents:
            continue
        if p.is_symlink():
            found[str(p)] = "-> " + os.readlink(p)
        elif p.is_file():
            found[str(p)] = p.read_bytes()
        else:
            found[str(p)] = "folder" if p.is_dir() else "special"
    return found


def dualmech(*args: str, limit: float = COMMAND_LIMIT_S) -> tuple[int, list[str]]:
    """``dualmech ARGS`` in a subprocess: its exit code and the non-empty lines of its stderr."""
    path = os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])
    proc = subprocess.run([sys.executable, "-m", "dualmech.cli", *args], cwd=ROOT, capture_output=True,
                          text=True, timeout=limit, env=dict(os.environ, PYTHONPATH=path))
    return proc.returncode, [ln for ln in proc.stderr.splitlines() if ln.strip()]


def _refused(run: Path, *words: str) -> None:
    """``dualmech report RUN`` exits 2 with one line holding ``words``."""
    code, lines = dualmech("report", str(run), "--jobs", "1")
    assert code == 2 and len(lines) == 1, (code, lines)
    for w in words:
        assert w in lines[0], lines[0]


def _edit_json(path: Path, edit) -> None:
    data = json.loads(path.read_text())
    edit(data)
    path.write_text(json.dumps(data))


@pytest.mark.parametrize("entry", ["figures/../../../victim", "figures/../../../outside/victim2",
                                   "figures//victim", "/victim"])
def test_a_manifest_path_leaving_the_folder_is_refused_and_nothing_deleted(pristine, run, tmp_path, entry):
    """Why: a manifest listing ``figures/../../../x`` made ``report`` delete a file outside the folder."""
    (tmp_path / "victim").write_text("precious")
    (tmp_path / "outside" / "victim2").write_text("precious too")
    before = _outside(tmp_path, run)
    _edit_json(run / "manifest.json", lambda m: m["files"].append(entry))
    _refused(run, "manifest.json", "files[")
    with pytest.raises(RunDirError, match="manifest.json"):  # validate --resume: refused at the lock
        _resume(run, pristine)
    assert _outside(tmp_path, run) == before


def _resume(run: Path, pristine: Path) -> None:
    """``validate --resume`` of the run folder (the stand-in engines; the pristine run's matrix file)."""
    run_matrix(load_matrix(pristine.parent / "small.toml"), run, jobs=1, resume=True, registry=FAKE_REGISTRY)


def test_a_lock_file_that_is_a_link_is_never_written_through(pristine, run, tmp_path):
    """Why: a ``.dualmech.lock`` linked to an outside file had that file truncated and the PID written in."""
    victim = tmp_path / "victim"
    victim.write_text("precious")
    (run / ".dualmech.lock").unlink(missing_ok=True)
    (run / ".dualmech.lock").symlink_to(victim)
    _refused(run, ".dualmech.lock", "link")
    with pytest.raises(RunDirError, match="link"):
        _resume(run, pristine)
    assert victim.read_text() == "precious"


def test_a_lock_file_hard_linked_to_another_file_is_refused(pristine, run, tmp_path):
    victim = tmp_path / "victim"
    victim.write_text("precious")
    (run / ".dualmech.lock").unlink(missing_ok=True)
    os.link(victim, run / ".dualmech.lock")
    with pytest.raises(RunDirError, match="hard link"):
        _resume(run, pristine)
    assert victim.read_text() == "precious"


def test_a_figures_link_to_an_outside_folder_is_refused(run, tmp_path):
    """Why: a ``figures/`` link made the report's PNGs land outside the folder."""
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    shutil.rmtree(run / "figures")
    (run / "figures").symlink_to(elsewhere, target_is_directory=True)
    _refused(run, "figures", "link")
    assert list(elsewhere.iterdir()) == []


@pytest.mark.parametrize("matrix", [5, [1, 2], "thesis", {}, {"name": "small"}, None])
def test_a_run_json_whose_matrix_is_not_a_matrix_is_one_line(run, matrix):
    """Why: ``matrix`` a number or a list gave an internal error."""
    _edit_json(run / "run.json", lambda r: r.update(matrix=matrix))
    _refused(run, "run.json", "matrix")


def test_a_run_json_case_id_leaving_the_folder_is_refused(run):
    _edit_json(run / "run.json", lambda r: r["matrix"]["cases"][0].update(id="../../victim"))
    _refused(run, "run.json", "case id")


def _first_case_file(run: Path) -> Path:
    return sorted((run / "cases").iterdir())[0]


@pytest.mark.parametrize("field, value, words", [
    ("engines", [], ("engines", "expected an object")),
    ("engines", {"dualmech": []}, ("engines.dualmech",)),
    ("engines", {"dualmech": {"engine": "dualmech"}}, ("engines.dualmech", "neither a table nor an error")),
    ("id", 7, ("id",)),
    ("raw", "x", ("raw",)),
])
def test_a_case_file_breaking_its_format_is_one_line(run, field, value, words):
    """Why: a case file with ``"engines": []`` gave an internal error."""
    case = _first_case_file(run)
    _edit_json(case, lambda c: c.update({field: value}))
    _refused(run, case.name, *words)


@pytest.mark.parametrize("damage, words", [
    (lambda t: t["columns"].update(S4=["a", "b"]), ("columns.S4", "numbers")),
    (lambda t: t["columns"].update(S4=t["columns"]["S4"][:-1]), ("columns.S4", "rows")),
    (lambda t: t["columns"].pop("S4"), ("columns.S4", "missing")),
    (lambda t: t.update(status=["exploded"] * len(t["status"])), ("status", "status words")),
])
def test_a_damaged_stored_table_is_one_line(run, damage, words):
    case = _first_case_file(run)
    _edit_json(case, lambda c: damage(c["engines"]["dualmech"]["table"]))
    _refused(run, case.name, *words)


@pytest.mark.parametrize("where", ["case", "run.json", "manifest.json", ".dualmech.lock"])
def test_a_fifo_in_the_run_folder_is_refused_without_a_hang(run, where):
    """Why: a case file replaced by a FIFO made ``report`` wait forever."""
    path = _first_case_file(run) if where == "case" else run / where
    path.unlink(missing_ok=True)
    os.mkfifo(path)
    _refused(run, path.name, "FIFO")


def test_a_cases_folder_linked_elsewhere_is_not_followed(run, tmp_path):
    elsewhere = tmp_path / "elsewhere"
    shutil.move(run / "cases", elsewhere)
    (run / "cases").symlink_to(elsewhere, target_is_directory=True)
    _refused(run, "cases", "link")


def test_a_run_json_linked_to_an_outside_file_is_not_read(run, tmp_path):
    shutil.move(run / "run.json", tmp_path / "run.json")
    (run / "run.json").symlink_to(tmp_path / "run.json")
    _refused(run, "run.json", "link")


def test_a_planted_errata_link_is_replaced_not_written_through(pristine, tmp_path):
    """The report copies docs/errata.md beside it: a planted ``errata.md`` link must not be written through
    (a thesis matrix copies it; the check is on the folder's writer)."""
    from dualmech.validation import rundir

    out = tmp_path / "run"
    shutil.copytree(pristine, out, symlinks=True)
    victim = tmp_path / "victim"
    victim.write_text("precious")
    (out / "errata.md").unlink(missing_ok=True)
    (out / "errata.md").symlink_to(victim)
    with pytest.raises(RunDirError, match="link"):
        with locked(out):
            rundir.write_file(out, "errata.md", "errata")
    assert victim.read_text() == "precious"
