"""``pointatlas info``: its flags as `InfoOptions` for the job
(`pointatlas.cli.jobs.run_info`: size, bounding box, spacing, k-NN components,
attributes), and what it prints: a table or JSON."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ..io import json_text
from ._app import app, console, err_console, guarded, say
from .jobs import InfoOptions, info_table, run_info

__all__ = ["info_command"]


@app.command("info")
@guarded
def info_command(
    file: Annotated[
        Path,
        typer.Argument(
            metavar="IN",
            help="Point set or mesh (PLY, OBJ, OFF, STL, XYZ, LAS), or a bundled model name.",
        ),
    ],
    k: Annotated[
        int, typer.Option("--k", help="k of the k-NN graph whose components are counted.")
    ] = 8,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON instead of a table.")] = False,
    report: Annotated[
        Path | None,
        typer.Option(
            "--report",
            help="Also write an HTML report: the summary and a 3-D view of the points "
            "coloured by k-NN component or local spacing (.html).",
        ),
    ] = None,
):
    """Summary of a point set: size, bounding box, spacing, k-NN components, attributes."""
    result = run_info(file, report, InfoOptions(k=k))
    info = result.info
    if as_json:
        typer.echo(json_text(info, indent=2))
    else:
        say(f"file: {file}")
        console.print(info_table(info))
    for path in result.written:
        say(f"wrote {path}", out=err_console if as_json else None)
