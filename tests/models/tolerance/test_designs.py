"""Sampled designs as kernel arrays (models/tolerance/designs.py): the same designs as the case loader builds,
the same outputs as their tables, however the positions are blocked, and the loader's verdict on bad
values."""

import copy

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from dualmech.models.case import CaseError, case_from_dict, load_case
from dualmech.models.slider_crank.analysis import solve_case
from dualmech.models.slider_crank.kernel import case_arrays
from dualmech.models.tolerance.designs import ARRAY_KEYS, analyse_designs, design_arrays
from dualmech.models.tolerance.outputs import design_outputs, output_names
from dualmech.models.tolerance.sampling import sample_chunk
from dualmech.models.tolerance.spec import design_case, nominal_values, spec_from_dict

FIELDS = ("theta", "s", "theta_dot", "s_dot", "theta_ddot", "s_ddot")


def _case(mode, step=9.0):
    raw = copy.deepcopy(load_case("a4-10-s1-3.5").raw)
    raw["motion"].update(angles_deg={"start": 0.0, "stop": 360.0, "step": step}, axial_amplitude=0.7,
                         axial_cycles=2.0)
    if mode == "force":
        del raw["loads"]["drive_torque"]
        raw["loads"]["slider_force"] = -40.0
    return case_from_dict(raw)


def _spec(keys):
    wide = {"geometry.slider_offset": 30.0, "geometry.crank_axial_shift": 4.0,
            "geometry.slider_twist_deg": 30.0,
            "loads.drive_torque": 50.0, "loads.slider_force": 20.0, "geometry.crank_length": 2.0,
            "bodies.rod_radius": 0.3, "motion.crank_rpm": 20.0}
    table = {k: {"dist": "uniform", "low": -wide[k], "high": wide[k]} for k in keys}
    return spec_from_dict({"tolerances": table})


ARRAYS_ONLY = {"torque": ("geometry.slider_offset", "geometry.crank_axial_shift", "geometry.slider_twist_deg",
                          "loads.drive_torque"),
               "force": ("geometry.slider_offset", "loads.slider_force")}
THROUGH_LOADER = ("geometry.slider_offset", "geometry.crank_length", "bodies.rod_radius", "motion.crank_rpm")


@pytest.mark.parametrize("mode", ["torque", "force"])
def test_arrays_are_the_loaders_designs_bit_for_bit(mode):
    case, spec = _case(mode), _spec(ARRAYS_ONLY[mode])
    assert all(k in ARRAY_KEYS for k in spec.keys)
    x = sample_chunk(spec, nominal_values(case, spec), 30, seed=3, index=0)
    got = design_arrays(case, spec, x)
    cases = [design_case(case, spec, row, "d") for row in x]
    geo, bodies = case_arrays(cases)
    assert_array_equal(got.geo, geo)
    for mine, theirs in zip(got.bodies, bodies):
        assert_array_equal(mine, theirs)
    p = len(case.motion.angles_deg)
    states = [c.own_crank_states() for c in cases]
    want = np.stack([np.concatenate([getattr(s, f) for s in states]) for f in FIELDS])
    assert_array_equal(got.crank(slice(0, 30), 0, p), want)
    assert_array_equal(got.crank(slice(4, 7), 5, 11), want.reshape(6, 30, p)[:, 4:7, 5:11].reshape(6, -1))


@pytest.mark.parametrize("mode,keys,chunk_positions", [
    ("torque", ARRAYS_ONLY["torque"], 7),  # a design split along its positions (240 > 100, a warm chain)
    ("torque", ARRAYS_ONLY["torque"], 130),  # three designs a block, the last block short
    ("force", ARRAYS_ONLY["force"], 100_000),
    ("torque", THROUGH_LOADER, 55),
], ids=["split-positions", "designs-per-block", "force-one-block", "through-loader"])
def test_blocked_outputs_are_those_of_the_designs_tables(mode, keys, chunk_positions):
    case, spec = _case(mode, 1.5 if chunk_positions < 100 else 9.0), _spec(keys)
    x = sample_chunk(spec, nominal_values(case, spec), 23, seed=5, index=0)
    got = analyse_designs(design_arrays(case, spec, x), mode, chunk_positions)
    want = design_outputs([solve_case(design_case(case, spec, row, "d")) for row in x], mode)
    assert len(set(want["status"])) > 1  # the sample crosses the edge of assembly
    counts = ("assembled_fraction", "dead_centres", "failed_positions", "branch_jumps")
    for name in (*output_names(mode), *counts, "status"):
        assert_array_equal(got[name], want[name], err_msg=name)


@pytest.mark.parametrize("key,bad,message", [
    ("geometry.slider_offset", 5e13, r"design-0000012 .*geometry.crank_length: .* less than 1/1e\+12"),
    ("geometry.slider_twist_deg", 2e6, r"design-0000012 .*geometry.slider_twist_deg: .*an angle in degrees"),
    ("loads.drive_torque", -3e15, r"design-0000012 .*loads.drive_torque: .*a torque"),
])
def test_a_value_the_loader_refuses_is_named_with_its_design(key, bad, message):
    case, spec = _case("torque"), _spec(ARRAYS_ONLY["torque"])
    x = sample_chunk(spec, nominal_values(case, spec), 20, seed=1, index=0)
    x[2, spec.keys.index(key)] = bad
    design_arrays(case, spec, x[:2], first=10)  # the designs around it load
    with pytest.raises(CaseError, match=message):
        design_arrays(case, spec, x, first=10)


def test_the_corners_refuse_a_chunk_exactly_when_the_loader_refuses_one_of_its_designs():
    """Chunks straddling every bound of the array keys (ranges and the proportions bound, 1e12 x a1 = 1.2e13):
    refused iff some design is, so the convexity the corner check relies on holds for these keys."""
    rng = np.random.default_rng(11)
    case, spec = _case("torque"), _spec(ARRAYS_ONLY["torque"])
    edges = np.array([1.2e13, 1.2e13, 1e6, 1e15])  # a4, S1 (proportions), alpha4 deg, torque (ranges)
    refused = 0
    for trial in range(40):
        x = rng.choice([-1.0, 1.0], size=(6, 4)) * edges * rng.uniform(0.9, 1.005, size=(6, 4))
        x[:, rng.integers(4, size=2)] = rng.uniform(-5.0, 5.0, size=(6, 2))  # some keys well inside
        loader = []
        for row in x:
            try:
                design_case(case, spec, row, "d")
                loader.append(True)
            except CaseError:
                loader.append(False)
        try:
            design_arrays(case, spec, x)
            arrays = True
        except CaseError:
            arrays = False
        assert arrays == all(loader), (trial, x)
        refused += not arrays
    assert 5 < refused < 35  # both verdicts reached
