"""A griffe extension for ``make docs``: ``#:`` comments document attributes.

The code documents its constants with ``#:`` comment lines just above the assignment
(Sphinx's convention), e.g. ``#: the methods of `denoise``` above ``DENOISE_METHODS``;
griffe reads only a string after it. This extension gives an attribute without a
docstring the text of those comment lines, so the API reference shows it
(mkdocs.yml ``extensions:``; docs/decisions/docs.md).
"""

from __future__ import annotations

from typing import Any

import griffe


def comment_above(lines: list[str], lineno: int) -> str:
    """The ``#:`` comment lines just above line ``lineno`` (1-based), joined."""
    found = []
    i = lineno - 2
    while i >= 0 and lines[i].lstrip().startswith("#:"):
        found.append(lines[i].lstrip()[2:].strip())
        i -= 1
    return "\n".join(reversed(found))


class CommentDocstrings(griffe.Extension):
    """Attributes without a docstring take the ``#:`` comment above them."""

    def on_attribute_instance(self, *, node: Any, attr: griffe.Attribute, **kwargs: Any):
        if attr.docstring is not None or attr.lineno is None or attr.filepath is None:
            return
        filepath = attr.filepath
        if filepath not in attr.lines_collection:
            return
        text = comment_above(attr.lines_collection[filepath], attr.lineno)
        if text:
            attr.docstring = griffe.Docstring(text, lineno=attr.lineno, parent=attr)
