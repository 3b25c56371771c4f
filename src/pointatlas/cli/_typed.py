"""The command line as the user typed it, for messages that quote an argument.

Typer turns a path argument into a ``pathlib.Path``, which drops a trailing
separator (``out.ply/`` arrives as ``out.ply``). The application's group records
the raw arguments of the command being run, so the output checks see what was
typed.
"""

from __future__ import annotations

import os
from pathlib import Path

from typer.core import TyperGroup

__all__ = ["TypedArgsGroup", "typed_spellings"]

#: The raw arguments of the command line being run (one command per process, or
#: one at a time under a test runner: each run replaces them).
_typed_args: tuple[str, ...] = ()


class TypedArgsGroup(TyperGroup):
    """The typer group of ``pointatlas``: records the raw arguments before parsing."""

    def parse_args(self, ctx, args: list[str]) -> list[str]:
        global _typed_args
        if ctx.parent is None:
            _typed_args = tuple(args)
        return super().parse_args(ctx, args)


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
