"""Tolerance SPEC parsing and seeded sampling (models/tolerance/spec.py, sampling.py)."""

import numpy as np
import pytest
from numpy.testing import assert_allclose

from dualmech.models.case import CaseError, load_case
from dualmech.models.tolerance.sampling import CHUNK_DESIGNS, judge_picks, n_chunks, sample_chunk
from dualmech.models.tolerance.spec import SpecError, design_case, load_spec, nominal_values, spec_from_dict

#: Sample moments against the distribution's (n = 20000): 5 standard errors of the mean / variance.
MOMENT_SE = 5.0


def _spec(**tolerances):
    return spec_from_dict({"tolerances": {k.replace("__", "."): v for k, v in tolerances.items()}})


def test_nested_tables_and_dotted_keys_are_the_same_spec():
    nested = spec_from_dict({"tolerances": {"geometry": {"slider_offset": {"dist": "normal", "sd": 0.1}}}})
    dotted = _spec(geometry__slider_offset={"dist": "normal", "sd": 0.1})
    assert nested.to_dict() == dotted.to_dict()  # (unused parameters are NaN, so compare the stored form)
    assert spec_from_dict(dotted.to_dict()).to_dict() == dotted.to_dict()  # what a study stores, workers read


@pytest.mark.parametrize("data, words", [
    ({"tolerances": {"geometry.slider_offset": {"dist": "gauss", "sd": 1}}},
     ["dist", "'gauss'", "truncnormal"]),
    ({"tolerances": {"geometry.slider_offset": {"dist": "normal"}}}, ["sd", "required"]),
    ({"tolerances": {"geometry.slider_offset": {"dist": "normal", "sd": -1}}}, ["sd", "-1", "positive"]),
    ({"tolerances": {"geometry.slider_offset": {"dist": "normal", "sd": float("nan")}}},
     ["sd", "nan", "finite"]),
    ({"tolerances": {"geometry.slider_offset": {"dist": "uniform", "low": 1, "high": 1}}}, ["low < high"]),
    ({"tolerances": {"geometry.slider_offset": {"dist": "uniform", "low": 0, "high": 1, "sd": 2}}},
     ["sd", "valid"]),
    ({"tolerances": {"geometry.slider_offset": {"dist": "uniform", "low": "a", "high": 1}}}, ["low", "'a'"]),
    ({"tolerances": {"geometry.slider_offset": {"dist": "truncnormal", "sd": 1, "low": 50, "high": 60}}},
     ["mass", "low..high"]),
    ({"tolerances": {"geometry.slider_offset": 0.1}}, ["geometry.slider_offset", "0.1", "dist"]),
    ({"tolerances": {}}, ["tolerances", "at least one"]),
    ({"tolerance": {}}, ["tolerance", "unknown key"]),
])
def test_bad_specs_are_one_line_naming_key_value_and_what_is_valid(data, words):
    with pytest.raises(SpecError) as err:
        spec_from_dict(data)
    message = str(err.value)
    assert "\n" not in message
    for w in words:
        assert w in message


def test_a_key_the_slider_crank_cannot_vary_is_one_line_naming_the_valid_ones():
    """Keys are the case kind's: checked when the SPEC meets the case (a loop table's "joint[2].a" parses)."""
    spec = _spec(geometry__nope={"dist": "normal", "sd": 1})
    with pytest.raises(SpecError) as err:
        nominal_values(load_case("ideal"), spec)
    message = str(err.value)
    assert "\n" not in message
    assert message.startswith("tolerances.geometry.nope: not a key that can vary "
                              "(valid: geometry.crank_length, geometry.rod_length, ")


def test_a_key_the_case_does_not_give_is_refused():
    spec = _spec(loads__slider_force={"dist": "normal", "sd": 1.0})
    with pytest.raises(SpecError, match="loads.slider_force.*does not give"):
        nominal_values(load_case("ideal"), spec)


def test_sampled_values_are_checked_by_the_case_loader():
    case = load_case("ideal")
    spec = _spec(geometry__crank_length={"dist": "uniform", "low": -20.0, "high": -13.0})
    with pytest.raises(CaseError, match="geometry.crank_length.*positive length"):
        design_case(case, spec, nominal_values(case, spec) - 14.0, "bad")


def test_design_case_sets_exactly_the_varied_keys():
    case = load_case("a4-20-s1-3.5")
    spec = _spec(geometry__slider_offset={"dist": "normal", "sd": 1.0},
                 bodies__rod__mass={"dist": "normal", "sd": 0.01})
    x = nominal_values(case, spec)
    assert_allclose(x, [20.0, case.bodies.rod.mass], rtol=0, atol=0)
    d = design_case(case, spec, x + [1.5, 0.002], "d")
    assert d.geometry.slider_offset == 21.5 and d.bodies.rod.mass == case.bodies.rod.mass + 0.002
    assert_allclose(d.bodies.rod.inertia, case.bodies.rod.inertia * d.bodies.rod.mass / case.bodies.rod.mass,
                    rtol=1e-15, atol=0)  # a stated mass keeps the inertia's shape (models/case.py)
    assert d.geometry.crank_length == case.geometry.crank_length and d.name == "d"


def test_same_seed_same_samples_and_chunks_are_independent_of_each_other():
    spec = _spec(geometry__slider_offset={"dist": "normal", "sd": 1.0},
                 geometry__slider_twist_deg={"dist": "truncnormal", "sd": 2.0, "low": -1.0, "high": 3.0})
    nominal = np.array([20.0, 270.0])
    n = 3 * CHUNK_DESIGNS + 7
    first = [sample_chunk(spec, nominal, n, 11, c) for c in range(n_chunks(n))]
    again = [sample_chunk(spec, nominal, n, 11, c) for c in reversed(range(n_chunks(n)))][::-1]
    for a, b in zip(first, again):
        assert_allclose(a, b, rtol=0, atol=0)
    assert first[-1].shape == (7, 2)
    other = sample_chunk(spec, nominal, n, 12, 0)
    assert not np.allclose(other, first[0])


@pytest.mark.parametrize("entry", [{"dist": "normal", "sd": 0.3},
                                   {"dist": "uniform", "low": -0.2, "high": 0.6},
                                   {"dist": "truncnormal", "sd": 1.0, "low": -0.5, "high": 2.0}])
def test_samples_follow_their_distribution(entry):
    spec = _spec(geometry__slider_offset=entry)
    t = spec.tolerances[0]
    n = 20_000
    x = np.concatenate([sample_chunk(spec, np.array([5.0]), n, 3, c) for c in range(n_chunks(n))])[:, 0] - 5.0
    if "low" in entry:
        assert x.min() >= t.low and x.max() <= t.high
    se_mean = np.sqrt(t.variance() / n)
    se_var = t.variance() * np.sqrt(2.0 / n) * 2  # x2: a kurtosis margin for the uniform / truncated cases
    assert_allclose(x.mean(), t.mean(), rtol=0, atol=MOMENT_SE * se_mean)
    assert_allclose(x.var(), t.variance(), rtol=0, atol=MOMENT_SE * se_var)


def test_judge_picks_are_seeded_and_within_the_candidates():
    cands = np.array([3, 5, 8, 13, 21])
    a, b = judge_picks(3, 7, cands), judge_picks(3, 7, cands)
    assert_allclose(a, b, rtol=0, atol=0)
    assert set(a) <= set(cands) and len(set(a)) == 3
    assert judge_picks(9, 7, cands).size == 5 and judge_picks(0, 7, cands).size == 0


def test_the_bundled_thesis_spec_reads():
    from pathlib import Path

    import dualmech.models

    spec = load_spec(Path(dualmech.models.__file__).parent / "cases/thesis/tolerances/tolerances-thesis.toml")
    assert spec.keys == ("geometry.slider_offset", "geometry.crank_axial_shift", "geometry.slider_twist_deg")


@pytest.mark.parametrize("text, lines", [
    ('[tolerances]\n"geometry.rod_length" = { dist = "normal", sd = 0.01 }\n[tolerances.geometry]\n'
     'rod_length = { dist = "normal", sd = 0.5 }\n', "lines 2, 4"),
    ('tolerances.geometry.rod_length = { dist = "normal", sd = 0.01 }\n\n[tolerances."geometry.rod_length"]\n'
     'dist = "normal"\nsd = 0.5\n', "lines 1, 3"),
])
def test_a_key_given_twice_is_one_line_naming_it_and_its_lines(tmp_path, text, lines):
    """Why: the same key given twice (dotted and nested, which TOML allows) was silently merged."""
    path = tmp_path / "spec.toml"
    path.write_text(text)
    with pytest.raises(SpecError) as err:
        load_spec(path)
    message = str(err.value)
    assert "\n" not in message and "geometry.rod_length" in message and "twice" in message
    assert lines in message
