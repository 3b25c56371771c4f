"""The consoles of the jobs and commands: verbatim lines, tables, progress bars."""

from __future__ import annotations

import contextlib
import sys

from rich.console import Console
from rich.markup import escape
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    SpinnerColumn,
    TextColumn,
    TimeElapsedColumn,
)

__all__ = ["PIPE_WIDTH", "console", "counted", "err_console", "progress_bar", "say", "warn"]

# soft_wrap: a printed line is never broken at the terminal width (paths stay whole
# when the output is piped or the terminal is narrow); tables still fit the width.
#: Width of tables when the output is not a terminal (a pipe, a file, a test runner):
#: wide enough that no table of ours wraps, whatever COLUMNS says.
PIPE_WIDTH = 160


def _console(stderr: bool = False) -> Console:
    stream = sys.stderr if stderr else sys.stdout
    is_tty = hasattr(stream, "isatty") and stream.isatty()
    return Console(stderr=stderr, soft_wrap=True, width=None if is_tty else PIPE_WIDTH)


console = _console()
err_console = _console(stderr=True)


def say(*parts, out: Console | None = None) -> None:
    """Print text verbatim on one line: no markup, no highlighting, no wrapping.

    For lines a script may read (``wrote PATH``): brackets in paths stay as they
    are and long paths are not broken.
    """
    (out or console).print(*parts, markup=False, highlight=False, soft_wrap=True, emoji=False)


def counted(n: int, one: str, many: str) -> str:
    """``n`` (thousands separated) and the words for one of a thing or for many.

    >>> counted(1, "normal", "normals"), counted(1200, "point lies", "points lie")
    ('1 normal', '1,200 points lie')
    """
    return f"{n:,} {one if n == 1 else many}"


def warn(text: str) -> None:
    """One yellow line ``warning: <text>`` on stderr (the text escaped: brackets in
    paths and ranges stay as they are)."""
    err_console.print(f"[bold yellow]warning:[/] {escape(text)}", highlight=False, soft_wrap=True)


@contextlib.contextmanager
def progress_bar(description: str, total: int | None = None, *, transient: bool = True):
    """A rich progress bar on stderr; yields ``advance(n=1)``.

    Hidden automatically when stderr is not a terminal and the task is short.
    """
    with Progress(
        SpinnerColumn(),
        TextColumn("[bold]{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        console=err_console,
        transient=transient,
        disable=not sys.stderr.isatty(),
    ) as progress:
        task = progress.add_task(description, total=total)

        def advance(n: int = 1):
            progress.advance(task, n)

        yield advance
