"""docs/matrix-format.md stays true: its example files parse, and expand to the case ids its runs print."""

from __future__ import annotations

import re
from pathlib import Path

from dualmech.models.kinds import kind_of
from dualmech.validation.matrix import load_matrix

DOC = Path(__file__).resolve().parents[3] / "docs" / "matrix-format.md"


def _example_files(tmp_path: Path) -> dict[str, Path]:
    """Every ```toml block of the page that starts with ``# file: NAME``, written to ``tmp_path/NAME``."""
    files = {}
    for block in re.findall(r"```toml\n(.*?)```", DOC.read_text(encoding="utf-8"), flags=re.S):
        first = block.splitlines()[0]
        if first.startswith("# file: "):
            path = tmp_path / first.removeprefix("# file: ").strip()
            path.write_text(block, encoding="utf-8")
            files[path.name] = path
    return files


def _printed_ids(command: str) -> list[str]:
    """The case column of the run the page prints after ``$ dualmech validate <command>``."""
    text = DOC.read_text(encoding="utf-8")
    run = text[text.index(f"$ dualmech validate {command}"):]
    run = run[:run.index("```")]
    return [line.split()[0] for line in run.splitlines() if "│" in line]


def test_the_examples_expand_to_the_cases_the_page_shows(tmp_path):
    files = _example_files(tmp_path)
    assert sorted(files) == ["design.toml", "full.toml", "minimal.toml", "rscr-study.toml"]
    for name in ("minimal.toml", "full.toml"):
        matrix = load_matrix(files[name])
        assert [c.id for c in matrix.cases] == _printed_ids(name), name
    full = load_matrix(files["full.toml"])
    assert full.engines == ("dualmech", "pinocchio", "mujoco", "mujoco-sim")
    assert [c.expect for c in full.cases if c.id.endswith("e=0.3")] == ["no_assembly", "no_assembly"]
    assert full.tolerance("mujoco-sim", "S4_ddot").value == 2e-3
    assert full.tolerance("pinocchio", "S4").name == "MATRIX_KINEMATICS"
    assert full.tolerance("mujoco", "stroke").value == 1e-4


def test_the_linkage_base_example_expands_to_the_cases_the_page_shows(tmp_path):
    matrix = load_matrix(_example_files(tmp_path)["rscr-study.toml"])
    assert [c.id for c in matrix.cases] == _printed_ids("rscr-study.toml")
    assert matrix.engines == ("dualmech", "pinocchio") and {kind_of(c.raw) for c in matrix.cases} == {"loop"}
