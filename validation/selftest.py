"""``dualmech selftest``: the validation gate proves it can fail (mutation testing).

A catalogue (``validation/mutants.toml``) lists deliberate faults, each one small
source change -- ``old`` text replaced by ``new`` text in one file -- in the
in-house solver, in the inputs every engine shares, in each judge and in the
comparison itself.  For every fault this module

1. copies the source tree (``core/``, ``models/``, ``validation/``, ``tests/``,
   ``docs/``, ``reports/``, ``pyproject.toml``, ``README.md``) to a scratch
   directory and applies the fault there (the checkout is never touched);
2. runs **the gate** on the scratch copy in fresh Python processes that import
   the scratch copy, not the installed package (:data:`BOOT` removes the
   editable-install finder and checks every ``dualmech`` package's
   ``__file__``):

   a. the catalogue's validation matrix (``matrix``, a fast subset of the default
      one that still exercises gravity, crank acceleration and an axial S1 law),
      with ``dualmech validate --baseline`` semantics: it fails when any check
      fails or anything regressed against the baseline that the *unmutated*
      copy wrote in the same selftest run;
   b. only when (a) passes: the catalogue's fast test modules (``tests``),
      ``pytest -x -q``;

   (for a fault in the comparison, b then a: it leaves every engine's numbers
   as they were, and its unit tests decide faster);

3. counts the fault **killed** when (a) or (b) fails (a crash or a non-zero exit
   is a failure, as it would be in CI), and records which part killed it.

The compiled kernel's numba cache is copied with the source: it is keyed on a
digest of the kernel's files, so a fault there recompiles the kernel and any
other fault reuses the unmutated copy's warm cache.

Before any fault, the gate runs on an unmutated copy and must pass: a gate that
fails without a fault proves nothing, so the selftest stops there.  A fault
whose ``old`` text does not occur exactly once in its file is *stale*: an
ERROR, never counted as killed.  A gate step that outlives ``timeout`` seconds
is stopped and the fault counted as killed by ``timeout`` (listed as such): the
CI job has no shorter limit, so a hang would fail CI too, later.

The score is ``killed / faults``; anything below 100 % exits 1.
"""

from __future__ import annotations

import concurrent.futures as cf
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import click

from dualmech.validation.cli_errors import one_line_errors

#: What a scratch copy holds (relative to the source root); absent optional entries are skipped.
COPIED: tuple[str, ...] = (
    "core", "models", "validation", "tests", "docs", "reports", "pyproject.toml", "README.md")
#: Entries a source root must have to be one.
REQUIRED: tuple[str, ...] = ("core", "models", "validation", "pyproject.toml")
#: Import packages and the folders that hold them (pyproject.toml ``package-dir``).
PACKAGES: dict[str, str] = {"core": "core", "models": "models", "validation": "validation"}
#: Fault classes of the catalogue (README "The gate proves it can fail").
CLASSES: tuple[str, ...] = ("solver", "shared-input", "judge", "comparison")
#: Default catalogue, relative to the source root.
CATALOGUE = "validation/mutants.toml"
_ID = re.compile(r"[A-Za-z0-9][A-Za-z0-9-]*")
#: Exit code of :data:`BOOT` when the scratch copy is not what gets imported (an ERROR, never a kill).
WRONG_IMPORT = 97
#: One thread for the BLAS and the compiled kernel of each gate process: mutants run side by side.
_ENV = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "NUMBA_NUM_THREADS": "1",
        "MPLBACKEND": "Agg", "PYTHONDONTWRITEBYTECODE": "1"}

#: Prelude of every gate process: ``python -c BOOT+code SCRATCH ...`` imports ``dualmech`` from SCRATCH only.
BOOT = f"""\
import os, sys
_root = os.path.abspath(sys.argv[1])
sys.meta_path[:] = [f for f in sys.meta_path
                    if not str(getattr(f, "__module__", "")).startswith("__editable__")]
sys.path_hooks[:] = [h for h in sys.path_hooks if "__editable__" not in str(getattr(h, "__module__", ""))]
sys.path[:] = [os.path.join(_root, ".pkg"), _root] + [p for p in sys.path if "__editable__" not in p]
sys.path_importer_cache.clear()
import importlib
for _name in {list(PACKAGES)!r}:
    try:  # the packages' __init__ files are empty: a failure here is the copy's layout, never a fault
        _file = str(importlib.import_module("dualmech." + _name).__file__)
    except ImportError as _err:
        _file = f"nowhere ({{_err}})"
    if not os.path.abspath(_file).startswith(os.path.join(_root, ".pkg") + os.sep):
        print(f"selftest: dualmech.{{_name}} imported from {{_file}}, not from {{_root}}", file=sys.stderr)
        sys.exit({WRONG_IMPORT})
"""
_MATRIX_GATE = "from dualmech.validation.selftest import gate_main\nsys.exit(gate_main(sys.argv[2:]))\n"
_TEST_GATE = "import pytest\nsys.exit(pytest.main(['-x', '-q', '-p', 'no:cacheprovider', *sys.argv[2:]]))\n"


class SelftestError(ValueError):
    """A catalogue or source tree that cannot be used; the message is one line."""


@dataclass(frozen=True)
class Mutant:
    """One deliberate fault: ``old`` replaced by ``new`` in ``file`` (relative to the source root)."""

    id: str
    file: str
    old: str
    new: str
    fault_class: str
    description: str


@dataclass(frozen=True)
class Catalogue:
    """The faults and the gate they are run against (matrix file and test modules, source-relative)."""

    mutants: tuple[Mutant, ...]
    matrix: str
    tests: tuple[str, ...]


@dataclass(frozen=True)
class GateRun:
    """One run of the gate on one scratch copy.

    ``verdict``: ``"pass"``, ``"matrix"`` (a check failed), ``"baseline"`` (only a
    regression), ``"incomplete"`` (work missing), ``"crash"`` (the matrix step raised),
    ``"tests"``, ``"timeout"`` or ``"error"`` (the harness could not judge: a stale
    fault, the wrong package imported).
    """

    verdict: str
    seconds: float
    detail: str = ""

    @property
    def killed(self) -> bool:
        return self.verdict not in ("pass", "error")


@dataclass(frozen=True)
class Outcome:
    """What happened to one mutant."""

    mutant: Mutant
    run: GateRun


@dataclass
class Report:
    """A whole selftest: the unmutated gate's run and every mutant's outcome."""

    pristine: GateRun
    outcomes: list[Outcome] = field(default_factory=list)
    seconds: float = 0.0

    @property
    def killed(self) -> int:
        return sum(o.run.killed for o in self.outcomes)

    @property
    def score(self) -> float:
        """Killed fraction in percent (0 for an empty catalogue)."""
        return 100.0 * self.killed / len(self.outcomes) if self.outcomes else 0.0

    @property
    def passed(self) -> bool:
        return self.pristine.verdict == "pass" and bool(self.outcomes) and self.killed == len(self.outcomes)


# ----------------------------------------------------------------------------- catalogue

def _text(where: str, value: object, *, empty: bool = False) -> str:
    if not isinstance(value, str) or (not value and not empty):
        raise SelftestError(f"{where}: expected a non-empty string, got {value!r}")
    return value


def parse_catalogue(data: dict, source: str = "<catalogue>") -> Catalogue:
    """Check a parsed catalogue table and build the :class:`Catalogue`.

    Format: ``matrix = "path"``, ``tests = ["path", ...]`` and one ``[[mutant]]``
    table per fault with ``id``, ``file``, ``class`` (one of :data:`CLASSES`),
    ``description``, ``old`` and ``new`` (``new != old``).
    """
    known = {"matrix", "tests", "mutant"}
    for key in data:
        if key not in known:
            raise SelftestError(f"{source}: {key}: unknown key (valid: {', '.join(sorted(known))})")
    matrix = _text(f"{source}: matrix", data.get("matrix"))
    tests = data.get("tests", [])
    if not isinstance(tests, list) or not all(isinstance(t, str) and t for t in tests):
        raise SelftestError(f"{source}: tests: expected an array of test module paths, got {tests!r}")
    entries = data.get("mutant", [])
    if not isinstance(entries, list) or not entries:
        raise SelftestError(f"{source}: mutant: expected at least one [[mutant]] table")
    mutants, seen = [], set()
    fields_ = {"id", "file", "class", "description", "old", "new"}
    for i, m in enumerate(entries):
        where = f"{source}: mutant[{i}]"
        if not isinstance(m, dict):
            raise SelftestError(f"{where}: expected a table, got {m!r}")
        for key in m:
            if key not in fields_:
                raise SelftestError(f"{where}.{key}: unknown key (valid: {', '.join(sorted(fields_))})")
        mid = _text(f"{where}.id", m.get("id"))
        if not _ID.fullmatch(mid):
            raise SelftestError(f"{where}.id: expected letters, digits and '-', got {mid!r}")
        where = f"{source}: mutant {mid}"
        if mid in seen:
            raise SelftestError(f"{where}: id given twice")
        seen.add(mid)
        cls = m.get("class")
        if cls not in CLASSES:
            raise SelftestError(f"{where}.class: expected one of {', '.join(CLASSES)}, got {cls!r}")
        old, new = _text(f"{where}.old", m.get("old")), _text(f"{where}.new", m.get("new"), empty=True)
        if old == new:
            raise SelftestError(f"{where}.new: identical to old (a fault must change the source)")
        mutants.append(Mutant(mid, _text(f"{where}.file", m.get("file")), old, new, cls,
                              _text(f"{where}.description", m.get("description"))))
    return Catalogue(tuple(mutants), matrix, tuple(tests))


def load_catalogue(path: str | Path) -> Catalogue:
    """Read a catalogue file (TOML)."""
    try:
        with Path(path).open("rb") as fh:
            data = tomllib.load(fh)
    except OSError as err:
        raise SelftestError(f"catalogue: cannot read {path} ({err.strerror})") from None
    except tomllib.TOMLDecodeError as err:
        raise SelftestError(f"catalogue: {path} is not valid TOML ({err})") from None
    return parse_catalogue(data, str(path))


def stale_reason(mutant: Mutant, root: Path) -> str | None:
    """Why ``mutant`` cannot be applied to the tree at ``root``; ``None`` if ``old`` occurs exactly once."""
    path = Path(root) / mutant.file
    try:
        text = path.read_text(encoding="utf-8")
    except OSError:
        return f"stale: {mutant.file} does not exist"
    count = text.count(mutant.old)
    if count != 1:
        return f"stale: old text occurs {count} times in {mutant.file} (must be exactly once)"
    return None


# ----------------------------------------------------------------------------- scratch copies

def source_root() -> Path:
    """The checkout this ``dualmech`` was imported from (the folder above ``validation/``)."""
    return Path(__file__).resolve().parents[1]


def check_source(root: Path) -> Path:
    """``root`` resolved, or a :class:`SelftestError` if it is not a dualmech source tree."""
    root = Path(root).resolve()
    missing = [p for p in REQUIRED if not (root / p).exists()]
    if missing:
        raise SelftestError(f"source: {root} is not a dualmech source tree (no {missing[0]}); "
                            "selftest needs the checkout, not an installed wheel")
    return root


def make_scratch(root: Path, dest: Path, mutant: Mutant | None = None) -> Path:
    """Copy the source tree at ``root`` to ``dest`` (created) and apply ``mutant`` there.

    ``dest/.pkg/dualmech/<name>`` links to ``dest/<folder>``, so a process with
    ``dest/.pkg`` first on ``sys.path`` (:data:`BOOT`) imports the copy.
    """
    dest = Path(dest)
    dest.mkdir(parents=True)
    # numba's disk cache (__pycache__/*.nbi, *.nbc) is kept: the kernel checks it against a digest of
    # its sources, so a fault in the kernel recompiles it and any other fault reuses the warm cache
    ignore = shutil.ignore_patterns("*.pyc", ".pytest_cache")
    for name in COPIED:
        src = Path(root) / name
        if src.is_dir():
            shutil.copytree(src, dest / name, ignore=ignore)
        elif src.is_file():
            shutil.copy2(src, dest / name)
    pkg = dest / ".pkg" / "dualmech"
    pkg.mkdir(parents=True)
    for name, folder in PACKAGES.items():
        (pkg / name).symlink_to(dest / folder, target_is_directory=True)
    if mutant is not None:
        why = stale_reason(mutant, dest)
        if why:
            raise SelftestError(f"mutant {mutant.id}: {why}")
        path = dest / mutant.file
        path.write_text(path.read_text(encoding="utf-8").replace(mutant.old, mutant.new, 1), encoding="utf-8")
    return dest


# ----------------------------------------------------------------------------- the gate

def gate_main(argv: list[str]) -> int:
    """The matrix part of the gate, run inside a scratch copy (``python -c BOOT...``).

    ``argv``: ``MATRIX OUTDIR BASELINE_IN|- BASELINE_OUT|-``.  Runs the matrix in
    this process, compares, checks (or writes) the baseline and writes the JUnit
    file as ``dualmech validate --baseline --junit`` does (everything but the
    report), and returns the exit code ``validate`` would
    (:func:`~dualmech.validation.cli_validate.exit_code`: 0 PASS, 1 FAIL or a
    regression, 3 INCOMPLETE).  Prints one JSON line: ``verdict``, ``checks``,
    ``failures``, ``regressions`` (a few of each) and their counts.
    """
    from dualmech.validation.baseline import baseline_summary, compare_baseline, read_baseline, write_baseline
    from dualmech.validation.cli_validate import exit_code, run_versions
    from dualmech.validation.compare import compare_run
    from dualmech.validation.junit import describe, write_junit
    from dualmech.validation.matrix import load_matrix
    from dualmech.validation.runner import load_entries, run_matrix, timings

    matrix_file, outdir, baseline_in, baseline_out = argv
    matrix = load_matrix(matrix_file)
    outcome = run_matrix(matrix, outdir, jobs=1)
    comparison = compare_run(matrix, outcome.results)
    summary = baseline_summary(matrix, comparison, outcome.results)
    regressions = compare_baseline(summary, read_baseline(baseline_in)) if baseline_in != "-" else []
    write_junit(Path(outdir) / "junit.xml", matrix, comparison, timings(load_entries(outdir, matrix)),
                regressions=regressions, versions=run_versions(Path(outdir)))
    if baseline_out != "-":
        write_baseline(baseline_out, summary)
    failures = comparison.failures()
    print(json.dumps({"verdict": str(comparison.verdict), "checks": len(comparison.checks),
                      "failures": [describe(c) for c in failures[:3]], "n_failures": len(failures),
                      "regressions": [str(r) for r in regressions[:3]], "n_regressions": len(regressions)}))
    return exit_code(comparison.verdict, regressions)


def _python(scratch: Path, code: str, args: list[str], timeout: float) -> tuple[int | None, str, str]:
    """Run ``python -c BOOT+code scratch *args`` in ``scratch``; ``None`` as exit code on timeout."""
    env = {**os.environ, **_ENV}
    env.pop("NUMBA_CACHE_DIR", None)  # keep the kernel cache in the copy (it carries the warm one)
    cmd = [sys.executable, "-c", BOOT + code, str(scratch), *args]
    try:
        proc = subprocess.run(cmd, cwd=scratch, env=env, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired as err:
        return None, _decode(err.stdout), _decode(err.stderr)
    return proc.returncode, proc.stdout, proc.stderr


def _decode(data: bytes | str | None) -> str:
    return data.decode(errors="replace") if isinstance(data, bytes) else (data or "")


def _last_line(text: str) -> str:
    lines = [ln.strip() for ln in text.strip().splitlines() if ln.strip()]
    return lines[-1] if lines else ""


def _matrix_verdict(code: int | None, out: str, err: str) -> tuple[str, str]:
    if code is None:
        return "timeout", "matrix step timed out"
    if code == WRONG_IMPORT:
        return "error", _last_line(err)
    report = None
    for line in reversed(out.splitlines()):
        if line.startswith("{"):
            report = json.loads(line)
            break
    if report is None:
        return "crash", _last_line(err) or f"exit code {code}"
    if code == 0:
        return "pass", f"{report['checks']} checks"
    if report["verdict"] == "FAIL":
        return "matrix", f"{report['n_failures']} checks fail, e.g. {report['failures'][0]}"
    if report["n_regressions"]:
        return "baseline", f"{report['n_regressions']} regressions, e.g. {report['regressions'][0]}"
    return "incomplete", f"exit code {code}: {report['verdict']}, e.g. {(report['failures'] or ['?'])[0]}"


def _tests_verdict(code: int | None, out: str, err: str) -> tuple[str, str]:
    if code is None:
        return "timeout", "tests timed out"
    if code == WRONG_IMPORT:
        return "error", _last_line(err)
    if code == 0:
        return "pass", _last_line(out)
    failed = [ln for ln in out.splitlines() if ln.startswith(("FAILED", "ERROR"))]
    return "tests", (failed[0] if failed else _last_line(out) or _last_line(err))[:200]


def run_gate(scratch: Path, catalogue: Catalogue, baseline_in: Path | None, baseline_out: Path | None,
             timeout: float, tests_first: bool = False) -> GateRun:
    """The gate on one scratch copy: the matrix part, then (if it passes) the test part.

    ``tests_first`` swaps the order (for faults in the comparison: they leave every
    engine's numbers as they were, and their unit tests decide faster); the second
    part runs only when the first passes.
    """
    start = time.perf_counter()
    args = [str(scratch / catalogue.matrix), str(scratch / ".run"),
            str(baseline_in) if baseline_in else "-", str(baseline_out) if baseline_out else "-"]
    parts = [lambda: _matrix_verdict(*_python(scratch, _MATRIX_GATE, args, timeout))]
    if catalogue.tests:
        parts.append(lambda: _tests_verdict(*_python(scratch, _TEST_GATE, list(catalogue.tests), timeout)))
    verdict, detail = "pass", ""
    for part in reversed(parts) if tests_first else parts:
        verdict, detail = part()
        if verdict != "pass":
            break
    return GateRun(verdict, time.perf_counter() - start, detail)


def run_selftest(
    catalogue: Catalogue,
    root: Path | None = None,
    *,
    jobs: int = 2,
    timeout: float = 300.0,
    only: tuple[str, ...] = (),
    progress: Callable[[Outcome], None] | None = None,
    keep: Path | None = None,
) -> Report:
    """Run every mutant of ``catalogue`` (or those named in ``only``) against the gate.

    Parameters
    ----------
    catalogue : Catalogue
    root : path, optional
        Source tree to copy (default :func:`source_root`); never modified.
    jobs : int
        Mutants gated side by side (each gate process runs one job).
    timeout : float
        Seconds each gate step (matrix, tests) may take.
    only : tuple of str
        Mutant ids to run (default all); an unknown id is a :class:`SelftestError`.
    progress : callable, optional
        Called with each :class:`Outcome` as it finishes.
    keep : path, optional
        Work directory to use and keep (scratch copies, runs, the baseline); default a temporary one.
    """
    root = check_source(source_root() if root is None else root)
    if jobs < 1:
        raise SelftestError(f"jobs: expected a number of processes >= 1, got {jobs}")
    if not timeout > 0:
        raise SelftestError(f"timeout: expected a positive number of seconds, got {timeout!r}")
    ids = {m.id for m in catalogue.mutants}
    unknown = [i for i in only if i not in ids]
    if unknown:
        raise SelftestError(f"only: {unknown[0]!r} is not a mutant of the catalogue")
    chosen = [m for m in catalogue.mutants if not only or m.id in only]
    start = time.perf_counter()
    work = Path(keep) if keep else Path(tempfile.mkdtemp(prefix="dualmech-selftest-"))
    work.mkdir(parents=True, exist_ok=True)
    try:
        baseline = work / "baseline.json"
        source = make_scratch(root, work / "pristine")  # one snapshot: every mutant is a copy of it
        pristine = run_gate(source, catalogue, None, baseline, timeout)
        report = Report(pristine)
        if pristine.verdict != "pass":
            report.seconds = time.perf_counter() - start
            return report

        def one(m: Mutant) -> Outcome:
            why = stale_reason(m, source)
            if why:
                return Outcome(m, GateRun("error", 0.0, why))
            scratch = make_scratch(source, work / f"mutant-{m.id}", m)
            first = m.fault_class == "comparison"
            gate = run_gate(scratch, catalogue, baseline, None, timeout, tests_first=first)
            outcome = Outcome(m, gate)
            if keep is None:
                shutil.rmtree(scratch, ignore_errors=True)
            return outcome

        with cf.ThreadPoolExecutor(max_workers=jobs) as pool:
            for fut in cf.as_completed([pool.submit(one, m) for m in chosen]):
                outcome = fut.result()
                report.outcomes.append(outcome)
                if progress is not None:
                    progress(outcome)
        order = {m.id: i for i, m in enumerate(chosen)}
        report.outcomes.sort(key=lambda o: order[o.mutant.id])
        report.seconds = time.perf_counter() - start
        return report
    finally:
        if keep is None:
            shutil.rmtree(work, ignore_errors=True)


# ----------------------------------------------------------------------------- output

def format_report(report: Report, jobs: int) -> str:
    """The table (mutant, class, killed by, seconds, why) and the score line."""
    p = report.pristine
    lines = [f"unmutated gate: {p.verdict.upper()} in {p.seconds:.1f} s ({p.detail})"]
    if p.verdict != "pass":
        lines.append("selftest: the gate fails without any fault, so no fault can prove anything; "
                     "fix that first")
        return "\n".join(lines)
    width = max([len(o.mutant.id) for o in report.outcomes] + [6])
    lines.append(f"{'mutant':{width}s}  {'class':12s}  {'killed by':10s}  {'s':>5s}  why")
    for o in report.outcomes:
        by = o.run.verdict if o.run.killed else ("ERROR" if o.run.verdict == "error" else "SURVIVED")
        lines.append(f"{o.mutant.id:{width}s}  {o.mutant.fault_class:12s}  {by:10s}  {o.run.seconds:5.1f}  "
                     f"{o.run.detail[:120]}")
    n = len(report.outcomes)
    timeouts = sum(o.run.verdict == "timeout" for o in report.outcomes)
    extra = f", {timeouts} of them by timeout" if timeouts else ""
    lines.append(f"mutation score: {report.killed}/{n} killed ({report.score:.1f} %){extra}; "
                 f"{report.seconds:.0f} s with {jobs} jobs")
    return "\n".join(lines)


# ----------------------------------------------------------------------------- command line

@click.command()
@click.option("--catalogue", type=click.Path(dir_okay=False), help=f"Fault catalogue [default: {CATALOGUE}].")
@click.option("--jobs", type=click.IntRange(min=1), default=2, show_default=True,
              help="Mutants gated side by side.")
@click.option("--timeout", type=float, default=300.0, show_default=True,
              help="Seconds each gate step may take (a step that outlives it counts as killed by timeout).")
@click.option("--only", multiple=True, metavar="ID", help="Run only these mutants (repeatable).")
@click.option("--source", type=click.Path(file_okay=False, exists=True),
              help="Source tree to copy [default: the checkout dualmech runs from].")
@click.option("--keep", type=click.Path(file_okay=False), help="Keep the scratch copies and runs here.")
@one_line_errors
def selftest(catalogue, jobs, timeout, only, source, keep) -> None:
    """Apply every deliberate fault of the catalogue to a scratch copy and require the gate to FAIL.

    Prints one row per fault (which part of the gate killed it, seconds) and the
    mutation score; exits 1 below 100 % or when the gate fails without a fault.
    """
    root = check_source(Path(source) if source else source_root())
    cat = load_catalogue(Path(catalogue) if catalogue else root / CATALOGUE)
    def progress(o: Outcome) -> None:
        click.echo(f"  {o.mutant.id}: {o.run.verdict} ({o.run.seconds:.1f} s)", err=True)

    report = run_selftest(cat, root, jobs=jobs, timeout=timeout, only=tuple(only),
                          keep=Path(keep) if keep else None, progress=progress)
    click.echo(format_report(report, jobs))
    if not report.passed:
        sys.exit(1)
