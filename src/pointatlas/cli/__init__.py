"""Command-line interface ``pointatlas`` (typer + rich).

Command modules register themselves on import; add one name per module to
``_COMMAND_MODULES`` (``_cmd_info`` and ``_cmd_core`` first, the rest sorted): the
help lists the commands (``info``, ``normals``, ``demo`` first) and ``demo`` runs the
steps in that order. They are imported on first use of ``app``, so that ``main`` can
install its Ctrl-C handler before the heavy imports.
"""

from __future__ import annotations

import importlib
import os
import signal
import sys
from typing import TYPE_CHECKING

from ._signals import STOPPED

if TYPE_CHECKING:
    import typer

__all__ = ["app", "main"]

app: typer.Typer  # declared for the API reference; bound on first use by __getattr__
"""The typer application: every ``pointatlas`` command (imported on first use)."""

# command modules (each registers on ``app`` / sub-apps when imported)
_COMMAND_MODULES = (
    "_cmd_info",
    "_cmd_core",
    "_cmd_cloudsurface",
    "_cmd_data",
    "_cmd_deform",
    "_cmd_denoise",
    "_cmd_experiment",
    "_cmd_features",
    "_cmd_render",
    "_cmd_segment",
    "_cmd_simplify",
    "_warm",
)


def _load_app():
    for name in _COMMAND_MODULES:
        importlib.import_module(f"{__name__}.{name}")
    from ._app import app

    return app


def __getattr__(name: str):
    if name == "app":
        return _load_app()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _interrupted_while_starting(signum, frame):  # pragma: no cover - timing dependent
    # nothing has been written yet: say so in one line and leave at once
    line, code = STOPPED[signum]
    sys.stderr.write(f"error: {line}\n")
    sys.stderr.flush()
    os._exit(code)


def main() -> None:
    """Entry point of the ``pointatlas`` console script.

    Ctrl-C (SIGTERM) while the command modules load prints one line and exits 130
    (143); once a command runs, ``guarded`` handles it (outputs stay as they were).

    Raises
    ------
    SystemExit
        With the command's exit status: 0, 1 (a user error) or 2 (a usage error);
        after Ctrl-C or SIGTERM the process ends at once with 130 or 143.
    """
    for signum in STOPPED:
        signal.signal(signum, _interrupted_while_starting)
    try:
        app = _load_app()
        from ._compile_notice import announce_compiles

        announce_compiles()  # one line on stderr while kernels compile (cold cache)
        app()
    except SystemExit as exc:
        if exc.code not in {code for _, code in STOPPED.values()}:
            raise
        # interrupted: the command has cleaned up and said so; leave without the
        # interpreter's teardown, which can crash (SIGSEGV) when a numba parallel
        # kernel's threads were stopped part-way
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(exc.code)
