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
    assert len([n for n in names if n.startswith("thesis/")]) == 9 and "thesis/ideal" in names
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
    # out of the stated ranges (issue 11): one short line naming the key, the value and the range
    (lambda d: d["geometry"].update(crank_length=1e300), ["geometry.crank_length", "1e+300", "1e+15"]),
    (lambda d: d["geometry"].update(rod_length=10**400), ["geometry.rod_length", "401 digits"]),
    (lambda d: d["geometry"].update(slider_offset=-(10**30)), ["geometry.slider_offset", "digits", "length"]),
    (lambda d: d["motion"].update(crank_rpm=1e160), ["motion.crank_rpm", "1e+160", "rpm", "1e+07"]),
    (lambda d: d["motion"].update(crank_rpm=1e308), ["motion.crank_rpm", "1e+308"]),
    (lambda d: d["motion"].update(crank_accel=-1e308), ["motion.crank_accel", "-1e+308", "rad/s^2"]),
    (lambda d: d["motion"].update(crank_rpm=True), ["motion.crank_rpm", "True", "number"]),
    (lambda d: d["motion"].update(crank_rpm=float("nan")), ["motion.crank_rpm", "nan", "finite"]),
    (lambda d: d["motion"].update(angles_deg={"step": 5e-324}), ["motion.angles_deg.step", "10,000,000"]),
    (lambda d: d["motion"].update(angles_deg={"step": 1e-300}), ["motion.angles_deg.step", "10,000,000"]),
    (lambda d: d["motion"].update(angles_deg={"start": -1e308}), ["motion.angles_deg.start", "degrees"]),
    (lambda d: d["motion"].update(axial_cycles=1e9), ["motion.axial_cycles", "1000"]),
    (lambda d: d["bodies"].update(density=1e-300), ["bodies.density", "1e-15"]),
    (lambda d: d["geometry"].update(rod_length=1e-15), ["geometry.rod_length", "1e+12", "largest length 12"]),
    (lambda d: d["loads"].update(drive_torque=1e16), ["loads.drive_torque", "torque"]),
    (lambda d: d["loads"].update(gravity=[0.0, 1e200, 0.0]), ["loads.gravity[1]", "acceleration"]),
    (lambda d: d["loads"].update(gravity=list(range(100_000))), ["loads.gravity", "3 numbers", "..."]),
    (lambda d: d.update(units="furlong-firkin"), ["units", "furlong-firkin", "inch-lbf-s", "m-kg-s"]),
    (lambda d: d.update(name="two\nlines"), ["name", "control"]),
    (lambda d: d.update({"x" * 5000: 1}), ["unknown", "..."]),
    # [mechanism] kind (issue 15): this format is the slider crank's; the other linkages have their own
    (lambda d: d.update(mechanism={"kind": "rssr"}), ["mechanism.kind", "'rssr'", "dualmech solve"]),
    (lambda d: d.update(mechanism={"kind": "four-bar"}),
     ["mechanism.kind", "'four-bar'", "slider-crank, rssr"]),
    (lambda d: d.update(mechanism={"kind": 4}), ["mechanism.kind", "4", "string"]),
    (lambda d: d.update(mechanism={"type": "rssr"}), ["mechanism.type", "unknown", "kind"]),
    (lambda d: d.update(mechanism={"kind": "RSSR"}, geometry={"input_crank": 0.1}),
     ["'RSSR'", "valid: slider"]),  # the kind is named before another format's keys are called unknown
    # [simulation] steps_per_degree (issue 12): whole steps from 1 to 1024
    (lambda d: d.update(simulation={"steps_per_degree": 0}),
     ["simulation.steps_per_degree", "0", "1 to 1024"]),
    (lambda d: d.update(simulation={"steps_per_degree": 4096}), ["simulation.steps_per_degree", "4096"]),
    (lambda d: d.update(simulation={"steps_per_degree": 32.5}),
     ["simulation.steps_per_degree", "32.5", "whole"]),
    (lambda d: d.update(simulation={"steps_per_degree": True}), ["simulation.steps_per_degree", "True"]),
    (lambda d: d.update(simulation={"step": 32}), ["simulation.step", "unknown", "steps_per_degree"]),
])
def test_bad_input_is_one_line_naming_key_and_value(edit, words):
    data = _base()
    edit(data)
    with pytest.raises(CaseError) as err:
        case_from_dict(data)
    msg = str(err.value)
    assert "\n" not in msg and len(msg) < 400, msg
    for w in words:
        assert w in msg, (w, msg)


@pytest.mark.parametrize("source, words", [
    # another kind's file: its kind is named before its keys (a loop table's top-level gravity) are
    ("rscr.toml", ["mechanism.kind: 'loop'", "dualmech.solve", "valid here: slider-crank"]),
    ("rssr.toml", ["mechanism.kind: 'rssr'", "dualmech.solve"]),
    # another kind's bundled name
    ("rscr", ["'rscr'", "bundled slider crank", "thesis/ideal", "dualmech cases", "dualmech.solve"]),
])
def test_load_case_names_the_reader_of_another_kind(source, words):
    """``load_case`` reads slider cranks; another kind's file or bundled name gets one line naming the
    verbs that read it, not an unknown key of its own format."""
    from dualmech.models.catalogue import bundled_case_path

    file = source.endswith(".toml")
    with pytest.raises(CaseError) as err:
        load_case(bundled_case_path(source[:-5]) if file else source)
    msg = str(err.value)
    assert "\n" not in msg and "unknown" not in msg, msg
    for w in words:
        assert w in msg, (w, msg)


def test_explicit_body_overrides():
    data = _base()
    data["bodies"]["crank"] = {"com": [-3.0, 0.0, 0.0]}
    data["bodies"]["slider"] = {
        "mass": 2.0,
        "com": [0.0, 0.0, 0.0],
        "inertia": [[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]],
    }
    case = case_from_dict(data)
    assert_allclose(case.bodies.crank.com, [-3.0, 0, 0])
    assert case.bodies.slider.mass == 2.0


def test_mechanism_kind_slider_crank_is_the_default_spelled_out():
    data = _base()
    data["mechanism"] = {"kind": "slider-crank"}
    assert case_from_dict(data).geometry == case_from_dict(_base()).geometry


def test_with_values_derives_a_validated_case():
    case = load_case("ideal").with_values({"geometry.slider_offset": 10.0})
    assert case.geometry.slider_offset == 10.0
    with pytest.raises(CaseError):
        load_case("ideal").with_values({"geometry.rod_length": 0.0})


def test_cli_bad_case_exits_2_without_traceback(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text('name = "x"\n[geometry]\ncrank_length = 12.0\n')
    proc = subprocess.run([sys.executable, "-m", "dualmech.cli", "solve", str(bad)],
                          capture_output=True, text=True)
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and "geometry.rod_length" in proc.stderr


# ----------------------------------------------------------------------------- input ranges (issue 11)

def test_the_range_edges_are_accepted():
    """The stated bounds are inclusive, and the physical extremes inside them load."""
    data = _base()
    data["geometry"].update(crank_length=1e3, rod_length=1e15)  # the largest length ratio, 1e12
    data["motion"].update(crank_rpm=-1e7, crank_accel=1e10, axial_cycles=1000.0, angles_deg={"step": 30.0})
    data["units"] = "mm-N-s"
    case = case_from_dict(data)
    assert case.motion.speed == pytest.approx(-1e7 * np.pi / 30, rel=1e-15)
    data["motion"]["crank_rpm"] = 0  # at rest: a quasi-static case is meaningful
    assert case_from_dict(data).motion.speed == 0.0


def test_the_most_positions_is_decided_before_building_them():
    data = _base()
    data["motion"]["angles_deg"] = {"start": 0.0, "stop": 1.0, "step": 1e-7}  # exactly 10^7
    assert len(case_from_dict(data).motion.angles_deg) == 10_000_000
    data["motion"]["angles_deg"]["step"] = 0.99e-7
    with pytest.raises(CaseError, match="10,000,000"):
        case_from_dict(data)


@pytest.mark.parametrize("text, words", [
    ('name = "x"\nunits = ' + "{a = " * 600 + "1" + "}" * 600, ["nested 600 deep", "16"]),
    ('name = "x"\nunits = ' + "[" * 600 + "1" + "]" * 600, ["nested 600 deep"]),
    ('name = "x"\n' + "a." * 20_000 + "b = 1", ["dotted key of 20001 parts"]),
    ('name = "x"\n[' + "g." * 20_000 + "b]", ["dotted key of 20001 parts"]),
    ('name = "x"\n' + "q = \"" + "y" * (1 << 20) + "\"", ["larger than 1,048,576 bytes"]),
    ('name = "x"\n[geometry\n', ["not valid TOML"]),
])
def test_hostile_toml_is_refused_before_parsing(tmp_path, text, words):
    """Deep nesting made tomllib recurse (RecursionError); 20,000-part keys took 1.5 GB before."""
    path = tmp_path / "hostile.toml"
    path.write_text(text)
    with pytest.raises(CaseError) as err:
        load_case(path)
    msg = str(err.value)
    assert "\n" not in msg
    for w in words:
        assert w in msg, (w, msg)


def test_toml_skeleton_ignores_dots_and_brackets_inside_strings(tmp_path):
    """Strings, comments and floats do not count as nesting or key parts (no false refusal)."""
    from dualmech.models.toml_input import read_toml

    deep = "[" * 20 + " a.a.a.a.a.a.a.a.a.a.a.a.a.a.a.a.a.a.a.a "
    text = (f'a = "{deep}"\nb = \'{deep}\'\nc = """\n{deep}\n"""\nd = \'\'\'{deep}\'\'\'\n'
            f'e = """x""""\nf = [1.5, 2.5e3, -0.5]  # {deep}\n')
    path = tmp_path / "ok.toml"
    path.write_text(text)
    data = read_toml(path, CaseError)
    assert data["a"] == data["b"] == deep and data["e"] == 'x"' and data["f"] == [1.5, 2500.0, -0.5]


@pytest.mark.parametrize("scale", [1e-6, 1.0, 1e3])
def test_the_rod_axisymmetry_check_does_not_depend_on_the_unit_system(scale):
    """A rod centre of mass 1e-9 of its length off the axis is refused at every length scale (was: absolute
    1e-12)."""
    from dualmech.core.inertia import BodyInertia
    from dualmech.models.bodies import check_rod_axisymmetric

    inertia = np.diag([1.0, 5.0, 5.0]) * scale**2
    check_rod_axisymmetric(BodyInertia(1.0, np.array([0.5, 0.0, 0.0]) * scale, inertia))
    with pytest.raises(CaseError, match="off the rod axis"):
        check_rod_axisymmetric(BodyInertia(1.0, np.array([0.5, 1e-9, 0.0]) * scale, inertia))
