"""JUnit XML for CI systems: one test case per matrix case and engine.

Each judge's test case fails with a message naming the case and every failing
quantity; an engine that raised is an ``<error>`` with its traceback.  The
reference engine has a test case too (it errs when it raised), so that a CI
system counts every engine run of the matrix.
"""

from __future__ import annotations

import platform
import xml.etree.ElementTree as ET
from datetime import datetime, timezone
from pathlib import Path

from dualmech.validation.compare import ENGINE, Check, Comparison
from dualmech.validation.matrix import Matrix


def describe(check: Check) -> str:
    """One line naming the case, engine and quantity of a failed check, and why."""
    head = f"{check.case} / {check.engine}: {check.quantity}"
    return f"{head}: {check.detail}" if check.detail else head


def junit_tree(
    matrix: Matrix,
    comparison: Comparison,
    seconds: dict[str, dict[str, float]] | None = None,
    errors_full: dict[str, dict[str, str]] | None = None,
) -> ET.ElementTree:
    """The JUnit document of a compared run.

    Parameters
    ----------
    seconds : dict, optional
        Case id -> engine -> run time (s), shown as each test case's time.
    errors_full : dict, optional
        Case id -> engine -> full error text (default: ``comparison.errors``).
    """
    seconds = seconds or {}
    errors_full = errors_full or comparison.errors
    suite = ET.Element("testsuite", name=f"dualmech.validate.{matrix.name}",
                       timestamp=datetime.now(timezone.utc).isoformat(timespec="seconds"),
                       hostname=platform.node())
    counts = {"tests": 0, "failures": 0, "errors": 0, "skipped": 0}
    total_time = 0.0
    for mc in matrix.cases:
        for engine in matrix.engines:
            t = seconds.get(mc.id, {}).get(engine, 0.0)
            total_time += t
            tc = ET.SubElement(suite, "testcase", classname=f"{matrix.name}.{mc.id}", name=engine, time=f"{t:.3f}")
            counts["tests"] += 1
            err = errors_full.get(mc.id, {}).get(engine)
            if mc.id not in comparison.strokes and err is None:
                ET.SubElement(tc, "skipped", message=f"{mc.id} / {engine}: not run (unfinished run)")
                counts["skipped"] += 1
                continue
            if err is not None:
                lines = [ln for ln in err.strip().splitlines() if ln.strip()]
                el = ET.SubElement(tc, "error", message=f"{mc.id} / {engine}: {lines[-1] if lines else 'failed'}",
                                   type="EngineError")
                el.text = err
                counts["errors"] += 1
                continue
            failed = [c for c in comparison.for_engine(mc.id, engine) if not c.passed]
            if failed:
                kind = "EngineError" if any(c.quantity == ENGINE for c in failed) else "ToleranceExceeded"
                el = ET.SubElement(tc, "failure", type=kind, message=(
                    f"{mc.id} / {engine}: {', '.join(c.quantity for c in failed)} out of tolerance"
                    if kind == "ToleranceExceeded" else describe(failed[0])))
                el.text = "\n".join(describe(c) for c in failed)
                counts["failures"] += 1
    for key, value in counts.items():
        suite.set(key, str(value))
    suite.set("time", f"{total_time:.3f}")
    root = ET.Element("testsuites", name="dualmech validate", time=f"{total_time:.3f}",
                      **{k: str(v) for k, v in counts.items() if k != "skipped"})
    root.append(suite)
    ET.indent(root)
    return ET.ElementTree(root)


def write_junit(path: str | Path, matrix: Matrix, comparison: Comparison,
                seconds: dict[str, dict[str, float]] | None = None,
                errors_full: dict[str, dict[str, str]] | None = None) -> None:
    """Write the JUnit XML of a compared run to ``path``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    junit_tree(matrix, comparison, seconds, errors_full).write(path, encoding="utf-8", xml_declaration=True)
