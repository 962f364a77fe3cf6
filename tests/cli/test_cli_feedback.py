"""What a user sees while a command works and when it is done: progress, masses and loads with units, and a
warning for a design whose sizes do not fit its units.

Through click's runner, whose stderr is not a terminal: progress is then plain lines
(``tests/cli/test_progress.py`` holds both modes of the display itself).  ``simulate`` needs no
compiled kernel, so these stay quick.
"""

from __future__ import annotations

import re

from click.testing import CliRunner

from dualmech.cli import main
from tests.models.test_plausibility import MM_CASE


def _run(*args: object):
    return CliRunner().invoke(main, [str(a) for a in args])


def test_simulate_shows_plain_progress_masses_and_peak_loads(tmp_path) -> None:
    result = _run("simulate", "thesis/ideal", "--duration", 0.5, "--samples", 51, "-o", tmp_path / "s.csv")
    assert result.exit_code == 0, result.output + result.stderr
    lines = result.stderr.splitlines()
    progress = [line for line in lines if line.startswith("simulate thesis/ideal:")]
    first = r"simulate thesis/ideal: [\d.e-]+ of 0\.5 s \(\d+ %\), \d+:\d\d elapsed.*"
    assert re.fullmatch(first, progress[0])
    assert re.fullmatch(r"simulate thesis/ideal: done, 0\.5 of 0\.5 s in \d+:\d\d", progress[-1])
    assert 2 <= len(progress) <= 2 + 9  # the first update, at most one line per tenth, done
    assert not re.search("\x1b|\r|…", result.stderr)
    summary = result.stdout.splitlines()  # with -o the summary goes to stdout
    masses = "body masses: crank 0.0614659 lbf·s²/in, rod 0.113826 lbf·s²/in, slider 0.0195652 lbf·s²/in"
    assert masses in summary
    assert any(re.fullmatch(r"peak joint 1 \(crank bearing\) \|force\|: [\d.e+]+ lbf at [\d.]+ deg", line)
               for line in summary)
    assert any(re.fullmatch(r"slider S4: [\d.]+ \.\. [\d.]+ in", line) for line in summary)


def test_mm_under_si_warns_in_one_line_and_still_exits_0(tmp_path) -> None:
    path = tmp_path / "mm.toml"
    path.write_text(MM_CASE.format(units="m-kg-s", density=7850.0))
    result = _run("simulate", path, "--duration", 0.01, "--samples", 3, "-o", tmp_path / "s.csv")
    assert result.exit_code == 0, result.output + result.stderr
    warnings = [line for line in result.stderr.splitlines() if line.startswith("dualmech: warning: ")]
    assert warnings[0] == ("dualmech: warning: link a2 = 300 m is longer than 100 m, implausible for units = "
                           "'m-kg-s': lengths look like mm; in m-kg-s lengths are in metres")
    assert len(warnings) == 4  # the rod, then the three masses that follow from the lengths
    assert "body masses: crank 1.97292e+08 kg, rod 4.73501e+08 kg, slider 2.1195e+08 kg" in result.stdout


def test_a_preset_does_not_warn(tmp_path) -> None:
    result = _run("simulate", "iftomm/spatial-slider-crank", "--duration", 0.01, "--samples", 3,
                  "-o", tmp_path / "s.csv")
    assert result.exit_code == 0, result.output + result.stderr
    assert "warning" not in result.stderr


def test_validate_of_one_case_names_masses_and_peaks(tmp_path, monkeypatch) -> None:
    """A design of one's own (one case file): the summary adds its masses and the reference's peak loads."""
    from dualmech.models.case import preset_path
    from dualmech.validation import engines

    fakes = "tests.matrix_fakes"
    monkeypatch.setitem(engines.ENGINES, "dualmech", {"slider-crank": f"{fakes}:solve_case"})
    monkeypatch.setitem(engines.ENGINES, "pinocchio", {"slider-crank": f"{fakes}:solve_case_judge"})
    result = _run("validate", preset_path("iftomm/spatial-slider-crank"), "-o", tmp_path / "run", "--jobs", 1,
                  "--engines", "dualmech,pinocchio")
    assert result.exit_code in (0, 1), result.output + result.stderr
    lines = result.stdout.splitlines()
    assert "body masses: crank 0.12 kg, rod 0.5 kg, slider 2 kg" in lines
    # the fakes' reactions are zero: a peak then reads "0 N (exactly 0)" (models/design_summary.py)
    peak = r"peak joint 2 \(crank pin ball\) \|force\|: \S+ N (at \S+ deg|\(exactly 0\))"
    assert any(re.fullmatch(peak, line) for line in lines)
    assert "warning" not in result.stderr
    progress = result.stderr.splitlines()  # plain lines, not rich's bars
    done = r".*: 1 cases x 2 engines: done, 2 of 2 results in \d+:\d\d"
    assert any(re.fullmatch(done, line) for line in progress)
    assert not re.search("\x1b|\r|…", result.stderr)
