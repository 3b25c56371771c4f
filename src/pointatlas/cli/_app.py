"""The typer application, shared error handling and progress helpers.

Every command module (``_cmd_<room>.py``) imports ``app`` (or a sub-app) from here
and registers its commands; ``cli/__init__.py`` imports the command modules.
"""

from __future__ import annotations

import contextlib
import functools
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Annotated

import typer
from rich.markup import escape

from .._core import PointAtlasError, interrupt_requested
from ._flag_checks import angle_deg_option, parse_seeds, vsa_options
from ._signals import stop_signals_handled, stopped_line
from ._typed import TypedArgsGroup
from .jobs import (
    console,
    err_console,
    fill_unusable_normals,
    progress_bar,
    read_input,
    read_with_normals,
    run_tiled,
    say,
    tile_options,
    warn,
)

__all__ = [
    "DEMO_STEPS",
    "EstimateNormalsOption",
    "NormalKOption",
    "HaloOption",
    "MaxMemoryOption",
    "SchedulerOption",
    "TileSizeOption",
    "WorkersOption",
    "run_tiled",
    "tile_options",
    "app",
    "console",
    "data_app",
    "demo_step",
    "err_console",
    "experiment_app",
    "guarded",
    "progress_bar",
    "parse_seeds",
    "read_input",
    "read_with_normals",
    "say",
    "deprecated_option",
    "fill_unusable_normals",
    "renamed_flag",
    "angle_deg_option",
    "ClassicOption",
    "EtaOption",
    "LocalOption",
    "MaxAngleDegOption",
    "MaxIterOption",
    "MergeOption",
    "SeedsOption",
    "SplitOption",
    "SwitchOption",
    "VSAKOption",
    "VSASeedOption",
    "WeightsOption",
    "vsa_options",
]

app = typer.Typer(
    cls=TypedArgsGroup,
    name="pointatlas",
    help="Point-set geometry processing: segmentation, simplification, features, denoising.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
data_app = typer.Typer(
    cls=TypedArgsGroup, help="Bundled models: list and export.", no_args_is_help=True
)
experiment_app = typer.Typer(
    cls=TypedArgsGroup, help="Reproduce the thesis' experiments.", no_args_is_help=True
)
app.add_typer(data_app, name="data")
app.add_typer(experiment_app, name="experiment")


def _one_line(exc: BaseException) -> str:
    """First line of an exception's message (its type name when empty)."""
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


def _fail(message: str, code: int):
    # escape: messages often hold "[...]" (ranges, "[Errno 2]") that rich would
    # otherwise read as markup and drop
    err_console.print(f"[bold red]error:[/] {escape(message)}", highlight=False, soft_wrap=True)
    raise typer.Exit(code=code)


def _stopped():
    """The one line and exit status of a command a signal stopped."""
    _fail(*stopped_line())


@contextlib.contextmanager
def warnings_as_lines():
    """While a command runs, every warning is one yellow line on stderr, once per
    message: Python's own format adds the source line of the call, and a file read
    twice (``info`` reads it as a mesh and as points) warned twice."""
    seen: set[str] = set()

    def show(message, category, filename, lineno, file=None, line=None):
        text = str(message)
        if text not in seen:
            seen.add(text)
            warn(text)

    with warnings.catch_warnings():
        warnings.showwarning = show
        yield


def guarded(func):
    """Turn user errors into one red line on stderr and exit status 1, warnings into
    one yellow line each (`warnings_as_lines`).

    ``PointAtlasError``, ``ValueError``, ``TypeError`` and ``OSError`` (missing file,
    permission) are user errors: no traceback. ``MemoryError`` also exits 1 with one
    line. Ctrl-C (SIGINT) prints "interrupted" and exits 130, SIGTERM prints
    "terminated" and exits 143, always: the handler records the request
    (`pointatlas.cli._signals`), so an interrupt that reaches Python as
    another exception (a ``SystemError`` out of a numba kernel) or is swallowed by
    library code still ends the command, and no output replaces an earlier file
    after it (``atomic_write`` checks the flag before the rename). Usage errors stay
    with typer (exit 2).
    """

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        with stop_signals_handled(), warnings_as_lines():
            try:
                result = func(*args, **kwargs)
                if interrupt_requested():
                    raise KeyboardInterrupt
                return result
            except typer.Exit:
                if interrupt_requested():
                    _stopped()
                raise
            except KeyboardInterrupt:
                _stopped()
            except BaseException as exc:
                if interrupt_requested():
                    _stopped()
                if isinstance(exc, PointAtlasError | ValueError | TypeError | OSError):
                    _fail(_one_line(exc), 1)
                if isinstance(exc, MemoryError):
                    _fail("out of memory (try a smaller input or fewer neighbours)", 1)
                raise

    return wrapper


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


def renamed_flag(new: str, value, old: str, old_value):
    """The value of a renamed flag: ``value`` (given as ``new``, or its default), or,
    when the old spelling ``old`` was given (a hidden alias kept for one release,
    docs/decisions/cli.md "One vocabulary"), ``old_value``, with a one-line notice
    on stderr. An old spelling that was not given is None (False for a switch)."""
    if old_value is None or old_value is False:
        return value
    say(
        f"warning: {old} is deprecated; use {new} (the old name goes in the next release)",
        out=err_console,
    )
    return old_value


def deprecated_option(old: str, new: str):
    """The hidden typer option of a flag's old spelling ``old`` (see `renamed_flag`)."""
    return typer.Option(old, hidden=True, help=f"Deprecated spelling of {new}.")


#: ``--estimate-normals/--no-estimate-normals`` of every command that needs normals
#: (see `read_with_normals`); the same flag and help everywhere.
EstimateNormalsOption = Annotated[
    bool | None,
    typer.Option(
        "--estimate-normals/--no-estimate-normals",
        help="Estimate (PCA) and orient normals first; default: only when the input has none "
        "(normals the input has are kept as input_normals when re-estimated).",
        show_default=False,
    ),
]
#: ``--normal-k``: neighbours of the estimated normals.
NormalKOption = Annotated[int, typer.Option("--normal-k", help="Neighbours for estimated normals.")]

# The VSA flags of ``segment`` and ``simplify``: declared once, so both commands
# take the same names, help and (in their signatures) defaults; `vsa_options`
# turns them into one `pointatlas.segment.VSAOptions`.
#: ``--k``: neighbourhood size of the VSA graph (default 8).
VSAKOption = Annotated[
    int, typer.Option("--k", help="Neighbours, the point itself included (thesis: 8).")
]
#: ``--eta``: L21 threshold of split and merge.
EtaOption = Annotated[
    float | None,
    typer.Option("--eta", help="L21 threshold for split/merge (thesis 4.3.3; thesis: 25)."),
]
#: ``--max-angle-deg``: largest mean normal deviation of a region (degrees).
MaxAngleDegOption = Annotated[
    float | None,
    typer.Option("--max-angle-deg", help="Max mean normal deviation per region (deg)."),
]
#: ``--seeds``: see `parse_seeds` (default "all").
SeedsOption = Annotated[
    str, typer.Option("--seeds", help="'all', a number of random seeds, or indices.")
]
#: ``--split/--no-split`` (default on).
SplitOption = Annotated[bool, typer.Option("--split/--no-split", help="Split step.")]
#: ``--merge/--no-merge`` (default on).
MergeOption = Annotated[bool, typer.Option("--merge/--no-merge", help="Merge step.")]
#: ``--switch`` (default batch).
SwitchOption = Annotated[str, typer.Option("--switch", help="batch, single or none.")]
#: ``--classic`` (default off).
ClassicOption = Annotated[
    bool, typer.Option("--classic", help="Classic VSA loop (flood/update/re-seed).")
]
#: ``--local`` (default off): `VSAOptions.local`, the local mode whose tiled runs
#: agree with an untiled run of the same mode (docs/decisions/segment.md).
LocalOption = Annotated[
    bool,
    typer.Option(
        "--local",
        help="Local VSA: the switch keeps regions under the threshold, merges within "
        "0.7 of it; tiles then agree with an untiled --local run.",
    ),
]
#: ``--weights`` (default uniform).
WeightsOption = Annotated[str, typer.Option("--weights", help="uniform or area (Eq. 4.6).")]
#: ``--max-iter`` (default 1000).
MaxIterOption = Annotated[int, typer.Option("--max-iter", help="VSA iterations.")]
#: ``--seed``: draws the random VSA seeds; recorded with the outputs (default 0).
VSASeedOption = Annotated[int, typer.Option("--seed", help="Seed for random VSA seeds.")]

#: ``IN``: a point-set or mesh file, or a bundled model name (`read_input`).
InputArgument = Annotated[
    Path, typer.Argument(metavar="IN", help="Point set or mesh file, or a bundled model name.")
]
#: ``--report``: an HTML report with a 3-D view of the result (`pointatlas.viz`), the
#: same flag on normals, features and segment.
ReportOption = Annotated[
    Path | None,
    typer.Option("--report", help="Also write an HTML report with a 3-D view (.html)."),
]

#: Tiled processing (`pointatlas.batch`), the same five flags on normals, features,
#: segment and denoise; `tile_options` turns them into a ``TileOptions`` (None
#: without ``--tile-size``: the command runs as before).
TileSizeOption = Annotated[
    float | None,
    typer.Option(
        "--tile-size",
        help="Process by x/y tiles of this edge length (coordinate units) on a dask cluster; "
        "LAS/LAZ is streamed by chunks. Default: all points at once. segment: add --local "
        "for tiles that agree with the untiled run (smooth terrain).",
        rich_help_panel="Tiles",
    ),
]
HaloOption = Annotated[
    float | None,
    typer.Option(
        "--halo",
        help="Halo width around every tile (default: automatic, wide enough for every "
        "neighbourhood); a given halo that is too narrow is an error.",
        rich_help_panel="Tiles",
    ),
]
WorkersOption = Annotated[
    int | None,
    typer.Option(
        "--workers", help="Worker processes of the local cluster (2).", rich_help_panel="Tiles"
    ),
]
SchedulerOption = Annotated[
    str | None,
    typer.Option(
        "--scheduler",
        help="Address of a running dask scheduler (tcp://host:8786).",
        rich_help_panel="Tiles",
    ),
]
MaxMemoryOption = Annotated[
    str | None,
    typer.Option(
        "--max-memory",
        help="Memory limit per worker, e.g. 4GB; larger tiles are refused.",
        rich_help_panel="Tiles",
    ),
]
