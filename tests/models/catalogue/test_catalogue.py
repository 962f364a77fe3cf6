"""Every bundled case of every kind, read by the one front door of a case (models/catalogue/).

Records hold arrays: two loads of one source are compared by their ``repr``."""

from __future__ import annotations

import pytest

from dualmech.models.catalogue import bundled_case_path, bundled_cases, load_mechanism
from dualmech.models.inputs import CaseError
from dualmech.models.kinds import KIND_HOMES, KINDS, kind_of, resolve
from dualmech.models.toml_input import read_toml


def test_every_bundled_case_loads_as_its_declared_kind() -> None:
    rows = bundled_cases()
    assert {kind for _, kind, _ in rows} == set(KINDS)  # every kind has a bundled case
    for name, kind, _ in rows:
        case = load_mechanism(name)
        assert kind_of(case) == kind and isinstance(case, resolve(KIND_HOMES[kind].record)), name
        path = bundled_case_path(name)
        assert kind_of(read_toml(path, CaseError)) == kind, name
        assert repr(load_mechanism(path)) == repr(case) == repr(load_mechanism(str(path))), name


def test_a_record_and_a_table_pass_through() -> None:
    case = load_mechanism("rssr")
    assert load_mechanism(case) is case
    assert repr(load_mechanism(read_toml(bundled_case_path("rssr"), CaseError))) == repr(case)


def test_an_unknown_name_and_a_non_case_are_one_line() -> None:
    with pytest.raises(CaseError, match=r"^case: 'no-such' is neither a file nor a bundled preset \(presets: "
                                        r"iftomm/\{spatial-slider-crank\}, thesis/\{.*ideal\}, .*rssr\)$"):
        load_mechanism("no-such")
    with pytest.raises(TypeError, match=r"^case: expected a dualmech\.Case .*got 3$"):
        load_mechanism(3)
