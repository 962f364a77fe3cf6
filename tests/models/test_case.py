"""Case files: presets load, bad input gives one clear line naming the key and the value."""

import subprocess
import sys

import numpy as np
import pytest
from numpy.testing import assert_allclose

from dualmech.models.case import CaseError, case_from_dict, load_case, preset_names


def _base() -> dict:
    return {
        "name": "t", "geometry": {"crank_length": 12.0, "rod_length": 50.0, "slider_offset": 0.0,
                                  "slider_twist_deg": 270.0, "crank_axial_shift": 0.0},
        "motion": {"crank_rpm": 50.0},
        "bodies": {"crank_radius": 1.5, "rod_radius": 1.0, "slider_side": 3.0, "density": 7850.0},
        "loads": {"drive_torque": 100.0},
    }


def test_presets_cover_the_thesis_example():
    names = preset_names()
    assert len(names) == 9 and "thesis/ideal" in names
    case = load_case("thesis/a4-30-s1-3.5")
    assert case.geometry.slider_offset == 30.0 and case.geometry.crank_axial_shift == 3.5
    # thesis section 3.1: m = pi r^2 a d / g
    assert_allclose(case.bodies.crank.mass, np.pi * 1.5**2 * 12 * 0.28 / 386.4, rtol=1e-15)
    assert_allclose(case.bodies.slider.inertia, np.eye(3) * case.bodies.slider.mass * 9 / 6, rtol=1e-15)
    assert len(case.motion.angles_deg) == 360


@pytest.mark.parametrize("edit, words", [
    (lambda d: d["geometry"].pop("rod_length"), ["geometry.rod_length", "missing"]),
    (lambda d: d["geometry"].update(rod_lenght=1.0), ["geometry.rod_lenght", "unknown", "rod_length"]),
    (lambda d: d["geometry"].update(rod_length="50"), ["geometry.rod_length", "'50'", "number"]),
    (lambda d: d["geometry"].update(crank_length=-1.0), ["geometry.crank_length", "-1.0", "positive"]),
    (lambda d: d["motion"].update(angles_deg={"step": 0.0}), ["motion.angles_deg.step", "non-zero"]),
    (lambda d: d["loads"].update(slider_force=5.0), ["both", "exactly one"]),
    (lambda d: d["loads"].pop("drive_torque"), ["neither", "exactly one"]),
    (lambda d: d["bodies"].update(rod={"com": [25.0, 1.0, 0.0]}), ["bodies.rod.com", "axis"]),
    (lambda d: d["bodies"].update(density=-1.0), ["bodies.density", "positive"]),
    (lambda d: d.update(colour="red"), ["colour", "unknown"]),
])
def test_bad_input_is_one_line_naming_key_and_value(edit, words):
    data = _base()
    edit(data)
    with pytest.raises(CaseError) as err:
        case_from_dict(data)
    msg = str(err.value)
    assert "\n" not in msg
    for w in words:
        assert w in msg, (w, msg)


def test_explicit_body_overrides():
    data = _base()
    data["bodies"]["crank"] = {"com": [-3.0, 0.0, 0.0]}
    data["bodies"]["slider"] = {"mass": 2.0, "com": [0.0, 0.0, 0.0], "inertia": [[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]]}
    case = case_from_dict(data)
    assert_allclose(case.bodies.crank.com, [-3.0, 0, 0])
    assert case.bodies.slider.mass == 2.0


def test_with_values_derives_a_validated_case():
    case = load_case("ideal").with_values({"geometry.slider_offset": 10.0})
    assert case.geometry.slider_offset == 10.0
    with pytest.raises(CaseError):
        load_case("ideal").with_values({"geometry.rod_length": 0.0})


def test_cli_bad_case_exits_2_without_traceback(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text('name = "x"\n[geometry]\ncrank_length = 12.0\n')
    proc = subprocess.run([sys.executable, "-m", "dualmech.validation", "solve", str(bad)],
                          capture_output=True, text=True)
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and "geometry.rod_length" in proc.stderr
