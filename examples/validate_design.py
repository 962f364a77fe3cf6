"""Validate your design: the in-house engine judged by Pinocchio, compared row by row, with its report.

``jobs=1`` solves in this process (more jobs start worker processes: keep the ``__main__`` guard).
The run folder is ``runs/validate-design`` under the current folder.  Run: ``python validate_design.py``.
"""

import dualmech

case = dualmech.Case(
    "first-design", units="m-kg-s",
    geometry={"crank_length": 0.05, "rod_length": 0.20, "slider_offset": 0.01,
              "slider_twist_deg": 270.0, "crank_axial_shift": 0.0},
    motion={"crank_rpm": 600.0},
    bodies={"crank_radius": 0.008, "rod_radius": 0.005, "slider_side": 0.025, "density": 7850.0},
    loads={"slider_force": 200.0, "gravity": [0.0, -9.81, 0.0]},
)

if __name__ == "__main__":
    run = dualmech.validate(case, "runs/validate-design", engines=["dualmech", "pinocchio"], jobs=1)
    checks = run.comparison.checks
    print(f"{sum(c.passed for c in checks)} of {len(checks)} checks passed")
    print("verdict:", run.verdict)
    print("report:", run.write_report().html)
