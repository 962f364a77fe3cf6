"""``dualmech selftest``: the catalogue cannot go stale silently, and the harness reports kills and survivors.

The full mutation run is a CI step (``.ci/run``); here the harness runs on a
three-fault catalogue against a one-case matrix, so that this module stays fast.
"""

from __future__ import annotations

import hashlib
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from dualmech.validation.selftest import (
    BOOT,
    CATALOGUE,
    CLASSES,
    PACKAGES,
    WRONG_IMPORT,
    Catalogue,
    Mutant,
    SelftestError,
    format_report,
    load_catalogue,
    make_scratch,
    parse_catalogue,
    run_selftest,
    source_root,
    stale_reason,
)

ROOT = source_root()
FULL = load_catalogue(ROOT / CATALOGUE)
#: The issue asks for at least 30 faults; the brief for this harness at least 32.
MIN_MUTANTS = 32


@pytest.mark.parametrize("page", ["README.md", "docs/index.md", "docs/validation.md"])
def test_the_pages_state_the_catalogues_size(page: str):
    """Each number of deliberate faults a page states is the catalogue's (seen failing before: the README and
    the docs' index said 74 of 77)."""
    text = (ROOT / page).read_text()
    stated = {int(n) for n in re.findall(r"(\d+) (?:deliberate )?faults", text)}
    assert stated == {len(FULL.mutants)}, f"{page} states {sorted(stated)}"


def test_catalogue_has_enough_faults_in_every_class():
    assert len(FULL.mutants) >= MIN_MUTANTS
    assert {m.fault_class for m in FULL.mutants} == set(CLASSES)
    assert (ROOT / FULL.matrix).is_file()


@pytest.mark.parametrize("entry", FULL.tests)
def test_every_gate_test_exists(entry: str):
    """A test path or node id (also one deselected) that no longer exists would silently test nothing."""
    path, _, node = entry.removeprefix("--deselect=").partition("::")
    assert (ROOT / path).is_file(), entry
    assert not node or f"def {node.split('[')[0]}(" in (ROOT / path).read_text(), entry


@pytest.mark.parametrize("mutant", FULL.mutants, ids=[m.id for m in FULL.mutants])
def test_every_fault_applies_to_the_current_source(mutant: Mutant):
    """Each ``old`` text occurs exactly once in its file: a refactor that moves it fails here, not quietly."""
    assert stale_reason(mutant, ROOT) is None, f"{mutant.id}: {stale_reason(mutant, ROOT)}"


def _one(**over) -> dict:
    m = {"id": "x", "file": "core/dual.py", "class": "solver", "description": "d", "old": "a", "new": "b",
         **over}
    return {"matrix": "m.toml", "mutant": [m]}


@pytest.mark.parametrize("data, words", [
    (_one(new="a"), ["mutant x.new", "identical"]),
    (_one(**{"class": "typo"}), ["mutant x.class", "solver", "'typo'"]),
    (_one(id="a b"), ["mutant[0].id", "'a b'"]),
    ({"matrix": "m.toml", "mutant": []}, ["mutant", "at least one"]),
    ({"mutant": _one()["mutant"]}, ["matrix", "None"]),
    ({**_one(), "extra": 1}, ["extra", "unknown key"]),
    ({"matrix": "m.toml", "mutant": [_one()["mutant"][0], {**_one()["mutant"][0], "id": "y"}]},
     ["mutant y", "same edit of core/dual.py as mutant x"]),
])
def test_bad_catalogue_is_one_line(data, words):
    with pytest.raises(SelftestError) as err:
        parse_catalogue(data)
    msg = str(err.value)
    assert "\n" not in msg and all(w in msg for w in words), msg


def test_stale_fault_is_reported(tmp_path):
    (tmp_path / "f.py").write_text("x = 1\nx = 1\n")
    twice = Mutant("m", "f.py", "x = 1", "x = 2", "solver", "d")
    assert "2 times" in stale_reason(twice, tmp_path)
    assert "does not exist" in stale_reason(Mutant("m", "g.py", "x", "y", "solver", "d"), tmp_path)


def test_boot_refuses_a_copy_that_is_not_what_gets_imported(tmp_path):
    """Without the copy's package links the gate process must stop with WRONG_IMPORT, never fall back."""
    proc = subprocess.run([sys.executable, "-c", BOOT, str(tmp_path)], capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == WRONG_IMPORT, proc.stderr
    assert "not in" in proc.stderr


SMALL_MATRIX = """
name = "selftest-unit"
base = "thesis/ideal"
engines = ["dualmech", "pinocchio"]
reference = "dualmech"
set = { "motion.angles_deg" = { start = 0.0, stop = 360.0, step = 10.0 } }
[[sweep]]
name = "one"
cases = [ { "geometry.slider_offset" = 10.0, "geometry.crank_axial_shift" = 1.0 } ]
include_base = false
"""


def _digest(paths: list[Path]) -> str:
    return hashlib.sha256(b"".join(p.read_bytes() for p in paths)).hexdigest()


def test_harness_kills_reports_survivors_and_stale_faults(tmp_path):
    """A judge's sign (matrix), the S1 law (tests: the one-case matrix has no axial motion), a no-op edit
    that must SURVIVE, and a stale fault that must be an ERROR; the checkout is left untouched.

    The matrix kill also shows that the scratch copy is what runs: the checkout has no such fault."""
    matrix = tmp_path / "small.toml"
    matrix.write_text(SMALL_MATRIX)
    by_id = {m.id: m for m in FULL.mutants}
    noop = Mutant("comment-only", "core/reactions.py",
                  "# D'Alembert: what the joints must supply to each body",
                  "# D'Alembert: the joints supply to each body", "solver", "a comment edit: no behaviour")
    stale = Mutant("stale", "core/reactions.py", "this text is not in the file", "x", "solver", "stale")
    cat = Catalogue((by_id["pin-acceleration-sign"], by_id["s1-law-cos"], noop, stale), str(matrix),
                    ("tests/models/test_common_mode.py",))
    files = sorted({ROOT / m.file for m in cat.mutants})
    before = _digest(files)
    report = run_selftest(cat, ROOT, jobs=2, timeout=600)  # generous: CI machines may be shared
    assert _digest(files) == before
    assert report.pristine.verdict == "pass", report.pristine.detail
    verdicts = {o.mutant.id: o.run.verdict for o in report.outcomes}
    assert verdicts == {"pin-acceleration-sign": "matrix", "s1-law-cos": "tests", "comment-only": "pass",
                        "stale": "error"}, report.outcomes
    assert report.killed == 2 and not report.passed
    text = format_report(report, jobs=2)
    assert "SURVIVED" in text and "ERROR" in text
    assert "mutation score: 2/4 killed (50.0 %)" in text


def test_unknown_mutant_id_is_refused():
    with pytest.raises(SelftestError, match="'nope' is not a mutant"):
        run_selftest(FULL, ROOT, only=("nope",))


def test_an_interrupted_selftest_kills_its_running_gates_and_does_not_wait_for_them(tmp_path, monkeypatch):
    """Why (issue 31): Ctrl-C while mutants were gated waited for every running gate step (minutes each:
    the thread pool's exit joins its threads) and left the gate processes running meanwhile."""
    import time

    from dualmech.validation.selftest import gate, run
    from dualmech.validation.selftest.run import Outcome

    monkeypatch.setattr(gate, "BOOT", "")  # the gate process runs the code below only
    monkeypatch.setattr(run, "make_scratch", lambda root, dest, mutant=None: dest)
    monkeypatch.setattr(run, "run_gate", lambda *args, **kwargs: gate.GateRun("pass", 0.0))
    first, second = FULL.mutants[:2]
    started: list[int] = []

    def gate_mutant(m, *args) -> Outcome:
        if m is first:
            deadline = time.monotonic() + 60.0
            while not gate._RUNNING and time.monotonic() < deadline:  # the second's gate process is running
                time.sleep(0.01)
            started.extend(p.pid for p in gate._RUNNING)
            return Outcome(m, gate.GateRun("matrix", 0.0))
        code, _, _ = gate._python(tmp_path, "import time; time.sleep(120)", [], 300.0)
        return Outcome(m, gate.GateRun("timeout" if code is None else "crash", 0.0))

    def ctrl_c(outcome: Outcome) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(run, "_gate_mutant", gate_mutant)
    start = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        run._run(FULL, tmp_path, [first, second], 2, 300.0, ctrl_c, tmp_path, False)
    assert time.monotonic() - start < 30.0
    deadline = time.monotonic() + 10.0
    while Path(f"/proc/{started[0]}").exists() and time.monotonic() < deadline:
        time.sleep(0.05)
    assert started and not Path(f"/proc/{started[0]}").exists()


def test_scratch_packages_are_pyprojects_package_dirs():
    """The copy links the folders pyproject.toml installs, so a layout move cannot leave a package out."""
    with open(ROOT / "pyproject.toml", "rb") as f:
        package_dir = tomllib.load(f)["tool"]["setuptools"]["package-dir"]
    assert PACKAGES == package_dir


def test_every_module_of_a_scratch_copy_is_imported_from_the_copy(tmp_path):
    """Every module of every package, the ``dualmech`` front door included, comes from the copy."""
    scratch = make_scratch(ROOT, tmp_path / "copy")
    code = BOOT + (
        "import importlib, pkgutil, dualmech\n"
        "names = ['dualmech'] + [m.name for m in pkgutil.walk_packages(dualmech.__path__, 'dualmech.')\n"
        "                       if not m.name.endswith('__main__')]\n"
        "for name in names:\n"
        "    print(name, importlib.import_module(name).__file__)\n")
    proc = subprocess.run([sys.executable, "-c", code, str(scratch)], capture_output=True, text=True,
                          cwd=scratch, timeout=300)
    assert proc.returncode == 0, proc.stderr
    files = dict(line.split(" ", 1) for line in proc.stdout.splitlines())
    assert {"dualmech", "dualmech.verbs", "dualmech.core.dual", "dualmech.cli.solve"} <= set(files)
    outside = {n: f for n, f in files.items() if not f.startswith(str(scratch / ".pkg") + "/")}
    assert not outside


def test_the_gates_tests_draw_the_ci_examples_and_do_not_shrink():
    """The gate's test processes load the ``selftest`` Hypothesis profile (tests/conftest.py): the CI
    profile's derandomized examples, so a fault is killed by the same examples as in CI, without the shrink
    phase, which took about 40 of a killed fault's 70 s and gives the gate nothing (it needs the verdict, not
    the smallest example)."""
    from hypothesis import Phase, settings

    from dualmech.validation.selftest.gate import _ENV

    assert _ENV["HYPOTHESIS_PROFILE"] == "selftest"
    profile, ci = settings.get_profile("selftest"), settings.get_profile("ci")
    assert profile.derandomize and profile.max_examples == ci.max_examples
    assert Phase.generate in profile.phases and Phase.shrink not in profile.phases
