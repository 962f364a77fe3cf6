"""Case names and file names in the MJCF text (issue 31): none can close the header comment or inject
markup, and both read back exactly.

The property test parses every generated document with an XML parser (expat): its elements and
attributes must be those of the same case under a plain name (but the model's name), there must be one
comment, and the name and file name quoted in it must read back with ``ast.literal_eval``.
"""

from __future__ import annotations

import ast
import xml.parsers.expat

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from dualmech.models.case import load_case
from dualmech.models.mjcf import MjcfStart, case_to_mjcf, runnable_mjcf
from dualmech.models.mjcf_export import xml_text

#: Any finite state: only the text is examined.
START = MjcfStart(np.array([0.3, 1.0, 0.9, 0.1, 0.2, 0.3, 40.0]), np.arange(6.0), 5.0)
#: The attack of the issue: with ``--`` written ``- -``, three dashes still closed the comment.
INJECTION = '---><mujoco model="injected"/><!--'
#: Pieces of names that XML comments, attributes and Python literals treat specially.
PIECES = ["-", "--", "---", "-->", "<!--", ">", "<", "&", ";", "'", '"', "\\", "\\x2d", "]]>", "?", " ", "x",
          "\n", "\r", "\t", "\x00", "\x1f", "\x7f", "\ud800", "\ufffe", "\u2010", "é", "\U0001f600"]
NAMES = st.lists(st.sampled_from(PIECES), max_size=12).map("".join) | st.text(max_size=20)


def _parse(text: str) -> tuple[list[str], list[tuple[str, dict]]]:
    """The comments and the elements (tag, attributes), in document order, of the XML ``text``."""
    comments: list[str] = []
    elements: list[tuple[str, dict]] = []
    parser = xml.parsers.expat.ParserCreate()
    parser.CommentHandler = comments.append
    parser.StartElementHandler = lambda tag, attrs: elements.append((tag, attrs))
    parser.Parse(text, True)
    return comments, elements


def _quoted(comment: str, marker: str) -> str:
    """The Python literal after ``marker`` on its comment line, read back."""
    line = next(ln.strip() for ln in comment.splitlines() if marker in ln)
    return ast.literal_eval(line.split(marker, 1)[1])


BASE = load_case("thesis/ideal")
PLAIN = _parse(runnable_mjcf(BASE, START, 1e-4, "m.xml"))[1]


def test_three_dashes_do_not_close_the_comment():
    """Why: ``---><mujoco model="injected"/>`` closed the comment and MuJoCo loaded the injected model."""
    text = runnable_mjcf(BASE.with_parts(name=INJECTION), START, 1e-4, "m.xml")
    comments, elements = _parse(text)
    assert len(comments) == 1 and elements[0] == ("mujoco", {"model": f"dualmech {INJECTION}"})
    assert "--" not in comments[0]
    assert _quoted(comments[0], ", case ") == INJECTION


@given(name=NAMES, file_name=NAMES)
def test_any_name_changes_no_structure_and_reads_back(name, file_name):
    text = runnable_mjcf(BASE.with_parts(name=name), START, 1e-4, file_name)
    comments, elements = _parse(text)
    assert len(comments) == 1
    assert elements[0] == ("mujoco", {"model": f"dualmech {xml_text(name)}"})
    assert elements[1:] == PLAIN[1:]
    assert _quoted(comments[0], ", case ") == name
    line = next(ln.strip() for ln in comments[0].splitlines() if "from_xml_path(" in ln)
    assert ast.parse(line).body[0].value.args[0].value == file_name


@given(name=NAMES)
def test_the_judges_model_of_any_name_is_one_document(name):
    comments, elements = _parse(case_to_mjcf(BASE.with_parts(name=name)))
    assert len(comments) == 1 and elements[0] == ("mujoco", {"model": f"dualmech {xml_text(name)}"})
