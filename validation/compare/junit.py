"""JUnit XML for CI systems: one test case per matrix case and engine.

Each judge's test case fails with a message naming the case and every failing
quantity; an engine that raised is an ``<error>`` with its traceback.  The
reference engine has a test case too (it fails on its own status check and errs
when it raised), so that a CI system counts every engine run of the matrix.
Nothing is hidden from a CI system that reads only this file: work that did not
run is a ``<failure type="Incomplete">`` (never ``<skipped>``), and every baseline
regression is a ``<failure type="Regression">`` of the test case it concerns (the
reference's for a case-wide one).  The suite's ``<properties>`` name the versions
that produced the run.
"""

from __future__ import annotations

import platform
import xml.etree.ElementTree as ET
from datetime import datetime, timezone
from pathlib import Path

from dualmech.core.files import write_bytes_durable
from dualmech.validation.compare import ENGINE, Check, Comparison, first_line
from dualmech.validation.compare.baseline import Regression
from dualmech.validation.matrix import Matrix


def describe(check: Check) -> str:
    """One line naming the case, engine and quantity of a failed check, and why."""
    head = f"{check.case} / {check.engine}: {check.quantity}"
    return f"{head}: {check.detail}" if check.detail else head


def _failure(tc: ET.Element, kind: str, message: str, lines: list[str]) -> None:
    el = ET.SubElement(tc, "failure", type=kind, message=message)
    el.text = "\n".join(lines)


def _regressions_by_test(matrix: Matrix, regressions: list[Regression]) -> dict[tuple[str, str], list[str]]:
    """(case id, engine) -> regression lines; case-wide ones go to the reference's test case."""
    out: dict[tuple[str, str], list[str]] = {}
    for r in regressions:
        engine = r.engine if r.engine in matrix.engines else matrix.reference
        out.setdefault((r.case, engine), []).append(str(r))
    return out


def junit_tree(
    matrix: Matrix,
    comparison: Comparison,
    seconds: dict[str, dict[str, float]] | None = None,
    errors_full: dict[str, dict[str, str]] | None = None,
    regressions: list[Regression] | None = None,
    versions: dict[str, str] | None = None,
) -> ET.ElementTree:
    """The JUnit document of a compared run.

    Parameters
    ----------
    seconds : dict, optional
        Case id -> engine -> run time (s), shown as each test case's time.
    errors_full : dict, optional
        Case id -> engine -> full error text (default: ``comparison.errors``).
    regressions : list of Regression, optional
        Baseline regressions; each fails the test case it concerns.
    versions : dict, optional
        Library -> version, written as the suite's properties.
    """
    seconds = seconds or {}
    errors_full = errors_full or comparison.errors
    by_test = _regressions_by_test(matrix, regressions or [])
    suite = ET.Element("testsuite", name=f"dualmech.validate.{matrix.name}",
                       timestamp=datetime.now(timezone.utc).isoformat(timespec="seconds"),
                       hostname=platform.node())
    props = ET.SubElement(suite, "properties")
    for name, value in {"verdict": str(comparison.verdict), **(versions or {})}.items():
        ET.SubElement(props, "property", name=name, value=str(value))
    counts = {"tests": 0, "failures": 0, "errors": 0, "skipped": 0}
    total_time = 0.0
    for mc in matrix.cases:
        for engine in matrix.engines_of(mc):  # a case's own engines (those that solve it)
            t = seconds.get(mc.id, {}).get(engine, 0.0)
            total_time += t
            tc = ET.SubElement(
                suite, "testcase", classname=f"{matrix.name}.{mc.id}", name=engine, time=f"{t:.3f}"
            )
            counts["tests"] += 1
            err = errors_full.get(mc.id, {}).get(engine)
            regressed = by_test.get((mc.id, engine), [])
            if err is not None:
                el = ET.SubElement(tc, "error", message=f"{mc.id} / {engine}: "
                                                        f"{first_line(err)}", type="EngineError")
                el.text = "\n".join([err, *regressed])
                counts["errors"] += 1
                continue
            failed = _mark_failures(tc, mc.id, engine, comparison, regressed)
            counts["failures"] += bool(failed or regressed)
    for key, value in counts.items():
        suite.set(key, str(value))
    suite.set("time", f"{total_time:.3f}")
    root = ET.Element("testsuites", name="dualmech validate", time=f"{total_time:.3f}",
                      **{k: str(v) for k, v in counts.items() if k != "skipped"})
    root.append(suite)
    ET.indent(root)
    return ET.ElementTree(root)


def _mark_failures(tc: ET.Element, case_id: str, engine: str, comparison: Comparison,
                   regressed: list[str]) -> list[Check]:
    """Add the ``failure`` element of one test case (the worst kind first); its failed checks."""
    failed = [c for c in comparison.for_engine(case_id, engine) if not c.passed]
    lines = [describe(c) for c in failed] + regressed
    if any(c.incomplete for c in failed):
        _failure(tc, "Incomplete", describe(failed[0]), lines)
    elif any(c.quantity == ENGINE for c in failed):
        _failure(tc, "EngineError", describe(failed[0]), lines)
    elif failed:
        _failure(tc, "ToleranceExceeded",
                 f"{case_id} / {engine}: {', '.join(c.quantity for c in failed)} out of tolerance", lines)
    elif regressed:
        _failure(tc, "Regression", regressed[0], lines)
    return failed


def write_junit(path: str | Path, matrix: Matrix, comparison: Comparison,
                seconds: dict[str, dict[str, float]] | None = None,
                errors_full: dict[str, dict[str, str]] | None = None,
                regressions: list[Regression] | None = None,
                versions: dict[str, str] | None = None) -> None:
    """Write the JUnit XML of a compared run to ``path`` (parameters as :func:`junit_tree`), atomically."""
    root = junit_tree(matrix, comparison, seconds, errors_full, regressions, versions).getroot()
    write_bytes_durable(Path(path), ET.tostring(root, encoding="utf-8", xml_declaration=True))
