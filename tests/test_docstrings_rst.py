"""Module docstrings are valid reStructuredText.

``make docs`` renders them with Sphinx (warnings are errors); this is the quick check that runs
in ``make test``, so a malformed docstring (an indented line without a blank line before it, a
title underline shorter than its title) fails here and not only in the documentation build.
Sphinx's cross-reference roles (``:func:`` …) are registered as plain literals.
"""

from __future__ import annotations

import ast
import io
from pathlib import Path

import pytest

docutils_core = pytest.importorskip("docutils.core")
from docutils import nodes  # noqa: E402
from docutils.parsers.rst import roles  # noqa: E402

PACKAGE = Path(__file__).resolve().parent.parent / "tmaplan"
for _role in ("func", "mod", "class", "data", "attr", "meth", "obj", "exc", "doc", "ref", "math"):
    roles.register_generic_role(_role, nodes.literal)


def rst_messages(text: str) -> str:
    """docutils warnings and errors for ``text`` ('' when it is valid)."""
    stream = io.StringIO()
    docutils_core.publish_doctree(
        text, settings_overrides={"report_level": 2, "halt_level": 5, "warning_stream": stream})
    return stream.getvalue()


def test_checker_catches_the_two_faults_seen_in_ci():
    assert "Unexpected indentation" in rst_messages("Line one\nline two\n  indented\nback")
    assert "underline too short" in rst_messages("Text.\n\nA title\n-----\n\nBody.")
    assert rst_messages("Fine ``code`` and :func:`x`.\n\nTitle\n-----\n\nBody.") == ""


@pytest.mark.parametrize("path", sorted(PACKAGE.rglob("*.py")), ids=lambda p: p.name)
def test_module_docstring_is_valid_rst(path):
    doc = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8")))
    if doc:
        assert rst_messages(doc) == "", f"{path.relative_to(PACKAGE.parent)}"
