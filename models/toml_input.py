"""Reading a TOML input file (case or matrix) with bounded size and nesting.

``tomllib`` parses whatever it is given: a deeply nested inline table or array
overflows the interpreter's stack (``RecursionError`` at ~500 levels), and one
dotted key of many parts (``a.a.a. ... = 1``) costs memory quadratic in its
length (20,000 parts: 1.5 GB).  :func:`read_toml` therefore bounds the file's
size and, before parsing, the bracket depth and the parts of every key on a
skeleton of the text (strings and comments blanked, float literals removed);
after parsing it bounds the depth of the resulting tables and arrays.  The
limits are far above anything the case and matrix formats use (their deepest
key is ``sweep[i].cases[j].geometry.slider_offset``: 6 levels).
"""

from __future__ import annotations

import re
import sys
import tomllib
from pathlib import Path
from typing import Any

#: Largest input file, bytes (the bundled cases and matrices are 1-3 kB).
MAX_TOML_BYTES = 1 << 20
#: Deepest nesting of tables and arrays, and most parts of one dotted key.
MAX_TOML_DEPTH = 16
#: Most digits in one integer literal: Python refuses to convert more (``sys.get_int_max_str_digits``), with
#: a message that names no key; a longer one is refused here, by its key.
MAX_NUMBER_DIGITS = sys.get_int_max_str_digits() or 4300

#: Strings (multi-line first, with up to two quotes before the closing delimiter) and comments.
_STRINGS_AND_COMMENTS = re.compile(
    r'"""(?:[^"\\]|\\.|"(?!""))*"""(?:"{1,2}(?!"))?'
    r"|'''(?:[^']|'(?!''))*'''(?:'{1,2}(?!'))?"
    r'|"(?:[^"\\\n]|\\.)*"'
    r"|'[^'\n]*'"
    r"|#[^\n]*",
    re.DOTALL,
)
#: A float literal with a decimal point (its dot is not a key separator).
_FLOAT = re.compile(r"(?<![\w.+-])[+-]?\d[\d_]*\.\d[\d_]*(?:[eE][+-]?\d[\d_]*)?(?![\w.])")
#: A run of digits (with TOML's ``_`` separators) longer than :data:`MAX_NUMBER_DIGITS`.
_LONG_NUMBER = re.compile(r"\d(?:_?\d){%d,}" % MAX_NUMBER_DIGITS)
#: A (possibly dotted) bare key; quoted parts were blanked to ``s``.
_KEY_CHAIN = re.compile(r"[\w-]+(?:[ \t]*\.[ \t]*[\w-]+)*")


def _blanked(text: str) -> str:
    """The text with every string replaced by ``s`` and every comment by nothing (lines kept)."""
    return _STRINGS_AND_COMMENTS.sub(lambda m: "" if m.group().startswith("#") else "s", text)


def _key_at(blanked: str, offset: int) -> str:
    """The dotted key of the value at ``offset`` of the blanked text: the last ``[table]`` header before it,
    the line's key and, inside an inline table, the last key before the value (``motion.angles_deg.step``)."""
    before = blanked[:offset]
    headers = re.findall(r"^[ \t]*\[\[?[ \t]*([\w.-]+)", before, re.MULTILINE)
    keys = re.findall(r"([\w.-]+)[ \t]*=", before.rsplit("\n", 1)[-1])
    inner = keys[-1:] if len(keys) > 1 else []
    parts = headers[-1:] + keys[:1] + inner
    return ".".join(parts) if keys else "a value"


def _check_text(text: str, where: str, error: type[ValueError]) -> None:
    """Number literals within :data:`MAX_NUMBER_DIGITS`, bracket depth and key parts within
    :data:`MAX_TOML_DEPTH`, before ``tomllib`` sees ``text``."""
    blanked = _blanked(text)
    long = _LONG_NUMBER.search(blanked)
    if long:
        digits = sum(c.isdigit() for c in long.group())
        raise error(f"{_key_at(blanked, long.start())}: a number of {digits:,} digits; at most "
                    f"{MAX_NUMBER_DIGITS:,} (line {blanked.count(chr(10), 0, long.start()) + 1} of {where})")
    skeleton = _FLOAT.sub("0", blanked)  # a float's dot is no key separator
    depth = deepest = 0
    for char in re.sub(r"[^\[\]{}]", "", skeleton):
        depth += 1 if char in "[{" else -1
        deepest = max(deepest, depth)
    if deepest > MAX_TOML_DEPTH:
        raise error(f"{where}: arrays or inline tables nested {deepest} deep; at most {MAX_TOML_DEPTH}")
    parts = max((m.group().count(".") + 1 for m in _KEY_CHAIN.finditer(skeleton)), default=0)
    if parts > MAX_TOML_DEPTH:
        raise error(f"{where}: a dotted key of {parts} parts; at most {MAX_TOML_DEPTH}")


def _depth(data: Any) -> int:
    """Nesting depth of tables and arrays (iterative: no recursion limit to hit)."""
    deepest, stack = 0, [(data, 0)]
    while stack:
        node, level = stack.pop()
        if isinstance(node, dict):
            node = list(node.values())
        if isinstance(node, list):
            deepest = max(deepest, level + 1)
            stack.extend((v, level + 1) for v in node if isinstance(v, (dict, list)))
    return deepest


def read_toml(path: Path, error: type[ValueError]) -> dict:
    """Parse the TOML file ``path`` within the module's bounds; any problem is one ``error`` line.

    Parameters
    ----------
    path : pathlib.Path
        A regular file.
    error : type
        The ``ValueError`` subclass to raise (``CaseError``, ``MatrixError``), with a
        message naming the file and what is wrong.
    """
    try:
        with Path(path).open("rb") as fh:
            raw = fh.read(MAX_TOML_BYTES + 1)
    except OSError as err:
        raise error(f"{path}: cannot read ({err.strerror or type(err).__name__})") from None
    if len(raw) > MAX_TOML_BYTES:
        raise error(f"{path}: larger than {MAX_TOML_BYTES:,} bytes, the most an input file may have")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as err:
        raise error(f"{path}: not UTF-8 text (byte {err.start}); TOML files are UTF-8") from None
    _check_text(text, str(path), error)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise error(f"{path}: not valid TOML ({str(err).splitlines()[0]})") from None
    except RecursionError:  # unreachable after _check_text; kept so no traceback can escape
        raise error(f"{path}: nested too deeply; at most {MAX_TOML_DEPTH} levels") from None
    if _depth(data) > MAX_TOML_DEPTH:
        raise error(f"{path}: tables and arrays nested {_depth(data)} deep; at most {MAX_TOML_DEPTH}")
    return data
