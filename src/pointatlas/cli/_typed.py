"""The command line as the user typed it, for messages that quote an argument; the
commands' help as the terminal's width wraps it.

Typer turns a path argument into a ``pathlib.Path``, which drops a trailing
separator (``out.ply/`` arrives as ``out.ply``). The application's group records
the raw arguments of the command being run, so the output checks see what was
typed.

Typer's rich help keeps a docstring's line breaks inside a paragraph, so a terminal
narrower than the docstring's lines broke each of them again (a line of a few words
after every long one); the groups give each command's help one line per paragraph
(`reflowed`), which rich then wraps to the terminal.
"""

from __future__ import annotations

import inspect
import os
import re
from pathlib import Path

from typer.core import TyperGroup

__all__ = ["TypedArgsGroup", "reflowed", "typed_spellings"]

#: The raw arguments of the command line being run (one command per process, or
#: one at a time under a test runner: each run replaces them).
_typed_args: tuple[str, ...] = ()


class TypedArgsGroup(TyperGroup):
    """The typer group of ``pointatlas`` and its sub-commands' groups: records the raw
    arguments before parsing (the top group), and gives each command its help
    `reflowed`."""

    def parse_args(self, ctx, args: list[str]) -> list[str]:
        global _typed_args
        if ctx.parent is None:
            _typed_args = tuple(args)
        return super().parse_args(ctx, args)

    def get_command(self, ctx, cmd_name: str):
        command = super().get_command(ctx, cmd_name)
        if command is not None and command.help:
            command.help = reflowed(command.help)
        return command


def reflowed(text: str) -> str:
    """``text`` (a docstring) with each paragraph on one line, for a help that the
    terminal wraps: ``code`` marks (rich shows them as typed) dropped, or made quotes
    around code of several words; the part after a form feed (click's end of help)
    left out.

    Examples
    --------
    >>> print(reflowed("Sum.\\n\\n    Adds ``a``\\n    to ``b + 1``.\\n"))
    Sum.
    <BLANKLINE>
    Adds a to 'b + 1'.
    """
    paragraphs = inspect.cleandoc(text.partition("\f")[0]).split("\n\n")
    return "\n\n".join(
        " ".join(re.sub("``(.+?)``", _code, p, flags=re.S).split()) for p in paragraphs
    )


def _code(match) -> str:
    """A ``code`` span of a help text, as `reflowed` shows it."""
    text = " ".join(match[1].split())
    return f"'{text}'" if " " in text else text


def typed_spellings(path) -> list[str]:
    """The arguments typed on the command line that name ``path``, as typed.

    ``--flag=value`` counts as ``value``. Empty when no command line names it (a
    library call).
    """
    target = Path(os.fspath(path))
    found = []
    for arg in _typed_args:
        value = arg.split("=", 1)[1] if arg.startswith("--") and "=" in arg else arg
        if value and Path(value) == target:
            found.append(value)
    return found
