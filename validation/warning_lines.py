"""Warnings as one plain line each: what the command line and its workers show instead of Python's format.

Python prints a warning as ``<file>:<line>: <Category>: <message>`` followed by the source line, an
internal the user cannot act on.  The library silences the floating-point warnings it expects (rows
without an answer carry NaN: ``np.errstate`` where they are computed); one that still reaches the
command line is a defect, shown as one line naming it, once per distinct message::

    dualmech: warning: invalid value encountered in add (numerical, in models/slider_crank/balancing.py; a
    defect)

Other warnings (a library's deprecation, dualmech's own ``UserWarning`` such as an implausible
mass) keep their message, on one line without the source.
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path
from typing import TextIO

#: Where dualmech's packages live (a warning raised in them names its file relative to this).
_ROOT = Path(__file__).resolve().parents[1]


def warning_line(message: Warning | str, category: type[Warning], filename: str) -> str:
    """The one line shown for a warning: numpy's floating-point warnings named as a defect, with the file
    (relative to the dualmech source, else its name); others by their message."""
    text = " ".join(str(message).split())
    if issubclass(category, RuntimeWarning):
        path = Path(filename)
        where = path.relative_to(_ROOT).as_posix() if path.is_relative_to(_ROOT) else path.name
        return f"dualmech: warning: {text} (numerical, in {where}; a defect, please report it)"
    return f"dualmech: warning: {text}"


def show_warnings_as_lines() -> None:
    """Make this process print every warning as :func:`warning_line` (once per distinct line)."""
    shown: set[str] = set()

    def show(message: Warning | str, category: type[Warning], filename: str, lineno: int,
             file: TextIO | None = None, line: str | None = None) -> None:
        text = warning_line(message, category, filename)
        if text not in shown:
            shown.add(text)
            print(text, file=file if file is not None else sys.stderr, flush=True)

    warnings.showwarning = show
