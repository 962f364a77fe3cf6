"""Hostile input (issue 11): fuzzed case and matrix files.

Property of every input: loading raises a ``ValueError`` whose message is one line
starting with the key it is about, or the input loads and the in-house engine gives
only finite numbers in its ``ok`` rows (and, for a matrix, every name that becomes a
file name is one safe path component).  The fuzz drives the library in-process (a
coarse angle step keeps each solve to milliseconds).  Hypothesis runs derandomized
(the same inputs on every run) with a stated number of examples.  The inputs the issue
lists, one by one, are in ``test_hostile_cli_inputs.py`` (command line, exit code 2 and
exactly one stderr line) and ``test_hostile_matrices.py``; the last line of defence in
``test_internal_errors.py``.
"""

from __future__ import annotations

import re
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from dualmech.core.status import Status
from dualmech.models.case import case_from_dict
from dualmech.models.slider_crank.analysis import solve_case
from dualmech.validation.matrix import check_file_name, matrix_from_dict, parse_matrix
from tests.hostile_inputs import HOSTILE_NUMBERS, ideal_case, mutate

ROOT = Path(__file__).resolve().parents[1]
CASE_FILES = sorted((ROOT / "models" / "cases" / "thesis").glob("*.toml"))
MATRIX_FILES = sorted((ROOT / "validation" / "matrices").glob("*.toml"))
#: Examples per fuzz test (two case tests and one matrix test: 400 + 150 + 150 inputs per run).
CASE_EXAMPLES, LEAF_EXAMPLES, MATRIX_EXAMPLES = 400, 150, 150
#: A message names its key first: a key of the case or matrix format (then '.', '[', ':' or ' '),
#: or an unknown key as written (then the message says "unknown"), or the file.
FORMAT_KEYS = ("name units description geometry motion bodies loads case base base_label engines reference "
               "quantities set labels load_modes sweep tolerances matrix").split()
KEY_FIRST = re.compile(r"^(" + "|".join(FORMAT_KEYS) + r")[.\[: ]")
#: Angles per fuzzed case when solving (the engine's cost is per position).
COARSE_STEP = 30.0

# ----------------------------------------------------------------------------- strategies

@st.composite
def mutated_cases(draw: st.DrawFn) -> dict:
    path = draw(st.sampled_from(CASE_FILES))
    return mutate(tomllib.loads(path.read_text()), draw, draw(st.integers(1, 3)))


@st.composite
def mutated_matrices(draw: st.DrawFn) -> tuple[dict, Path]:
    path = draw(st.sampled_from(MATRIX_FILES))
    data = mutate(tomllib.loads(path.read_text()), draw, draw(st.integers(1, 3)))
    if draw(st.booleans()):
        data.pop("load_modes", None)
    if draw(st.booleans()) and isinstance(data.get("sweep"), list) and data["sweep"]:
        sweep = data["sweep"][0]
        if isinstance(sweep, dict):
            sweep["expect"] = draw(st.sampled_from(["no_assembly", "no_assembly", "maybe", 1]))
    if draw(st.booleans()):
        data["name"] = draw(st.sampled_from(["/tmp/victim", "../../x", "a/b", "..", ".hidden", "-rf",
                                             "x" * 101, "ok-name", "a\x00b", "tab\tname", "ünï", ""]))
    return data, path


# ----------------------------------------------------------------------------- the property

def _assert_one_line_naming_a_key(err: ValueError) -> None:
    msg = str(err)
    assert msg and "\n" not in msg and len(msg) < 600, repr(msg)
    assert KEY_FIRST.match(msg) or ": unknown" in msg or msg.startswith("/"), f"no key first: {msg!r}"


def _assert_finite_ok_rows(case) -> None:
    if len(case.motion.angles_deg) > 360 / COARSE_STEP:
        case = case.with_values({"motion.angles_deg": {"start": 0.0, "stop": 360.0, "step": COARSE_STEP}})
    with np.errstate(all="ignore"):  # the engine flags such rows; the property is what it calls ok
        table = solve_case(case)
    ok = table.status == Status.OK
    for name, column in table.columns.items():
        bad = ok & ~np.isfinite(np.asarray(column, dtype=float))
        assert not bad.any(), (f"{case.name}: {name} not finite in {int(bad.sum())} ok rows, "
                               f"e.g. at {table['theta1_deg'][bad][:3]} deg")


def _check_case(data: dict) -> None:
    try:
        case = case_from_dict(data)
    except ValueError as err:
        _assert_one_line_naming_a_key(err)
        return
    _assert_finite_ok_rows(case)


@settings(max_examples=CASE_EXAMPLES, derandomize=True, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(mutated_cases())
def test_fuzzed_case_files_load_cleanly_or_fail_in_one_line(data):
    _check_case(data)


@settings(max_examples=LEAF_EXAMPLES, derandomize=True, deadline=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from(CASE_FILES),
       st.sampled_from(["geometry.crank_length", "geometry.rod_length", "geometry.slider_offset",
                        "geometry.slider_twist_deg", "geometry.crank_axial_shift", "motion.crank_rpm",
                        "motion.crank_accel", "motion.axial_amplitude", "motion.axial_cycles",
                        "bodies.crank_radius", "bodies.rod_radius", "bodies.slider_side",
                        "bodies.weight_density", "bodies.gravity_constant", "loads.drive_torque"]),
       st.one_of(HOSTILE_NUMBERS, st.floats(min_value=-1e15, max_value=1e15)))
def test_every_number_of_a_case_at_any_value(path, key, value):
    """One number at a time, over its whole range and beyond: within the range the engine is finite."""
    data = tomllib.loads(path.read_text())
    section, leaf = key.split(".")
    data[section][leaf] = value
    _check_case(data)


@settings(max_examples=MATRIX_EXAMPLES, derandomize=True, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(mutated_matrices())
def test_fuzzed_matrix_files_expand_cleanly_or_fail_in_one_line(data_and_path):
    data, path = data_and_path
    try:
        matrix = parse_matrix(data, source=str(path), matrix_file=path)
    except ValueError as err:
        _assert_one_line_naming_a_key(err)
        return
    for name in (matrix.name, *(c.id for c in matrix.cases), *(s.name for s in matrix.sweeps)):
        assert check_file_name("name", name) == name and Path(name).name == name and name not in (".", "..")
    assert matrix_from_dict(matrix.to_dict()) == matrix
    assert len(matrix.cases) <= 1000
    for mc in matrix.cases[:4]:  # a few cases per matrix keeps the run short; the case fuzz does the rest
        _assert_finite_ok_rows(mc.case())


# ----------------------------------------------------------------------------- the property is not vacuous

def test_the_fuzz_property_catches_a_non_finite_ok_row(monkeypatch):
    """The property is not vacuous: an engine that calls a NaN row ok fails it."""
    real = solve_case

    def broken(case):
        table = real(case)
        table.columns["j2_fx"][0] = np.nan
        table.status[0] = Status.OK
        return table

    monkeypatch.setattr(sys.modules[__name__], "solve_case", broken)
    with pytest.raises(AssertionError, match="j2_fx not finite"):
        _check_case(ideal_case())
