"""``pointatlas data list`` and ``data export``: the bundled models."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from .._core import PointAtlasError
from ..io import (
    MESH_EXTENSIONS,
    POINT_WRITE_EXTENSIONS,
    json_text,
    write_mesh,
    write_point_set,
)
from ._app import (
    console,
    data_app,
    guarded,
    say,
)
from ._outputs import (
    XYZ_EXTENSIONS,
    check_outputs,
    check_point_output,
)
from .jobs import bundled_data

__all__ = ["data_export_command", "data_list_command"]


@data_app.command("list")
@guarded
def data_list_command(
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON instead of a table.")] = False,
):
    """List the bundled models and synthetic shapes (name, points, licence, source)."""
    rows = [
        {"name": r.name, "points": r.n_points, "license": r.license, "source": r.source}
        for r in bundled_data().info()
    ]
    if as_json:
        typer.echo(json_text(rows, indent=2))
        return
    table = Table(title="bundled models (pointatlas data export NAME OUT)", title_justify="left")
    table.add_column("name", style="bold", no_wrap=True)
    table.add_column("points", justify="right", no_wrap=True)
    table.add_column("licence")
    table.add_column("source", overflow="fold")
    for r in rows:
        table.add_row(r["name"], f"{r['points']:,}", r["license"], r["source"])
    console.print(table)


@data_app.command("export")
@guarded
def data_export_command(
    name: Annotated[
        str, typer.Argument(metavar="NAME", help="Bundled model name (`pointatlas data list`).")
    ],
    out_path: Annotated[
        Path, typer.Argument(metavar="OUT", help="Output file; format by extension.")
    ],
    points_only: Annotated[
        bool,
        typer.Option(
            "--points", help="Write the point set (normals, attributes such as labels), no faces."
        ),
    ] = False,
):
    """Write a bundled model to a file.

    Mesh formats (.obj .off .stl .ply) keep the faces; point formats (.xyz .txt
    .las .laz), or ``--points`` with .ply, write the points with their normals and
    attributes (e.g. the ground-truth ``labels`` of synthetic shapes).
    """
    data = bundled_data()
    ext = out_path.suffix.lower()
    check_outputs(
        [], [("OUT", out_path, tuple(sorted(set(MESH_EXTENSIONS) | set(POINT_WRITE_EXTENSIONS))))]
    )
    if name not in data.names():
        raise PointAtlasError(f"unknown model {name!r}; bundled: {', '.join(data.names())}")
    if points_only and ext not in POINT_WRITE_EXTENSIONS:
        raise PointAtlasError(
            f"--points needs a point format ({', '.join(POINT_WRITE_EXTENSIONS)})"
        )
    if ext in MESH_EXTENSIONS and not points_only:
        mesh = data.load_mesh(name)
        path = write_mesh(out_path, mesh)
        say(f"wrote {path} ({mesh.n_vertices:,} vertices, {mesh.n_faces:,} faces)")
        return
    ps = data.load(name)
    if ext in XYZ_EXTENSIONS and ps.attributes:
        check_point_output(out_path, ps, {})
    path = write_point_set(out_path, ps)
    say(f"wrote {path} ({ps.n_points:,} points)")
