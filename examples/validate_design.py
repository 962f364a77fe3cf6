"""Validate your design: the in-house engine judged by Pinocchio, compared row by row, with its report.

``jobs=1`` solves in this process (more jobs start worker processes: keep the ``__main__`` guard).
The run folder is ``runs/validate-design`` under the current folder.  Run: ``python validate_design.py``.
"""

from pathlib import Path

import dualmech

case = dualmech.load_case(Path(__file__).with_name("first-design.toml"))  # first_design.py builds it in code

if __name__ == "__main__":
    run = dualmech.validate(case, "runs/validate-design", engines=["dualmech", "pinocchio"], jobs=1)
    checks = run.comparison.checks
    print(f"{sum(c.passed for c in checks)} of {len(checks)} checks passed")
    print("verdict:", run.verdict)
    print("report:", run.write_report().html)
