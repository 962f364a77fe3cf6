"""A case's sizes against its stated unit system (:mod:`dualmech.models.plausibility`).

The mistake a user made: the IFToMM-sized crank entered in mm under ``units = "m-kg-s"`` solved to a
1.2e8 kg crank and a 1.28e16 N·m drive torque, exit 0, no word.  It must warn (naming the likely
cause), and the bundled presets must not.
"""

from __future__ import annotations

import warnings

import pytest

from dualmech.models.case import load_case, preset_names
from dualmech.models.plausibility import ImplausibleUnitsWarning, implausible, masses_line, warn_implausible

#: A steel slider crank in mm (crank 80, rod 300, offset 156), with units and densities as given.
MM_CASE = """
name = "mm-design"
units = "{units}"
[geometry]
crank_length = 80.0
rod_length = 300.0
slider_offset = 156.0
slider_twist_deg = 270.0
crank_axial_shift = 0.0
[motion]
crank_rpm = 60.0
angles_deg = {{ start = 0.0, stop = 360.0, step = 10.0 }}
[bodies]
crank_radius = 10.0
rod_radius = 8.0
slider_side = 30.0
density = {density}
[loads]
drive_torque = 1.0
"""


def _case(tmp_path, units: str, density: float):
    path = tmp_path / "case.toml"
    path.write_text(MM_CASE.format(units=units, density=density))
    return load_case(str(path))


def test_mm_under_si_warns_with_the_cause(tmp_path) -> None:
    case = _case(tmp_path, "m-kg-s", 7850.0)
    found = implausible(case)
    assert found[0].startswith("link a2 = 300 m is longer than 100 m")
    assert "lengths look like mm; in m-kg-s lengths are in metres" in found[0]
    crank = next(line for line in found if line.startswith("crank mass"))
    assert "crank mass 1.97e+08 kg is over 100000 kg" in crank and "follows from the lengths" in crank
    with pytest.warns(ImplausibleUnitsWarning) as record:
        warn_implausible(case)
    assert [str(w.message) for w in record] == [f"mm-design: {line}" for line in found]


def test_the_same_design_under_mm_units_is_plausible(tmp_path) -> None:
    assert implausible(_case(tmp_path, "mm-N-s", 7.85e-9)) == []


def test_a_density_in_kg_per_m3_under_mm_units_warns(tmp_path) -> None:
    """Lengths right, density in kg/m³ where mm-N-s wants t/mm³: the masses are 1e12 times too large."""
    found = implausible(_case(tmp_path, "mm-N-s", 7850.0))
    assert found and all(line.split()[0] in ("crank", "rod", "slider") for line in found)
    assert "steel is 7.85e-09" in found[0] and "t/mm³" in found[0]


def test_metres_under_mm_units_warn(tmp_path) -> None:
    path = tmp_path / "case.toml"
    text = MM_CASE.format(units="mm-N-s", density=7.85e-9)
    for key, value in (("80.0", "0.08"), ("300.0", "0.3"), ("156.0", "0.156"), ("10.0\n", "0.01\n"),
                       ("8.0\n", "0.008\n"), ("30.0\n", "0.03\n")):
        text = text.replace(f"= {key}", f"= {value}", 1)
    path.write_text(text)
    found = implausible(load_case(str(path)))
    assert "link a1 = 0.08 mm is shorter than 0.1 mm" in found[0] and "lengths look like m;" in found[0]


def test_an_inertia_in_kg_mm2_under_si_warns() -> None:
    case = load_case("iftomm/spatial-slider-crank")
    rod = case.raw["bodies"]["rod"]
    wrong = case.with_values({"bodies.rod.inertia": [[v * 1e6 for v in row] for row in rod["inertia"]]})
    found = implausible(wrong)
    assert len(found) == 1 and found[0].startswith("rod inertia 4e+03 kg·m²")


@pytest.mark.parametrize("name", preset_names())
def test_presets_are_plausible(name: str) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error", ImplausibleUnitsWarning)
        assert warn_implausible(load_case(name)) == []


def test_masses_line_has_units() -> None:
    assert masses_line(load_case("iftomm/spatial-slider-crank")) == (
        "body masses: crank 0.12 kg, rod 0.5 kg, slider 2 kg")
    assert masses_line(load_case("thesis/ideal")).startswith("body masses: crank 0.0614659 lbf·s²/in")


def test_the_api_solve_warns(tmp_path) -> None:
    """``dualmech.validation.solve`` (the API) issues the warning and still solves."""
    from dualmech.verbs import solve

    with pytest.warns(ImplausibleUnitsWarning) as record:
        table = solve(_case(tmp_path, "m-kg-s", 7850.0))
    assert str(record[0].message).startswith("mm-design: link a2 = 300 m") and len(record) == 4
    assert len(table) == 36  # 0 .. 350 deg (the stop is excluded)
