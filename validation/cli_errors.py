"""The command line's one rule for bad input: one line on stderr and exit code 2, never a traceback."""

from __future__ import annotations

import functools
import sys
from typing import Callable

import click


def one_line_errors(func: Callable) -> Callable:
    """Turn ``ValueError``/``OSError`` raised by the library into one line and exit code 2."""

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        try:
            return func(*args, **kwargs)
        except (ValueError, OSError) as err:
            click.echo(f"dualmech: error: {err}", err=True)
            sys.exit(2)

    return wrapper
