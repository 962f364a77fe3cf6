"""The ``dualmech`` command line (``dualmech.cli``): a thin shell over importable functions.

Every subcommand calls a library function of ``core``, ``models`` or ``validation`` and
prints its result; bad input (a :class:`ValueError` from the library) becomes one line on
stderr and exit code 2, never a traceback (:mod:`dualmech.cli.errors`).  This package is the
top layer: it may import every other one, none of them imports it.

The subcommands are registered here, in :data:`COMMANDS`, and nowhere else.
"""

from __future__ import annotations

import importlib.util
import sys
from typing import Any

import click

from dualmech.cli.errors import when_closing
from dualmech.cli.progress import show_kernel_compiles
from dualmech.cli.selftest import selftest
from dualmech.cli.simulate import simulate
from dualmech.cli.solve import benchmark, case_path, cases, mjcf, solve
from dualmech.cli.tolerance import tolerance
from dualmech.cli.validate import report, validate
from dualmech.validation.exit_codes import EXIT_INTERRUPTED
from dualmech.validation.run.executors import end_all_pools
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
    """Dual-number solver for single spatial loops (the generalized slider crank, the RSSR, the RCCC, any
    table of R, P, C, S, U joints), judged by Pinocchio, MuJoCo and Exudyn."""
    show_warnings_as_lines()  # one line each, never Python's file:line and source
    # bounded (the interpreter's exit would join workers without a limit); Ctrl-C while it waits: 130
    ctx.call_on_close(when_closing(end_all_pools))
    spawn_without_the_command_line()
    show_kernel_compiles()  # a cold numba cache: a notice and progress while the kernel compiles


for _command in COMMANDS:
    main.add_command(_command)


def spawn_without_the_command_line() -> None:
    """Keep spawned pool workers from importing the command line (0.7 s each, before their first line).

    A spawned worker first imports the program's main module (multiprocessing's ``spawn``), here the
    ``dualmech`` console script, which imports this package (click, the commands, numpy, the models),
    all unused by a worker.  For that time a worker whose parent had been killed did not know it yet:
    measured, 1.3-2.6 s before the last worker was gone after SIGKILL to ``validate`` while its pool
    started (0.2 s without).  Where the main module is that script (it holds :func:`main`), it is
    declared the module ``dualmech.cli.__main__`` (what ``python -m dualmech.cli`` runs), which spawn
    does not import again.  Any other main module (a user's program, pytest) is left as it is.
    """
    program = sys.modules.get("__main__")
    if getattr(program, "main", None) is main and getattr(program, "__spec__", None) is None:
        program.__spec__ = importlib.util.find_spec("dualmech.cli.__main__")
