"""Issue 31: no warning reaches the user in Python's raw form (``file:line: RuntimeWarning`` and the source).

A design that assembles at some angles only gives NaN rows; the report's balancing section added them
and numpy's "invalid value encountered in add" reached stderr with its source lines.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from dualmech.validation.warning_lines import warning_line
from tests.hostile_inputs import run_cli

ROOT = Path(__file__).resolve().parents[2]


def test_a_numerical_warning_is_one_line_naming_the_file_as_a_defect():
    line = warning_line(RuntimeWarning("invalid value\nencountered in add"), RuntimeWarning,
                        str(ROOT / "models" / "slider_crank" / "balancing.py"))
    assert line == ("dualmech: warning: invalid value encountered in add "
                    "(numerical, in models/slider_crank/balancing.py; a defect, please report it)")
    assert warning_line(UserWarning("rod mass 1e8 kg"), UserWarning, "/x/y.py") == \
        "dualmech: warning: rod mass 1e8 kg"


def test_an_installed_process_prints_each_warning_once_on_one_line():
    code = ("import numpy as np; from dualmech.validation.warning_lines import show_warnings_as_lines; "
            "show_warnings_as_lines(); [np.log(np.array([-1.0])) for _ in range(3)]")
    proc = subprocess.run([sys.executable, "-W", "always", "-c", code], capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, lines
    assert lines[0].startswith("dualmech: warning: invalid value encountered in log"), lines


def test_validate_of_a_design_that_assembles_in_part_prints_no_raw_warning(tmp_path):
    text = (ROOT / "models" / "cases" / "thesis" / "ideal.toml").read_text()
    case = tmp_path / "short-rod.toml"
    case.write_text(text.replace("rod_length = 50.0", "rod_length = 1.0"))  # assembles near 90, 270 deg only
    proc = run_cli("validate", str(case), "--engines", "dualmech,pinocchio", "-o", str(tmp_path / "run"),
                   cwd=tmp_path)
    assert proc.returncode in (0, 1, 3), proc.stderr
    assert "Warning" not in proc.stderr and "warning:" not in proc.stderr, proc.stderr
    assert (tmp_path / "run" / "report.html").is_file()  # the balancing section that warned was drawn
