"""Every bundled case of every kind, and a case of any kind read from a file, a name or a table.

The one front door of a case for the commands and the API: ``dualmech solve rssr``, ``solve thesis/ideal``
and ``solve my_loop.toml`` all read their case here, and its kind (:func:`~dualmech.models.kinds.kind_of`)
then picks the solver, the summary and the options (:data:`~dualmech.models.kinds.KIND_HOMES`); no caller
asks "is this a linkage?".
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from dualmech.models.case import load_case, preset_names, preset_path
from dualmech.models.inputs import CaseError, show
from dualmech.models.kinds import SLIDER_CRANK, case_from_data, is_record, kind_of
from dualmech.models.linkages import bundled_names, bundled_path, read_linkage
from dualmech.models.toml_input import read_toml


def bundled_cases() -> list[tuple[str, str, str]]:
    """Every bundled preset of every kind as ``(name, kind, one line about it)``: the slider crank's
    (``"thesis/ideal"``, its link-joint constants and description), then the other kinds' (``"rssr"``,
    their ``[mechanism] kind`` and description).  Each name is what :func:`load_mechanism` takes."""
    rows = []
    for name in preset_names():
        case = load_case(name)
        g = case.geometry
        rows.append((name, SLIDER_CRANK, f"a1={g.crank_length:g} a2={g.rod_length:g} a4={g.slider_offset:g} "
                     f"alpha4={g.slider_twist_deg:g} S1={g.crank_axial_shift:g}  "
                     f"{case.raw.get('description', '')}"))
    for name in bundled_names():
        data = read_linkage(name)
        rows.append((name, kind_of(data), str(data.get("description", ""))))
    return rows


def bundled_case_path(name: str) -> Path:
    """The file of the bundled preset ``name`` of any kind (a name of :func:`bundled_cases`, or a slider
    crank's unique stem such as ``"ideal"``).

    Raises
    ------
    CaseError
        One line naming ``name`` and every valid name, where it is none of them.
    """
    if name in bundled_names():
        return bundled_path(name)
    try:
        return preset_path(name)
    except CaseError:
        raise CaseError(f"case: {show(name)} is neither a file nor a bundled preset (presets: "
                        f"{preset_list()})") from None


def preset_list() -> str:
    """Every bundled preset's name, those of a folder grouped: ``"thesis/{ideal, a4-10-s1-3.5}, rssr"``."""
    groups: dict[str, list[str]] = {}
    for name in preset_names():
        group, stem = name.split("/", 1)
        groups.setdefault(group, []).append(stem)
    return ", ".join([f"{g}/{{{', '.join(stems)}}}" for g, stems in groups.items()] + bundled_names())


def load_mechanism(source: Any) -> Any:
    """The checked case record of ``source``, of whatever kind it is.

    Parameters
    ----------
    source : a case record, str, os.PathLike or dict
        A checked record (:data:`~dualmech.models.kinds.KIND_HOMES`: returned as is), a case TOML file, a
        bundled preset name of any kind (:func:`bundled_cases`) or a parsed case table.

    Raises
    ------
    TypeError
        One line, where ``source`` is none of these.
    CaseError
        One line, for any invalid file, name or table (the key, the value and what would be valid).
    """
    if is_record(source):
        return source
    if isinstance(source, dict):
        return case_from_data(source)
    if not isinstance(source, (str, os.PathLike)):
        raise TypeError(f"case: expected a dualmech.Case (or another kind's checked case), a case file, a "
                        f"preset name (dualmech cases lists them) or a case table (dict), got {show(source)}")
    path = Path(source)
    return case_from_data(read_toml(path if path.is_file() else bundled_case_path(str(source)), CaseError))
