"""The exit codes of a validation run: ``dualmech validate``, ``dualmech report`` and the selftest's gate.

:data:`EXIT_BAD_INPUT`, :data:`EXIT_WORKERS_LOST` and :data:`EXIT_INTERRUPTED` are every command's
(:mod:`dualmech.cli.errors`): a lost worker and an interrupt end ``solve``, ``tolerance``, ``report`` ...
as they end ``validate``.  A dead worker is 4, not 130: 130 is 128 + SIGINT, what shells and CI read as
"the user pressed Ctrl-C"; a worker killed by the OOM killer or a signal is a fault of the machine,
as a lost Dask cluster is, and its remedy is the same (finished results are kept; resume).

One home for them: the command line (:mod:`dualmech.cli`) exits with them, and the selftest's
gate returns the code ``validate`` would (:func:`dualmech.validation.selftest.gate.gate_main`).
The "Exit codes" table of ``docs/validation.md`` lists :data:`EXIT_CODES`.
"""

from __future__ import annotations

#: Exit codes of ``validate`` and ``report`` (also in docs/validation.md, "Exit codes").
EXIT_PASS, EXIT_FAIL, EXIT_BAD_INPUT, EXIT_INCOMPLETE = 0, 1, 2, 3
EXIT_WORKERS_LOST, EXIT_INTERRUPTED = 4, 130
EXIT_CODES: dict[int, str] = {
    EXIT_PASS: "PASS: every check of a complete run passed, no regression",
    EXIT_FAIL: "FAIL: a check failed, an engine failed, or (with --baseline) something regressed",
    EXIT_BAD_INPUT: "bad input, or an output folder that is not dualmech's or is in use (one line on stderr)",
    EXIT_INCOMPLETE: "INCOMPLETE: no check failed, but work is missing (cases or engines not run)",
    EXIT_WORKERS_LOST: "a worker process died (a signal, the OOM killer), or the Dask scheduler or all its "
                       "workers were lost (one line; finished cases are kept; re-run with --resume)",
    EXIT_INTERRUPTED: "interrupted, Ctrl-C (one line; finished cases are kept; re-run with --resume)",
}


def exit_code(verdict: str, regressions: list) -> int:
    """The exit code of a compared run: FAIL (or any regression) 1, INCOMPLETE 3, PASS 0."""
    if verdict == "FAIL" or regressions:
        return EXIT_FAIL
    return EXIT_INCOMPLETE if verdict == "INCOMPLETE" else EXIT_PASS
