"""Command-line interface ``pointatlas`` (typer + rich).

Command modules register themselves on import; add one import line per module.
"""

# command modules (each registers on ``app`` / sub-apps when imported)
# (one import line per module, keep sorted)
from . import (
    _cmd_core,  # noqa: F401
    _cmd_features,  # noqa: F401
    _cmd_segment,  # noqa: F401
    _cmd_simplify,  # noqa: F401
    _exp_vsa,  # noqa: F401
)
from ._app import app

__all__ = ["app", "main"]


def main() -> None:
    """Entry point of the ``pointatlas`` console script."""
    app()
