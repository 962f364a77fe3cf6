"""The in-house engine's loop table: where the loop does not close, its message names the drive positions."""

from __future__ import annotations

import copy

import numpy as np

from dualmech.models.linkages import linkage_case, read_linkage
from dualmech.models.loop.table import solve_loop_table


def _runs(key: np.ndarray, mask: np.ndarray) -> list[str]:
    """The runs of ``mask`` as ``"first..last"`` of ``key`` (written out here, apart from the engine's)."""
    runs, start = [], None
    for i, flag in enumerate([*mask, False]):
        if flag and start is None:
            start = i
        elif not flag and start is not None:
            runs.append(f"{key[start]:g}" if start == i - 1 else f"{key[start]:g}..{key[i - 1]:g}")
            start = None
    return runs


def test_a_gap_is_named_by_its_drive_angles() -> None:
    """The bundled 7R over a full turn has a gap near 250 deg (docs/conventions.md, "Loop tables") and past it
    closes only on other assemblies: the messages name exactly the runs of ``no_assembly`` rows and of
    ``branch_jump`` rows (a loop table gave no message before)."""
    data = copy.deepcopy(read_linkage("7r"))
    data["drive"]["positions"]["stop"] = 360.0
    table = solve_loop_table(linkage_case(data))
    words = np.asarray(table.status, dtype=str)
    gap, ended = words == "no_assembly", words == "branch_jump"
    assert gap.any() and ended.any()  # past the gap, the loop closes only on other assemblies
    runs, jumps = (", ".join(_runs(table.columns["theta1_deg"], rows)) for rows in (gap, ended))
    assert table.meta["messages"] == [
        f"no_assembly: the loop does not close at theta1 = {runs} deg",
        "branch_jump: the branch followed from the start has ended: the loop closes only on another "
        f"assembly at theta1 = {jumps} deg"]


def test_a_loop_that_closes_everywhere_has_no_message() -> None:
    table = solve_loop_table(linkage_case("rscr"))
    assert (np.asarray(table.status, dtype=str) != "no_assembly").all() and table.meta["messages"] == []
