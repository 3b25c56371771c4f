"""``pointatlas deform``: its arguments as `DeformOptions` for the job
(`pointatlas.cli.jobs.run_deform`: move the points of a cloud surface with its cloud
points, Algorithm 3), and what it prints."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ._app import app, console, deprecated_option, guarded, renamed_flag, say
from .jobs import DeformOptions, run_deform

__all__ = ["deform_command"]


@app.command("deform")
@guarded
def deform_command(
    surface_dir: Annotated[
        Path, typer.Argument(metavar="CLOUDSURFACE_DIR", help="Output folder of cloudsurface.")
    ],
    new_cloud_points: Annotated[
        Path,
        typer.Argument(
            metavar="NEW_CLOUD_POINTS",
            help="The cloud points at time 1 (complex.ply with moved vertices, or any point "
            "file with one point per cloud, in order).",
        ),
    ],
    output: Annotated[Path, typer.Argument(metavar="OUT", help="The moved points (.ply).")],
    inverse: Annotated[
        bool, typer.Option("--inverse", help="Map points at time 1 back to time 0.")
    ] = False,
    points_path: Annotated[
        Path | None,
        typer.Option("--move", help="Points to move (default: the cloud surface's points)."),
    ] = None,
    report: Annotated[
        Path | None,
        typer.Option(
            "--report",
            help="Also write an HTML report with a 3-D view of the moved points "
            "(coloured by displacement) and the moved complex (.html).",
        ),
    ] = None,
    old_points: Annotated[Path | None, deprecated_option("--points", "--move")] = None,
):
    """Move the points of a cloud surface with its cloud points (Algorithm 3).

    Points in three clouds follow their triangle, in two clouds their edge, in one
    cloud their vertex; points that cannot be routed keep their position and are
    counted (field ``route`` = 0). Writes OUT, with ``--report`` an HTML report and,
    last, OUT.json.
    """
    points_path = renamed_flag("--move", points_path, "--points", old_points)
    options = DeformOptions(
        new_cloud_points=new_cloud_points, inverse=inverse, move=points_path, report=report
    )
    _print_deform(run_deform(surface_dir, output, options))


def _print_deform(result) -> None:
    """The console lines of ``deform``: the points moved by each route, then the files
    written."""
    c, n = result.routes, result.n_points
    console.print(
        f"moved {n - c['unroutable']:,} of {n:,} points: "
        f"{c['triangle']:,} by triangles, {c['edge']:,} by edges, {c['vertex']:,} by vertices; "
        f"{c['unroutable']:,} unroutable (kept in place)"
    )
    for path in result.written:
        say(f"wrote {path}")
