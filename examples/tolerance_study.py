"""A small tolerance study of your design: the slider offset and twist vary as a machine shop makes them.

200 sampled designs (Monte Carlo) and the exact sensitivities at the nominal design, with no judges'
spot checks (``judge_samples=0``), into a temporary folder.  Run: ``python tolerance_study.py``.
"""

import tempfile
from pathlib import Path

import dualmech

case = dualmech.load_case(Path(__file__).with_name("first-design.toml"))  # first_design.py builds it in code
spec = {"tolerances": {                     # offsets from the nominal values, in the case's units
    "geometry.slider_offset": {"dist": "normal", "sd": 0.0005},          # ±0.5 mm (1 sd)
    "geometry.slider_twist_deg": {"dist": "uniform", "low": -0.5, "high": 0.5},
}}

if __name__ == "__main__":
    with tempfile.TemporaryDirectory() as folder:
        study = dualmech.tolerance_study(case, spec, n=200, seed=1, outdir=f"{folder}/study", judge_samples=0)
        stroke = study.summary["outputs"]["stroke"]
        print(f"yield: {study.summary['yield']['value']:.3f} of {study.summary['yield']['n']} designs")
        print(f"stroke: mean {stroke['mean']:.7f} m, std {stroke['std']:.3e} m, p99 {stroke['p99']:.7f} m")
        print(f"linear std of the stroke: {study.summary['linear_std']['stroke']:.3e} m")
        for key, slope in study.summary["sensitivity"]["stroke"].items():
            print(f"d stroke / d {key}: {slope:.6g}")
        print("sensitivities checked:", study.summary["sensitivity_check"]["passed"])
        print("report files:", len(study.files))
