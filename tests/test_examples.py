"""Every script of ``examples/`` runs as a user would run it (a fresh process, an empty working folder) and
prints what it promises: strokes and peak loads against the closed-form oracle, a PASS, a checked study.
The tutorials' matrix and SPEC files are read by the loaders, and expand to the cases their runs print."""

from __future__ import annotations

import re
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

import dualmech
from dualmech.models.tolerance.spec import load_spec
from dualmech.validation.matrix import load_matrix
from tests.oracles import slider_motion

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
TUTORIALS = ROOT / "docs" / "tutorials"
#: Wall-clock limit of one example: the slowest (the tolerance study, or a validation that imports
#: Pinocchio) takes under a minute on the loaded 2-core machine once the kernel is compiled; the first
#: compile of the kernel alone can take 4 minutes there.
TIMEOUT_S = 600
#: A stroke printed with 9 decimals (metres) against the unrounded closed form: the print's rounding
#: (5e-10 m) and the solver's closure (S4_VS_CLOSED_FORM x a2 = 2e-13 m), with a margin of 2.
PRINTED_STROKE_ATOL = 1e-9
#: A derivative printed with 6 significant digits against the oracle's central difference (step 1e-7 of a
#: 1e-2 m offset: truncation ~1e-12, rounding ~1e-9 relative): the print's rounding dominates.
PRINTED_SLOPE_RTOL = 1e-5


def run_example(name: str, cwd: Path) -> str:
    """The standard output of ``examples/<name>`` run in ``cwd``; a failure shows its standard error."""
    done = subprocess.run([sys.executable, str(EXAMPLES / name)], cwd=cwd, capture_output=True, text=True,
                          timeout=TIMEOUT_S)
    assert done.returncode == 0, f"examples/{name} exited {done.returncode}:\n{done.stderr[-3000:]}"
    return done.stdout


def first_design(a4: float | None = None) -> dualmech.Case:
    """The design of ``examples/first-design.toml``, with the slider offset ``a4`` (m) if given."""
    case = dualmech.load_case(EXAMPLES / "first-design.toml")
    return case if a4 is None else case.with_values({"geometry.slider_offset": a4})


def oracle_stroke(case: dualmech.Case) -> float:
    """max S4 - min S4 of the closed form at the case's own crank angles."""
    s4 = slider_motion(case)["S4"]
    return float(s4.max() - s4.min())


def check_first_design(out: str, cwd: Path) -> None:
    stroke = float(re.search(r"^stroke: (\S+) m$", out, re.M).group(1))
    assert_allclose(stroke, oracle_stroke(first_design()), rtol=0, atol=PRINTED_STROKE_ATOL)
    peaks = re.findall(r"^peak \|force\| at joint (\d): (\S+) N at (\d+) deg$", out, re.M)
    assert [int(j) for j, _, _ in peaks] == [1, 2, 3, 4], out
    table = dualmech.solve(first_design())
    ok = table["status"] == "ok"
    for joint, value, _ in peaks:  # the printed peaks are the table's, to their 3 decimals
        force = np.linalg.norm([table[f"j{joint}_f{axis}"][ok] for axis in "xyz"], axis=0)
        assert_allclose(float(value), force.max(), rtol=0, atol=5e-4)
    assert re.search(r"^peak \|drive_torque\|: \S+ N·m at \d+ deg$", out, re.M), out


def check_offset_sweep(out: str, cwd: Path) -> None:
    rows = [(float(a4), float(stroke))
            for a4, stroke in re.findall(r"^a4 = (\S+) m: stroke (\S+) m$", out, re.M)]
    assert [a4 for a4, _ in rows] == [0.0, 0.005, 0.01, 0.02, 0.04], out
    crank = first_design().geometry.crank_length
    # a centred slider crank strokes exactly twice its crank (at 0 and 180 deg, both sampled)
    assert_allclose(rows[0][1], 2 * crank, rtol=0, atol=PRINTED_STROKE_ATOL)
    for a4, stroke in rows:
        assert_allclose(stroke, oracle_stroke(first_design(a4)), rtol=0, atol=PRINTED_STROKE_ATOL)
    assert all(b[1] > a[1] for a, b in zip(rows, rows[1:])), f"an offset lengthens the stroke: {rows}"


def check_validate_design(out: str, cwd: Path) -> None:
    passed, total = map(int, re.search(r"^(\d+) of (\d+) checks passed$", out, re.M).groups())
    assert passed == total > 0, out
    assert re.search(r"^verdict: PASS$", out, re.M), out
    assert (cwd / "runs" / "validate-design" / "report.html").is_file()


def check_tolerance_study(out: str, cwd: Path) -> None:
    assert re.search(r"^yield: 1\.000 of 200 designs$", out, re.M), out
    assert re.search(r"^sensitivities checked: True$", out, re.M), out
    slope = float(re.search(r"^d stroke / d geometry\.slider_offset: (\S+)$", out, re.M).group(1))
    step = 1e-7
    a4 = first_design().geometry.slider_offset
    central = (oracle_stroke(first_design(a4 + step)) - oracle_stroke(first_design(a4 - step))) / (2 * step)
    assert_allclose(slope, central, rtol=PRINTED_SLOPE_RTOL, atol=0)
    assert not list(cwd.iterdir()), "the study belongs in a temporary folder, not the working folder"


#: examples/<script> -> what its output must show
CHECKS: dict[str, Callable[[str, Path], None]] = {
    "first_design.py": check_first_design,
    "offset_sweep.py": check_offset_sweep,
    "validate_design.py": check_validate_design,
    "tolerance_study.py": check_tolerance_study,
}


def test_every_example_is_checked() -> None:
    assert sorted(p.name for p in EXAMPLES.glob("*.py")) == sorted(CHECKS)


@pytest.mark.parametrize("name", sorted(CHECKS))
def test_example_runs_and_prints_its_result(name: str, tmp_path: Path) -> None:
    CHECKS[name](run_example(name, tmp_path), tmp_path)


def toml_blocks(page: str) -> list[str]:
    """The ```toml blocks of ``docs/tutorials/<page>``, in order."""
    return re.findall(r"^```toml\n(.*?)^```", (TUTORIALS / page).read_text(encoding="utf-8"), re.S | re.M)


def printed_case_ids(page: str) -> list[str]:
    """The case column of the summary tables a tutorial prints."""
    text = (TUTORIALS / page).read_text(encoding="utf-8")
    return [line.split()[0] for line in text.splitlines() if "│" in line]


def test_matrix_tutorial_expands_to_the_cases_it_prints(tmp_path: Path) -> None:
    (tmp_path / "first-design.toml").write_bytes((EXAMPLES / "first-design.toml").read_bytes())
    (tmp_path / "offsets.toml").write_text(toml_blocks("matrix.md")[0], encoding="utf-8")
    cases = load_matrix(tmp_path / "offsets.toml").cases
    assert sorted(c.id for c in cases) == sorted(printed_case_ids("matrix.md"))


def test_tolerance_tutorial_spec_loads(tmp_path: Path) -> None:
    (tmp_path / "spec.toml").write_text(toml_blocks("tolerance.md")[0], encoding="utf-8")
    assert list(load_spec(tmp_path / "spec.toml").keys) == [
        "geometry.slider_offset", "geometry.slider_twist_deg", "geometry.rod_length"]


#: A value the tutorial prints with 6 significant digits, against the study that printed it.
PRINTED_RTOL = 1e-5


def test_tolerance_tutorial_rssr_spec_gives_the_linear_spread_it_prints(tmp_path: Path) -> None:
    """The tutorial's RSSR SPEC loads with the RSSR's own keys, and its linear propagation (deterministic:
    the sensitivities at the nominal design) gives the linear std the printed run shows."""
    from dualmech.models.tolerance.plan import study_case
    from dualmech.models.tolerance.study import StudyInput
    from dualmech.validation.tolerance.study import run_study

    (tmp_path / "rssr-spec.toml").write_text(toml_blocks("tolerance.md")[1], encoding="utf-8")
    spec = load_spec(tmp_path / "rssr-spec.toml")
    assert list(spec.keys) == ["geometry.coupler", "geometry.output_crank", "geometry.frame_twist_deg",
                               "bodies.coupler.mass"]
    summary, _, _ = run_study(StudyInput(study_case("rssr"), spec, 1, 0), "linear", tmp_path / "out",
                              judge_samples=0)
    assert summary["sensitivity_check"]["passed"]
    text = (TUTORIALS / "tolerance.md").read_text(encoding="utf-8")
    printed = {m[1]: float(m[2]) for m in re.finditer(r"^(range_\w+|peak_\w+) +\S+ +\S+ +\S+ +(\S+) +\S+$",
                                                         text, re.M)}
    assert set(printed) == {"range_phi4_deg", "peak_j1_force", "peak_j1_moment", "peak_drive_torque",
                            "peak_output_torque"}
    del printed["peak_output_torque"]  # the given torque: its linear std is the differences' round-off
    for name, value in printed.items():
        assert_allclose(summary["linear_std"][name], value, rtol=PRINTED_RTOL, err_msg=name)
