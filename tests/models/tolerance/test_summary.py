"""Statistics of a tolerance study (models/tolerance/summary.py); Monte Carlo against linear propagation."""

import copy

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.special import ndtri

from dualmech.models.case import case_from_dict, load_case
from dualmech.models.slider_crank.analysis import solve_case
from dualmech.models.tolerance.outputs import design_outputs
from dualmech.models.tolerance.spec import design_case, nominal_values, spec_from_dict
from dualmech.models.tolerance.study import StudyInput
from dualmech.models.tolerance.summary import Z95, describe, sobol_first_order, wilson
from dualmech.validation.tolerance.study import run_study

#: Coverage of a 95 % interval over 400 seeded replications: 380 expected, binomial sd 4.4; ~3.4 sd each side.
COVERAGE_RANGE = (0.91, 0.99)
#: First-order Sobol estimates at n = 4000 against the exact indices: binning noise ~ 1/sqrt(n) per bin mean.
SOBOL_ABS = 0.03


def test_wilson_interval_known_values():
    assert_allclose(wilson(0, 10)["ci"], [0.0, Z95**2 / (10 + Z95**2)], rtol=1e-12, atol=1e-15)
    w = wilson(45, 50)
    assert_allclose(w["value"], 0.9, rtol=0, atol=0)
    assert_allclose(w["ci"], [0.7864, 0.9565], rtol=0, atol=1e-4)  # by hand: centre 0.8715, half 0.0851


@pytest.mark.parametrize("draw, truth", [
    (lambda rng, n: rng.exponential(2.0, n), {"mean": 2.0, "std": 2.0, "p99": 2.0 * np.log(100.0)}),
    (lambda rng, n: rng.uniform(-1.0, 3.0, n), {"mean": 1.0, "std": 4.0 / np.sqrt(12.0), "p99": 2.96}),
])
def test_confidence_intervals_cover_at_their_stated_rate(draw, truth):
    rng = np.random.default_rng(20261123)
    hits = {k: 0 for k in truth}
    reps = 400
    for _ in range(reps):
        d = describe(draw(rng, 500))
        for k, v in truth.items():
            lo, hi = d[f"{k}_ci"]
            hits[k] += lo <= v <= hi
    for k in truth:
        assert COVERAGE_RANGE[0] <= hits[k] / reps <= COVERAGE_RANGE[1], (k, hits[k] / reps)


def test_sobol_first_order_of_an_additive_function():
    rng = np.random.default_rng(5)
    x = rng.uniform(size=(4000, 3))
    y = x[:, 0] + 0.5 * x[:, 1]  # variances 1/12 and 1/48: shares 0.8 and 0.2; the third input does nothing
    assert_allclose(sobol_first_order(x, y), [0.8, 0.2, 0.0], rtol=0, atol=SOBOL_ABS)


def _force_mode(name, **motion):
    raw = copy.deepcopy(load_case(name).raw)
    del raw["loads"]["drive_torque"]
    raw["loads"]["slider_force"] = -500.0
    raw["bodies"]["slider"] = {"mass": 0.02, "com": [0.5, 0.2, -0.1]}  # joint-4 moments are not 0 by symmetry
    raw["motion"]["angles_deg"] = {"start": 0.0, "stop": 360.0, "step": 4.0}
    raw["motion"].update(motion)
    return case_from_dict(raw)


def _bonferroni(summary):
    """Intervals at a family-wise 95 %: two comparisons per output (the summary's are 95 % each)."""
    m = 2 * len(summary["outputs"])
    return float(ndtri(1.0 - 0.05 / (2 * m))) / Z95


def test_small_tolerances_monte_carlo_agrees_with_linear_propagation(tmp_path):
    """Offsets ~1e-3 of each size: second-order terms ~1e-3 of the first-order ones, far inside the CIs."""
    case = _force_mode("a4-20-alpha-232")
    spec = spec_from_dict({"tolerances": {
        "geometry.slider_offset": {"dist": "normal", "sd": 0.02},
        "geometry.crank_length": {"dist": "uniform", "low": -0.01, "high": 0.03},
        "geometry.slider_twist_deg": {"dist": "truncnormal", "sd": 0.1, "low": -0.15, "high": 0.2},
        "bodies.rod.mass": {"dist": "normal", "sd": 1e-4}}})
    summary, _, _ = run_study(StudyInput(case, spec, 600, 3), "both", tmp_path, judge_samples=0)
    widen = _bonferroni(summary)
    for name, o in summary["outputs"].items():
        mean_half = widen * (o["mean_ci"][1] - o["mean_ci"][0]) / 2
        std_half = widen * (o["std_ci"][1] - o["std_ci"][0]) / 2
        assert_allclose(summary["linear_mean"][name], o["mean"], rtol=0, atol=mean_half, err_msg=name)
        assert_allclose(summary["linear_std"][name], o["std"], rtol=0, atol=std_half, err_msg=name)


def test_large_tolerances_part_where_the_output_curves(tmp_path):
    """a4 uniform +-10 in on 20 in: the stroke is convex in a4 (it grows like a4^2 / a2 off the plane), so the
    Monte Carlo mean exceeds the linear one by ~f''/2 Var(a4) and the spread is not the tangent's: both fall
    outside their intervals, and the second-order term accounts for the mean's gap."""
    case = _force_mode("a4-20-s1-3.5")
    spec = spec_from_dict({"tolerances": {"geometry.slider_offset": {"dist": "uniform", "low": -10.0,
                                                                     "high": 10.0}}})
    summary, _, _ = run_study(StudyInput(case, spec, 600, 4), "both", tmp_path, judge_samples=0)
    o = summary["outputs"]["stroke"]
    assert summary["linear_mean"]["stroke"] < o["mean_ci"][0]
    assert not o["std_ci"][0] <= summary["linear_std"]["stroke"] <= o["std_ci"][1]
    x0 = nominal_values(case, spec)
    h = 0.5
    f = [design_outputs([solve_case(design_case(case, spec, x0 + d, "h"))], "force")["stroke"][0]
         for d in (-h, 0, h)]
    curvature = (f[0] - 2 * f[1] + f[2]) / h**2
    second_order_mean = summary["nominal"]["stroke"] + 0.5 * curvature * 20.0**2 / 12.0
    half = (o["mean_ci"][1] - o["mean_ci"][0]) / 2
    assert_allclose(second_order_mean, o["mean"], rtol=0, atol=4 * half)  # the quartic term is left over


def test_round_off_outputs_are_reported_as_zero_with_their_level(tmp_path):
    """With a ball joint at the slider j4's moment about P3 is round-off (~1e-13 lbf·in): it is reported as 0
    with its round-off level, no variance share, sensitivity 0 (its exact derivative), no histogram; the
    other peaks are not (issue 30, "Noise shown as results")."""
    from dualmech.core.thresholds import ROUND_OFF_RELATIVE
    from dualmech.validation.tolerance.report import figure_jobs

    raw = copy.deepcopy(load_case("a4-20-alpha-232").raw)  # the slider's mass centre at P3: no j4 moment
    del raw["loads"]["drive_torque"]
    raw["loads"]["slider_force"] = -500.0
    raw["motion"]["angles_deg"] = {"start": 0.0, "stop": 360.0, "step": 4.0}
    case = case_from_dict(raw)
    spec = spec_from_dict({"tolerances": {
        "geometry.slider_offset": {"dist": "normal", "sd": 0.02},
        "bodies.rod.mass": {"dist": "normal", "sd": 1e-4}}})
    summary, _, samples = run_study(StudyInput(case, spec, 60, 3), "both", tmp_path, judge_samples=0)
    raw = np.asarray(samples["peak_j4_moment"], float)
    assert 0 < np.nanmax(raw) <= ROUND_OFF_RELATIVE.value * np.nanmin(samples["peak_j1_moment"])
    assert set(summary["round_off"]) == {"peak_j4_moment"}
    assert_allclose(summary["round_off"]["peak_j4_moment"], np.nanmax(raw), rtol=0, atol=0)
    assert summary["nominal"]["peak_j4_moment"] == 0.0
    out = summary["outputs"]["peak_j4_moment"]
    assert out["mean"] == 0.0 and out["std"] == 0.0 and out["p99"] == 0.0
    assert summary["contribution"]["peak_j4_moment"] is None
    assert summary["linear_share"]["peak_j4_moment"] is None
    assert all(v == 0.0 for v in summary["sensitivity"]["peak_j4_moment"].values())
    assert summary["linear_std"]["peak_j4_moment"] == 0.0
    drawn = {(kind, name) for kind, name, *_ in figure_jobs(summary, samples)}
    assert not {n for _, n in drawn} & {"peak_j4_moment"}
    assert ("hist", "peak_j1_moment") in drawn and ("tornado", "peak_j1_moment") in drawn
    assert summary["units"] == {"stroke": "in", **{f"peak_j{j}_force": "lbf" for j in range(1, 5)},
                                "peak_j1_moment": "lbf·in", "peak_j4_moment": "lbf·in",
                                "peak_drive_torque": "lbf·in"}
    from dualmech.validation.tolerance.report import write_tolerance_report

    write_tolerance_report(tmp_path, summary, None, samples)
    text = (tmp_path / "report.md").read_text().replace("\\", "")  # Markdown's escapes
    row = next(line for line in text.splitlines() if line.startswith("| peak_j4_moment"))
    assert "[lbf·in]" in row and "round-off" in row and "—" in row
    assert "| stroke [in] |" in text and "| peak_j1_force [lbf] |" in text
    assert "hist-peak_j4_moment" not in text and "tornado-peak_j4_moment" not in text


def test_a_constant_output_gets_no_distribution_and_no_shares(tmp_path):
    """The given drive torque is joint 1's moment in the planar ideal case whatever the crank length: it
    spreads by round-off only (~3e-14 of 100 lbf·in), and its histogram crashed the study ("Too many bins
    for data range", issue 31's fuzz): it is reported as constant, with its spread, no figure and no
    variance share."""
    from dualmech.models.tolerance.summary import CONSTANT_RELATIVE
    from dualmech.validation.tolerance.report import figure_jobs, write_tolerance_report

    raw = copy.deepcopy(load_case("ideal").raw)
    raw["motion"]["angles_deg"] = {"start": 0.0, "stop": 360.0, "step": 10.0}
    spec = spec_from_dict({"tolerances": {"geometry.crank_length": {"dist": "normal", "sd": 0.01}}})
    study = StudyInput(case_from_dict(raw), spec, 6, 0)
    summary, _, samples = run_study(study, "mc", tmp_path, judge_samples=0)
    moment = np.append(summary["nominal"]["peak_j1_moment"], samples["peak_j1_moment"])
    assert set(summary["constant"]) == {"peak_j1_moment"}
    assert_allclose(summary["constant"]["peak_j1_moment"], np.ptp(moment), rtol=0, atol=0)
    assert np.ptp(moment) <= CONSTANT_RELATIVE * 100.0
    assert np.ptp(samples["peak_j1_force"]) > 1e3 * CONSTANT_RELATIVE * np.max(samples["peak_j1_force"])
    assert summary["contribution"]["peak_j1_moment"] is None
    assert summary["contribution"]["peak_j1_force"] is not None
    assert not {name for _, name, *_ in figure_jobs(summary, samples)} & {"peak_j1_moment"}
    write_tolerance_report(tmp_path, summary, None, samples)
    text = (tmp_path / "report.md").read_text().replace("\\", "")
    row = next(line for line in text.splitlines() if line.startswith("| peak_j1_moment"))
    assert "| 100 (constant: spread" in row and "—" in row
