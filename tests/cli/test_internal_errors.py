"""The last line of defence of the command line (issue 11): an internal error is one line, exit code 70,
with its traceback in a file; a bad input is one line, exit code 2; click's own handling is kept.
"""

from __future__ import annotations

from pathlib import Path

from click.testing import CliRunner


def _command(exc: BaseException):
    import click

    from dualmech.cli.errors import one_line_errors

    @click.command()
    @click.option("-o", "--output", "outdir", default=None)
    @one_line_errors
    def cmd(outdir):
        raise exc

    return cmd


def test_an_internal_error_is_one_line_exit_70_with_the_traceback_in_the_output_folder(tmp_path):
    res = CliRunner().invoke(_command(KeyError("no such thing\nsecond line")), ["-o", str(tmp_path)])
    assert res.exit_code == 70
    line = res.output.strip()
    assert "\n" not in line and line.startswith("dualmech: internal error: KeyError: 'no such thing")
    log = Path(line.rsplit("traceback in ", 1)[1])
    assert log.parent == tmp_path and "Traceback" in log.read_text() and "KeyError" in log.read_text()


def test_an_internal_error_without_an_output_folder_logs_to_a_temporary_file():
    res = CliRunner().invoke(_command(ZeroDivisionError("float division by zero")), [])
    assert res.exit_code == 70
    log = Path(res.output.strip().rsplit("traceback in ", 1)[1])
    try:
        assert log.is_file() and "ZeroDivisionError" in log.read_text()
    finally:
        log.unlink()


def test_a_bad_input_message_is_cut_to_its_first_line():
    big = ValueError("x: got array([" + ", ".join(["1.0"] * 2000) + "])\n  [more rows]\n")
    res = CliRunner().invoke(_command(big), [])
    assert res.exit_code == 2
    line = res.output.strip()
    assert "\n" not in line and line.startswith("dualmech: error: x: got array([1.0")
    assert line.endswith(" ...")
    assert len(line) < 400


def test_an_interrupt_is_one_line_exit_130_and_usage_errors_keep_their_handling():
    """Why: an interrupt was left to click ("Aborted!", exit 1: the code of a FAIL)."""
    import click

    res = CliRunner().invoke(_command(KeyboardInterrupt()), [])
    assert res.exit_code == 130 and res.output == "dualmech: interrupted\n"
    res = CliRunner().invoke(_command(click.UsageError("bad usage")), [])
    assert res.exit_code == 2 and "Usage:" in res.output



def test_a_failure_of_the_arithmetic_is_internal_not_bad_input(tmp_path):
    """numpy's LinAlgError subclasses ValueError; it is an engine failure (exit 70), never the user's input
    (2)."""
    import numpy as np

    res = CliRunner().invoke(_command(np.linalg.LinAlgError("SVD did not converge")), ["-o", str(tmp_path)])
    assert res.exit_code == 70
    assert res.output.startswith("dualmech: internal error: LinAlgError: SVD did not converge")


def test_every_exit_code_is_a_row_of_the_documented_table():
    """docs/validation.md, "Exit codes", lists every code a command exits with, and no other."""
    import re

    from dualmech.cli.errors import EXIT_INTERNAL
    from dualmech.validation.exit_codes import EXIT_CODES

    text = (Path(__file__).resolve().parents[2] / "docs/validation.md").read_text()
    table = text.split("## Exit codes", 1)[1].split("\n## ", 1)[0]
    assert {int(code) for code in re.findall(r"^\| (\d+) \|", table, re.M)} == {*EXIT_CODES, EXIT_INTERNAL}
