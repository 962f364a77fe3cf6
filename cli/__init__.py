"""The ``dualmech`` command line (``dualmech.cli``): a thin shell over importable functions.

Every subcommand calls a library function of ``core``, ``models`` or ``validation`` and
prints its result; bad input (a :class:`ValueError` from the library) becomes one line on
stderr and exit code 2, never a traceback (:mod:`dualmech.cli.errors`).  This package is the
top layer: it may import every other one, none of them imports it.

The subcommands are registered here, in :data:`COMMANDS`, and nowhere else.
"""

from __future__ import annotations

import sys
from typing import Any

import click

from dualmech.cli.progress import show_kernel_compiles
from dualmech.cli.selftest import selftest
from dualmech.cli.simulate import simulate
from dualmech.cli.solve import benchmark, case_path, cases, mjcf, solve
from dualmech.cli.tolerance import tolerance
from dualmech.cli.validate import report, validate
from dualmech.validation.executors import end_all_pools
from dualmech.validation.exit_codes import EXIT_INTERRUPTED
from dualmech.validation.warning_lines import show_warnings_as_lines

#: Every subcommand of ``dualmech``, by module: one case (cases, case-path, solve, mjcf, benchmark),
#: forward dynamics, the tolerance study, the validation run and its report, the mutation selftest.
COMMANDS: tuple[click.Command, ...] = (
    cases, case_path, solve, mjcf, benchmark, simulate, tolerance, validate, report, selftest,
)


class OneLineUsage(click.Group):
    """The ``dualmech`` group: a usage error (unknown option, bad or missing value) is one line on stderr,
    ``dualmech: error: <what> (dualmech <command> --help)``, exit code 2, as every other refusal
    (:mod:`dualmech.cli.errors`); click would print the usage, a hint and the error on four lines."""

    def main(self, *args: Any, **kwargs: Any) -> Any:  # noqa: D102 (click's entry point)
        kwargs.update(standalone_mode=False, prog_name="dualmech")  # also as python -m dualmech.cli
        try:
            code = super().main(*args, **kwargs)
        except click.exceptions.UsageError as err:
            where = err.ctx.command_path if err.ctx is not None else "dualmech"
            message = " ".join(err.format_message().split())
            click.echo(f"dualmech: error: {message} ({where} --help)", err=True)
            sys.exit(err.exit_code)
        except click.exceptions.ClickException as err:
            click.echo(f"dualmech: error: {' '.join(err.format_message().split())}", err=True)
            sys.exit(err.exit_code)
        except click.exceptions.Abort:  # Ctrl-C while click itself reads (a command's own: cli.errors)
            click.echo("dualmech: interrupted", err=True)
            sys.exit(EXIT_INTERRUPTED)
        sys.exit(code if isinstance(code, int) else 0)  # --help, --version, ctx.exit(n): their code


@click.group(cls=OneLineUsage)
@click.version_option(package_name="dualmech")
@click.pass_context
def main(ctx: click.Context) -> None:
    """Dual-number solver for the generalized slider crank, judged by Pinocchio and MuJoCo."""
    show_warnings_as_lines()  # one line each, never Python's file:line and source
    ctx.call_on_close(end_all_pools)  # bounded: the interpreter's exit would join workers without a limit
    show_kernel_compiles()  # a cold numba cache: a notice and progress while the kernel compiles


for _command in COMMANDS:
    main.add_command(_command)
