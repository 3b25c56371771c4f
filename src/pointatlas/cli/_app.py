"""The typer application, shared error handling and progress helpers.

Every command module (``_cmd_<room>.py``) imports ``app`` (or a sub-app) from here
and registers its commands; ``cli/__init__.py`` imports the command modules.
"""

from __future__ import annotations

import contextlib
import functools
import sys
from collections.abc import Callable

import typer
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

from .._core import PointAtlasError

__all__ = [
    "DEMO_STEPS",
    "app",
    "console",
    "data_app",
    "demo_step",
    "err_console",
    "experiment_app",
    "guarded",
    "progress_bar",
    "read_input",
]

app = typer.Typer(
    name="pointatlas",
    help="Point-set geometry processing: segmentation, simplification, features, denoising.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
data_app = typer.Typer(help="Bundled models: list and export.", no_args_is_help=True)
experiment_app = typer.Typer(help="Reproduce the thesis' experiments.", no_args_is_help=True)
app.add_typer(data_app, name="data")
app.add_typer(experiment_app, name="experiment")

console = Console()
err_console = Console(stderr=True)


def _one_line(exc: BaseException) -> str:
    """First line of an exception's message (its type name when empty)."""
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


def _fail(message: str, code: int):
    # escape: messages often hold "[...]" (ranges, "[Errno 2]") that rich would
    # otherwise read as markup and drop
    err_console.print(f"[bold red]error:[/] {escape(message)}", highlight=False, soft_wrap=True)
    raise typer.Exit(code=code)


def guarded(func):
    """Turn user errors into one red line on stderr and exit status 1.

    ``PointAtlasError``, ``ValueError``, ``TypeError`` and ``OSError`` (missing file,
    permission) are user errors: no traceback. ``MemoryError`` also exits 1 with one
    line, Ctrl-C exits 130 ("interrupted"). Usage errors stay with typer (exit 2).
    """

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        try:
            return func(*args, **kwargs)
        except (PointAtlasError, ValueError, TypeError, OSError) as exc:
            _fail(_one_line(exc), 1)
        except MemoryError:
            _fail("out of memory (try a smaller input or fewer neighbours)", 1)
        except KeyboardInterrupt:
            _fail("interrupted", 130)

    return wrapper


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


#: The steps of ``pointatlas demo``, run in order on the demo model. A step is
#: ``step(ps, out_dir, console) -> PointSet | None``: ``ps`` the model's PointSet
#: (points + area-weighted mesh normals; earlier steps may have added attributes),
#: ``out_dir`` a ``pathlib.Path`` that exists, ``console`` the rich console to
#: print to. Returning a PointSet hands it to the following steps (e.g. with an
#: extra attribute); returning None keeps the current one. The first docstring
#: line is printed as the step's heading. Command modules append their step at
#: import time with :func:`demo_step`; modules are imported in sorted order, after
#: the core steps (info, normals, picture).
DEMO_STEPS: list[Callable] = []


def demo_step(func: Callable) -> Callable:
    """Decorator: append ``func`` to :data:`DEMO_STEPS` and return it unchanged."""
    DEMO_STEPS.append(func)
    return func


def read_input(path, *, with_normals: bool = True, zero_normals: str = "raise"):
    """Read IN: a point set or mesh file, or, where no such file exists, a bundled
    model name (``pointatlas data list``: ``fandisk``, ``synth:cube``, ...)."""
    from pathlib import Path

    from ..io import read_point_set

    p = Path(path)
    if not p.exists():
        from .. import data

        if str(path) in data.names():
            ps = data.load(str(path))
            return ps if with_normals else ps.replace(normals=None)
        if not p.suffix:
            raise PointAtlasError(
                f"{path}: no such file and not a bundled model; bundled: {', '.join(data.names())}"
            )
    return read_point_set(p, with_normals=with_normals, zero_normals=zero_normals)
