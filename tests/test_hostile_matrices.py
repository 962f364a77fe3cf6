"""Hostile input (issue 11), the matrix files the issue lists, one by one: a name that leaves the output
folder, optional and bounded keys, unknown keys named with the valid ones, a crank at rest.  The fuzzed
matrices are in ``test_fuzz_inputs.py``.
"""

from __future__ import annotations

import tomllib

import pytest

from dualmech.validation.matrix import matrix_from_dict, parse_matrix
from tests.hostile_inputs import run_cli

MATRIX = """
name = "{name}"
base = "thesis/ideal"
engines = ["dualmech", "pinocchio"]
set = {{ "motion.angles_deg" = {{ start = 0.0, stop = 360.0, step = 90.0 }} }}

[[sweep]]
name = "a4"
grid = {{ "geometry.slider_offset" = [10.0] }}
"""


@pytest.mark.parametrize("name", ["VICTIM", "../../victim", "a/../../victim", "..", "victim\x01"])
def test_a_matrix_name_that_leaves_the_output_folder_is_refused_and_nothing_is_written(tmp_path, name):
    """The matrix name is the default output folder runs/<name>: it wrote to '/tmp/victim' and '../../x'."""
    work = tmp_path / "a" / "b"
    work.mkdir(parents=True)
    victim = tmp_path / "victim"
    path = work / "m.toml"
    path.write_text(MATRIX.format(name=str(victim) if name == "VICTIM" else name.replace("\x01", "\\u0001")))
    proc = run_cli("validate", str(path), "--jobs", "1", cwd=work)
    assert proc.returncode == 2, proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and "name: " in proc.stderr, proc.stderr
    assert not victim.exists() and sorted(p.name for p in tmp_path.rglob("*")) == ["a", "b", "m.toml"]


def test_a_matrix_without_load_modes_runs_in_the_base_case_mode():
    """The format calls [load_modes] optional; it raised StopIteration."""
    matrix = parse_matrix(tomllib.loads(MATRIX.format(name="no-modes")))
    assert matrix.modes == ("torque",) and [c.id for c in matrix.cases] == ["torque_base", "torque_a4=10"]
    assert all(c.case().loads.drive_torque == 100.0 for c in matrix.cases)


def test_sweep_expect_is_declared_carried_and_checked():
    data = tomllib.loads(MATRIX.format(name="expect"))
    data["sweep"].append({"name": "beyond", "expect": "no_assembly", "include_base": False,
                          "grid": {"geometry.slider_offset": [80.0]}})
    matrix = parse_matrix(data)
    expects = {c.id: c.expect for c in matrix.cases}
    assert expects == {"torque_base": None, "torque_a4=10": None, "torque_a4=80": "no_assembly"}
    assert {c.id: c.expect for c in matrix_from_dict(matrix.to_dict()).cases} == expects
    data["sweep"][1]["expect"] = "no-assembly"
    with pytest.raises(ValueError, match=r"sweep\[1\]\.expect: 'no-assembly' is not an expectation"):
        parse_matrix(data)


def test_a_matrix_is_bounded_before_it_is_expanded():
    data = tomllib.loads(MATRIX.format(name="big"))
    data["sweep"][0]["grid"] = {"geometry.slider_offset": list(range(100)),
                                "geometry.rod_length": [50.0 + k for k in range(100)],
                                "geometry.crank_axial_shift": list(range(100))}
    with pytest.raises(ValueError, match=r"more than 1,000 cases .*1,000,000 points"):
        parse_matrix(data)


def test_an_unknown_key_is_named_with_every_valid_key_sorted():
    """One helper writes every "unknown key" line (models.inputs.check_keys): the key (quoted when odd) and
    the valid keys, sorted; a sweep's and a SPEC's keys go through it."""
    from dualmech.models.inputs import check_keys
    from dualmech.models.tolerance.spec import SpecError, spec_from_dict

    with pytest.raises(ValueError) as err:
        check_keys("bodies.crank", {"mass": 1.0, "colour": "red"}, {"mass", "inertia", "com"})
    assert str(err.value) == "bodies.crank.colour: unknown key (valid: com, inertia, mass)"
    with pytest.raises(SpecError) as err:
        spec_from_dict({"tolerances": {}, "a b": 1})
    assert str(err.value) == "'a b': unknown key (valid top-level keys: description, tolerances)"
    data = tomllib.loads(MATRIX.format(name="keys"))
    data["sweep"][0]["grids"] = {}
    with pytest.raises(ValueError) as err:
        parse_matrix(data)
    assert str(err.value) == ("sweep[0].grids: unknown key "
                              "(valid: cases, expect, fixed, grid, include_base, label, name)")
    check_keys("", {"name": "x"}, ("name",))  # every key valid: no error


def test_report_of_a_crank_at_rest_has_no_balancing_ratio():
    """crank_rpm = 0 (quasi-static, a meaningful case) divided by a zero shaking force in the report."""
    from dualmech.validation.report.derived import balancing

    data = tomllib.loads(MATRIX.format(name="rest"))
    data["set"]["motion.crank_rpm"] = 0.0
    rows = balancing(parse_matrix(data)).rows
    assert rows and all(r["force_before"] == 0.0 and r["ratio"] is None for r in rows)
