"""Exact sensitivities (models/tolerance/sensitivity.py) against central differences of the solver."""

import copy
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from dualmech.models.case import case_from_dict, load_case
from dualmech.models.slider_crank.analysis import solve_case
from dualmech.models.tolerance import sensitivity
from dualmech.models.tolerance.differences import check_sensitivities
from dualmech.models.tolerance.outputs import design_outputs, output_names
from dualmech.models.tolerance.sensitivity import SensitivityError, output_group, sensitivities
from dualmech.models.tolerance.spec import design_case, nominal_values, spec_from_dict
from tests.models.tolerance.closed_form_sensitivity import closed_form_sensitivities

#: Exact derivative against a central difference, relative: the issue's bar.  Measured <= 7.1e-7
#: (d peak_drive_torque / d axial_amplitude: a small derivative; the outputs' round-off over 2h dominates).
SENSITIVITY_VS_CENTRAL_DIFFERENCE = 1e-6
#: The same derivative by two derivations (complex steps, no truncation): round-off of the outputs times
#: the conditioning of the closure; measured <= 5.1e-12.
SENSITIVITY_VS_RESTATEMENT = 1e-9
#: Central-difference step, relative to max(|key|, 1) (angles: STEP rad, their scale is a radian, not their
#: value of 232-310 deg, whose 1e-5 gives a truncation of 2e-6 in the torque-mode peaks).
#: Truncation h^2 f'''/6 ~ 1e-10 of f' and round-off
#: (the solver's outputs carry ~1e-13 relative noise) 1e-13/h ~ 1e-8: both well under the 1e-6 bar, while
#: 1e-4 would let truncation near the 1/t load peaks reach 1e-6 and 1e-7 would let round-off reach 1e-6.
STEP = 1e-5
#: A derivative that is zero (to round-off) is compared absolutely: this fraction of the output group's
#: peak per unit of the key (e.g. joint-4 moments, identically 0 here, whose "peak" is round-off).
ZERO_DERIVATIVE = 1e-6

KEYS = ("geometry.slider_offset", "geometry.crank_length", "geometry.rod_length", "geometry.slider_twist_deg",
        "geometry.crank_axial_shift", "motion.axial_amplitude", "motion.crank_rpm", "bodies.crank_radius",
        "bodies.rod_radius", "bodies.slider_side", "bodies.weight_density", "bodies.rod.mass")


def _force_mode_case():
    raw = copy.deepcopy(load_case("a4-30-s1-3.5").raw)
    del raw["loads"]["drive_torque"]
    raw["loads"].update(slider_force=-500.0, gravity=[0.0, -386.4, 0.0])
    raw["motion"].update(axial_amplitude=0.5, axial_cycles=2.0, crank_accel=3.0)
    return case_from_dict(raw), KEYS + ("loads.slider_force",)


def _torque_mode_case():
    raw = copy.deepcopy(load_case("a4-20-alpha-232").raw)
    raw["motion"]["angles_deg"] = {"start": 3.0, "stop": 360.0, "step": 7.0}  # |t| >= 0.04: no dead centre
    raw["bodies"]["slider"] = {"mass": 0.02, "com": [0.5, 0.2, -0.1]}  # explicit mass and an off-centre com
    return case_from_dict(raw), KEYS + ("loads.drive_torque", "bodies.slider.mass")


def _universal_joint_case():
    """Force mode with a universal joint at the slider (the rod's spin is then determined, not a gauge)."""
    case, keys = _force_mode_case()
    return case_from_dict({**copy.deepcopy(case.raw), "joints": {"rod_slider": "universal"}}), keys


def _revolute_crank_case():
    """Torque mode with a revolute crank (no axial motion, so no axial amplitude to vary)."""
    case, keys = _torque_mode_case()
    return (case_from_dict({**copy.deepcopy(case.raw), "joints": {"crank": "revolute"}}),
            tuple(k for k in keys if k != "motion.axial_amplitude"))


MAKERS = [_force_mode_case, _torque_mode_case, _universal_joint_case, _revolute_crank_case]
MAKER_IDS = ["force-mode", "torque-mode", "universal-joint", "revolute-crank"]


def _central_differences(case, spec):
    x0 = nominal_values(case, spec)
    mode = case.loads.mode
    out = {}
    for j, key in enumerate(spec.keys):
        h = STEP * (np.degrees(1.0) if key.endswith("_deg") else max(abs(x0[j]), 1.0))
        sides = []
        for sign in (1.0, -1.0):
            x = x0.copy()
            x[j] += sign * h
            sides.append(design_outputs([solve_case(design_case(case, spec, x, "fd"))], mode))
        out[key] = {n: float(sides[0][n][0] - sides[1][n][0]) / (2 * h) for n in output_names(mode)}
    return x0, out


@pytest.mark.parametrize("make", MAKERS, ids=MAKER_IDS)
def test_sensitivities_match_central_differences_on_every_output(make):
    case, keys = make()
    spec = spec_from_dict({"tolerances": {k: {"dist": "normal", "sd": 0.1} for k in keys}})
    x0, fd = _central_differences(case, spec)
    _assert_same_derivatives(case, spec, sensitivities(case, spec), {n: {k: fd[k][n] for k in keys} for n in
                             output_names(case.loads.mode)}, SENSITIVITY_VS_CENTRAL_DIFFERENCE)


def _assert_same_derivatives(case, spec, exact, other, rtol):
    """``exact.values`` and ``other`` (``[output][key]``) agree to ``rtol``; a derivative that is zero to
    round-off is judged absolutely against its output group's peak (``ZERO_DERIVATIVE``)."""
    mode, x0 = case.loads.mode, nominal_values(case, spec)
    for j, key in enumerate(spec.keys):
        for name in output_names(mode):
            scale = max(abs(exact.nominal_outputs[n]) for n in output_group(name, mode))
            assert_allclose(exact.values[name][key], other[name][key], rtol=rtol,
                            atol=ZERO_DERIVATIVE * scale / max(abs(x0[j]), 1.0),
                            err_msg=f"d {name} / d {key}")


def test_peaks_are_differentiated_at_the_crank_angle_of_their_maximum():
    case, keys = _force_mode_case()
    spec = spec_from_dict({"tolerances": {"geometry.slider_offset": {"dist": "normal", "sd": 0.1}}})
    exact = sensitivities(case, spec)
    table = solve_case(case)
    theta, s4 = table["theta1_deg"], table["S4"]
    assert exact.positions_deg["stroke"] == [theta[np.argmax(s4)], theta[np.argmin(s4)]]
    load = np.abs(table["drive_torque"])
    assert exact.positions_deg["peak_drive_torque"] == [theta[np.argmax(load)]]


@pytest.mark.parametrize("make", [_force_mode_case, _torque_mode_case], ids=["force-mode", "torque-mode"])
def test_sensitivities_agree_with_a_closed_form_restatement(make):
    """Two derivations of the same derivatives: through the solver's loop, screws, Newton step, rates and
    reactions (the study's), and through the closed-form kinematics of
    tests/models/tolerance/closed_form_sensitivity.py (no shared solver code).  Measured: 1.4e-14 (force
    mode) and 5.1e-12 (torque mode) relative."""
    case, keys = make()
    spec = spec_from_dict({"tolerances": {k: {"dist": "normal", "sd": 0.1} for k in keys}})
    table = solve_case(case)
    _assert_same_derivatives(case, spec, sensitivities(case, spec, table),
                             closed_form_sensitivities(case, spec, table), SENSITIVITY_VS_RESTATEMENT)


def test_without_the_complex_newton_step_the_sensitivities_are_refused(monkeypatch):
    """Deliberate fault: the closure's complex Newton steps skipped, so the unknowns carry no derivative
    (the IFT step is what differentiates the loop): the study's run-time check refuses the result."""
    case, keys = _force_mode_case()
    spec = spec_from_dict({"tolerances": {k: {"dist": "normal", "sd": 0.1} for k in keys}})
    monkeypatch.setattr(sensitivity, "polish", lambda loop, inputs, state: state)
    check = check_sensitivities(case, spec, sensitivities(case, spec))
    assert not check.passed


def test_the_derivative_run_must_reproduce_the_solver():
    """Deliberate fault: a nominal table whose joint-2 forces are 1e-7 off is refused, not differentiated."""
    case = load_case("a4-20-s1-3.5")
    spec = spec_from_dict({"tolerances": {"geometry.slider_offset": {"dist": "normal", "sd": 0.1}}})
    table = solve_case(case)
    table.columns["j2_fy"] = table.columns["j2_fy"] * (1.0 + 1e-7)
    with pytest.raises(SensitivityError, match="differs from the solver"):
        sensitivities(case, spec, table)


@pytest.mark.parametrize("make", [_force_mode_case, _torque_mode_case], ids=["force-mode", "torque-mode"])
def test_the_run_time_check_passes_exact_sensitivities_and_names_a_wrong_one(make):
    """Deliberate fault: one derivative 1e-4 too large (relative) fails the check, which names it."""
    case, keys = make()
    spec = spec_from_dict({"tolerances": {k: {"dist": "normal", "sd": 0.1} for k in keys}})
    exact = sensitivities(case, spec)
    check = check_sensitivities(case, spec, exact)
    assert check.passed and check.worst_ratio <= 1.0
    name, key = "peak_j2_force", "geometry.rod_length"
    values = {n: dict(v) for n, v in exact.values.items()}
    values[name][key] *= 1.0 + 1e-4
    wrong = check_sensitivities(case, spec, replace(exact, values=values))
    assert not wrong.passed and (wrong.output, wrong.key) == (name, key)


@settings(max_examples=15, deadline=None, derandomize=True)
@given(a4=st.floats(-25.0, 45.0), twist=st.one_of(st.floats(185.0, 355.0), st.floats(5.0, 175.0)),
       s1=st.floats(-12.0, 12.0), amp=st.floats(0.0, 6.0), cycles=st.sampled_from([0.0, 1.0, 2.0]),
       torque_mode=st.booleans())
def test_the_solver_path_and_the_restatement_agree_on_random_geometries(a4, twist, s1, amp, cycles,
                                                                        torque_mode):
    """Property: for any ball-joint geometry (offsets that leave some angles unassembled included), both
    derivations of every derivative agree; torque mode's peaks near dead centres are ill-conditioned in
    both alike, so the bound is the restatement's, not the central differences'."""
    case = load_case("a4-30-s1-3.5").with_values({
        "geometry.slider_offset": a4, "geometry.slider_twist_deg": twist, "geometry.crank_axial_shift": s1,
        "motion.axial_amplitude": amp, "motion.axial_cycles": cycles,
        "motion.angles_deg": {"start": 0.0, "stop": 360.0, "step": 3.0}})
    raw = copy.deepcopy(case.raw)
    raw["loads"] = {"drive_torque": 100.0} if torque_mode else {"slider_force": 250.0}
    case = case_from_dict(raw)
    keys = tuple(k for k in KEYS if k != "bodies.rod.mass") + (
        "loads.drive_torque" if torque_mode else "loads.slider_force",)
    spec = spec_from_dict({"tolerances": {k: {"dist": "normal", "sd": 0.1} for k in keys}})
    table = solve_case(case)
    assume((table.status == "ok").any())
    _assert_same_derivatives(case, spec, sensitivities(case, spec, table),
                             closed_form_sensitivities(case, spec, table), SENSITIVITY_VS_RESTATEMENT)


def test_the_steps_are_exactly_representable():
    """Why: a 0.001 in tolerance on a 50 in rod asked for 50 + 1e-9, which is 50 + 1.00044e-9; the
    quotient divided by 1e-9 and the check FAILed a right derivative."""
    from dualmech.models.tolerance.differences import steps

    case = load_case("a4-30-s1-3.5")
    for sd in (0.001, 0.1, 1e9, 1e-300):
        spec = spec_from_dict({"tolerances": {k: {"dist": "normal", "sd": sd} for k in KEYS}})
        x0 = nominal_values(case, spec)
        for h in steps(spec, x0):
            assert np.all(h > 0)
            assert np.all(((x0 + h) - x0 == h) & ((x0 - h) + h == x0) & (x0 - (x0 - h) == h))


@pytest.mark.parametrize("sd", [0.001, 1e9, 1e-300])
def test_a_realistic_or_extreme_sd_passes_right_derivatives_and_a_wrong_one_fails(sd):
    """Why: sd = 0.001 on the 50 in rod FAILed (7.2 x its bound), sd = 1e9 collapsed the bound (7.8e3 x),
    sd = 1e-300 took a zero step (NaN, then a TypeError in the message).  The bound is now the check's own
    truncation and rounding; a derivative 1e-3 off still fails."""
    case = load_case("a4-30-s1-3.5")
    spec = spec_from_dict({"tolerances": {"geometry.rod_length": {"dist": "normal", "sd": sd},
                                          "geometry.slider_offset": {"dist": "normal", "sd": sd}}})
    exact = sensitivities(case, spec)
    check = check_sensitivities(case, spec, exact)
    assert check.passed and np.isfinite(check.worst_ratio), check
    name, key = "peak_j2_force", "geometry.rod_length"
    values = {n: dict(v) for n, v in exact.values.items()}
    values[name][key] *= 1.0 + 1e-3
    wrong = check_sensitivities(case, spec, replace(exact, values=values))
    assert not wrong.passed and (wrong.output, wrong.key) == (name, key)
