"""Hostile input (issue 11), the case files and options the issue lists, one by one, at the command
line: each is refused with exit code 2 and exactly one stderr line naming the key, and nothing is
written.  The fuzzed files are in ``test_fuzz_inputs.py``.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.hostile_inputs import ideal_case, run_cli

ROOT = Path(__file__).resolve().parents[1]


def _write_case(tmp_path: Path, edit) -> Path:
    data = ideal_case()
    edit(data)
    lines = []
    for section, table in data.items():
        if not isinstance(table, dict):
            lines.insert(0, f"{section} = {_toml(table)}")
            continue
        lines.append(f"[{section}]")
        lines += [f"{k} = {_toml(v)}" for k, v in table.items()]
    path = tmp_path / "case.toml"
    path.write_text("\n".join(lines) + "\n")
    return path


class Raw(str):
    """TOML text written as is (a number Python's ``str`` would refuse to print)."""


def _toml(v: object) -> str:
    if isinstance(v, Raw):
        return str.__str__(v)
    if isinstance(v, bool):
        return str(v).lower()
    if isinstance(v, str):
        return '"' + v + '"'
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {_toml(x)}" for k, x in v.items()) + " }"
    if isinstance(v, list):
        return "[" + ", ".join(_toml(x) for x in v) + "]"
    return str(v)  # TOML writes floats and integers as Python does ("1e+300" is valid TOML)


CASE_EDITS = {
    "1e300 length": (lambda d: d["geometry"].update(crank_length=1e300), "geometry.crank_length"),
    "crank_rpm 1e160": (lambda d: d["motion"].update(crank_rpm=1e160), "motion.crank_rpm"),
    "crank_rpm 1e308": (lambda d: d["motion"].update(crank_rpm=1e308), "motion.crank_rpm"),
    "crank_accel -1e308": (lambda d: d["motion"].update(crank_accel=-1e308), "motion.crank_accel"),
    "huge integer": (lambda d: d["geometry"].update(rod_length=10**400), "geometry.rod_length"),
    "overflowing step": (lambda d: d["motion"].update(angles_deg={"step": 5e-324}), "motion.angles_deg.step"),
    "unknown units": (lambda d: d.update(units="parsec-stone-fortnight"), "units"),
    # issue 31: Python's own refusal ("Exceeds the limit (4300 digits) for integer string conversion")
    "5001-digit twist": (lambda d: d["geometry"].update(slider_twist_deg=Raw("2" + "7" * 5000)),
                         "geometry.slider_twist_deg"),
    "5001-digit step": (lambda d: d["motion"].update(angles_deg={"step": Raw("1" + "0" * 5000)}),
                        "motion.angles_deg.step"),
    "kind = 42": (lambda d: d.update(mechanism={"kind": 42}), "mechanism.kind"),
    "mechanism = 3": (lambda d: d.update(mechanism=3), "mechanism"),
}


@pytest.mark.parametrize("what", sorted(CASE_EDITS))
def test_cli_solve_refuses_the_issues_case_inputs_in_one_line(tmp_path, what):
    edit, key = CASE_EDITS[what]
    proc = run_cli("solve", str(_write_case(tmp_path, edit)), "-o", str(tmp_path / "out.csv"), cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"dualmech: error: {key}:"), proc.stderr
    assert not (tmp_path / "out.csv").exists()


def test_cli_solve_names_a_linkage_files_bad_kind_not_its_keys(tmp_path):
    """Issue 31: ``kind = 42`` in an RCCC file was reported as an unknown geometry key."""
    text = (ROOT / "models" / "linkages" / "cases" / "rccc.toml").read_text()
    path = tmp_path / "rccc.toml"
    path.write_text(text.replace('kind = "rccc"', "kind = 42"))
    proc = run_cli("solve", str(path), cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.strip().splitlines() == [
        "dualmech: error: mechanism.kind: expected a string, one of slider-crank, rssr, rccc, loop; got 42"]


def test_cli_solve_refuses_deeply_nested_toml(tmp_path):
    path = tmp_path / "deep.toml"
    path.write_text('name = "x"\nunits = ' + "{ a = " * 5000 + "1" + " }" * 5000 + "\n")
    proc = run_cli("solve", str(path), cwd=tmp_path)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert "nested 5000 deep" in proc.stderr


@pytest.mark.parametrize("option, value, words", [
    ("--torque", "1e400", ["inf"]),            # crashed inside the error handler
    ("--torque", "sqrt(-1)", ["not a real number"]),  # hung
    ("--torque", "9**9**9", ["exponent"]),     # hung
    ("--rtol", "nan", ["--rtol", "nan"]),       # hung
    ("--samples", "1" + "0" * 5000, ["--samples", "100,000"]),
    ("--duration", "abc", ["--duration", "'abc'"]),
])
def test_cli_simulate_refuses_the_issues_options_in_one_line(tmp_path, option, value, words):
    out = str(tmp_path / "o.csv")
    proc = run_cli("simulate", "ideal", "--duration", "0.01", option, value, "-o", out, cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("dualmech: error: "), proc.stderr
    for w in words:
        assert w in lines[0], (w, lines[0])


@pytest.mark.parametrize(("args", "words", "help_of"), [
    (("solve", "ideal", "--duration", "3"), ["No such option", "--duration"], "dualmech solve --help"),
    (("nope",), ["No such command", "nope"], "dualmech --help"),
    (("validate", "--jobs", "0"), ["--jobs", "0 is not in the range", "1<=x<=1024"],
     "dualmech validate --help"),
])
def test_a_usage_error_is_one_line_naming_the_help(tmp_path, args, words, help_of):
    """Issue 31's fuzz: click printed a usage error on four lines (usage, hint, blank, error).

    click's own wording differs between releases (8.2: ``No such option: --duration``; 8.3: ``No such
    option '--duration'.``), so the line is checked for its parts, not for click's punctuation.
    """
    proc = run_cli(*args, cwd=tmp_path)
    assert proc.returncode == 2
    lines = proc.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("dualmech: error: "), proc.stderr
    assert lines[0].endswith(f"({help_of})"), lines[0]
    for word in words:
        assert word in lines[0], (word, lines[0])
