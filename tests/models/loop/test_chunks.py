"""A long loop table analysed chunk by chunk (``models/loop/chunks.py``) is the whole run.

Oracle: the whole run (:func:`~dualmech.models.loop.table.solve_loop_table`), which follows its branch
through every row at once: the same words at every row, and every value within 1e-12 of its unit group's
scale (the gate's measure, :func:`~dualmech.validation.compare.tables.worst`: a chunk's stations are its
own, so its rows differ by rounding).  The tables chunked at small sizes cross what a chunk boundary must
carry: a start past the first rows (the user table ``rrcrc``, assembled at 11 of its 36 rows), a joint
lock (its 228.2 deg), a gap between two assembled ranges, a general 7R of several assemblies.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dualmech.models.catalogue import load_mechanism
from dualmech.models.loop.chunks import iter_tables
from dualmech.models.loop.columns import loop_spec
from dualmech.models.loop.table import solve_loop_table
from dualmech.models.tables import LinkageTable
from dualmech.validation.compare.tables import worst
from tests.models.loop.test_condition import TURNING_A4, _slider_crank

USER_TABLES = Path(__file__).parents[2] / "validation" / "data"


def _chunked(mechanism, size: int) -> LinkageTable:
    """The chunks of :func:`iter_tables` joined into one table."""
    tables = list(iter_tables(mechanism, size))
    columns = {c: np.concatenate([t.columns[c] for t in tables]) for c in tables[0].columns}
    return LinkageTable(tables[0].engine, tables[0].case, columns,
                        np.concatenate([t.status for t in tables]), {})


def _gap() -> object:
    """The slider crank's table over a turn where it assembles on two ranges with a gap between."""
    _, mechanism = _slider_crank(TURNING_A4, {"start": -80.5, "stop": 279.0, "step": 1.0})
    return mechanism


MECHANISMS = {
    "rscr": lambda: load_mechanism("rscr"),
    "rrcrc": lambda: load_mechanism(str(USER_TABLES / "rrcrc.toml")),
    "gap": _gap,
    "7r": lambda: load_mechanism("7r"),
}


@pytest.mark.parametrize("size", [5, 17])
@pytest.mark.parametrize("name", list(MECHANISMS))
def test_a_table_in_chunks_is_the_whole_run(name: str, size: int) -> None:
    mechanism = MECHANISMS[name]()
    whole, chunked = solve_loop_table(mechanism), _chunked(mechanism, size)
    assert len(chunked) == len(whole) and list(chunked.status) == list(whole.status)
    assert list(chunked.columns) == list(whole.columns)
    differences = worst(whole, chunked, loop_spec(mechanism))
    assert max(differences.values()) <= 1e-12, {c: d for c, d in differences.items() if d > 1e-12}


def test_the_cases_cross_what_a_boundary_must_carry() -> None:
    """The tables above hold what they are meant to: a start past the first rows and a joint lock (rrcrc),
    two assembled ranges with a gap between (the slider crank's)."""
    rrcrc = solve_loop_table(MECHANISMS["rrcrc"]())
    assert list(rrcrc.status).index("ok") > 5
    words = solve_loop_table(_gap()).status
    assembled = np.flatnonzero(words == "ok")
    assert assembled.size and np.any(np.diff(assembled) > 1) and np.any(words == "no_assembly")
