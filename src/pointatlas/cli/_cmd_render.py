"""``pointatlas render``: a point set or mesh file as a PNG (offscreen, fixed camera)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated

import numpy as np
import typer

from .._core import PointAtlasError, PointSet
from ..io import (
    MESH_EXTENSIONS,
    read_mesh,
    read_point_set,
)
from ._app import (
    app,
    deprecated_option,
    guarded,
    progress_bar,
    renamed_flag,
    say,
)
from ._outputs import (
    check_outputs,
)
from ._reports import Z_UP_EXTENSIONS

__all__ = ["render_command", "render_file"]

#: Integer attributes whose name contains one of these are drawn as categories.
CATEGORY_HINTS = ("label", "class", "region", "segment", "cluster", "component")


def _pick_coloring(ps: PointSet, color_by: str) -> dict:
    """Keyword arguments of ``render_points`` for ``--color-by`` (see the docs)."""
    attrs = ps.attributes
    key = color_by.strip()
    if key == "normals":
        return {}
    if key == "labels" and "labels" not in attrs:
        candidates = [a for a in attrs if any(h in a.lower() for h in CATEGORY_HINTS)]
        if not candidates:
            raise PointAtlasError(
                "--color-by labels: the file has no 'labels' attribute; fields: " + _field_list(ps)
            )
        key = candidates[0]
    if key in attrs:
        values = np.asarray(attrs[key])
        if values.ndim == 2 and values.shape[1] in (3, 4) and key.lower() in ("colors", "colours"):
            return {"colors": values}
        if values.ndim != 1:
            raise PointAtlasError(
                f"--color-by {key}: attribute has shape {values.shape}, not one value per "
                f"point; fields: {_field_list(ps)}"
            )
        if values.dtype.kind in "iu" and any(h in key.lower() for h in CATEGORY_HINTS):
            return {"labels": values}
        if values.dtype.kind not in "biuf":
            raise PointAtlasError(f"--color-by {key}: attribute is not numeric ({values.dtype})")
        return {"scalars": values.astype(np.float64), "scalar_name": key}
    if key in ("x", "y", "z"):
        axis = "xyz".index(key)
        return {"scalars": ps.points[:, axis], "scalar_name": key}
    raise PointAtlasError(
        f"--color-by {color_by!r} is not a field of the file; fields: {_field_list(ps)}"
    )


def _field_list(ps: PointSet) -> str:
    return ", ".join(["normals", "x", "y", "z", *sorted(ps.attributes)])


def _view(azimuth_deg: float, elevation_deg: float, up: str, path: Path):
    if not (math.isfinite(azimuth_deg) and math.isfinite(elevation_deg)):
        raise PointAtlasError("--azimuth-deg and --elevation-deg must be finite")
    if not -90.0 <= elevation_deg <= 90.0:
        raise PointAtlasError(f"--elevation-deg must lie in [-90, 90]; got {elevation_deg}")
    if up == "auto":
        up = "z" if path.suffix.lower() in Z_UP_EXTENSIONS else "y"
    if up not in ("x", "y", "z"):
        raise PointAtlasError(f"--up must be auto, x, y or z; got {up!r}")
    return math.radians(azimuth_deg), math.radians(elevation_deg), np.eye(3)["xyz".index(up)]


def render_file(
    in_path: Path,
    out_path: Path,
    *,
    color_by: str = "normals",
    title: str | None = None,
    size=(1024, 1024),
    azimuth_deg: float = 35.0,
    elevation_deg: float = 25.0,
    up: str = "auto",
    cmap: str = "viridis",
    draw: str = "auto",
) -> Path:
    """Render a point-set or mesh file to a PNG (the ``render`` command)."""
    from ..viz import fit_camera, render_mesh, render_points

    check_outputs([in_path], [("OUT", out_path, (".png",))])
    out_path = Path(out_path)
    az, el, up_vec = _view(azimuth_deg, elevation_deg, up, Path(in_path))
    if draw not in ("auto", "points", "mesh"):
        raise PointAtlasError(f"--as must be auto, points or mesh; got {draw!r}")
    mesh = None
    if draw != "points" and Path(in_path).suffix.lower() in MESH_EXTENSIONS:
        mesh = read_mesh(in_path)
        if mesh.n_faces == 0:
            mesh = None
    if draw == "mesh" and mesh is None:
        raise PointAtlasError(f"--as mesh: {str(in_path)!r} has no faces")
    if draw == "mesh" and color_by != "normals":
        raise PointAtlasError("--color-by colours points; use it without --as mesh")
    if mesh is not None and (draw == "mesh" or color_by == "normals"):
        camera = fit_camera(mesh.vertices, azimuth=az, elevation=el, up=up_vec)
        colors = mesh.face_colors if color_by == "normals" else None
        return render_mesh(
            out_path,
            mesh.vertices,
            mesh.faces,
            face_offsets=mesh.face_offsets,
            face_colors=colors,
            title=title or mesh.name,
            view=camera,
            size=size,
        )
    ps = read_point_set(in_path, zero_normals="drop")
    coloring = _pick_coloring(ps, color_by)
    camera = fit_camera(ps.points, azimuth=az, elevation=el, up=up_vec)
    return render_points(
        out_path,
        ps.points,
        normals=ps.normals,
        cmap=cmap,
        title=title or ps.name,
        view=camera,
        size=size,
        **coloring,
    )


@app.command("render")
@guarded
def render_command(
    in_path: Annotated[Path, typer.Argument(metavar="IN", help="Point set or mesh file.")],
    out_path: Annotated[Path, typer.Argument(metavar="OUT.png", help="PNG to write.")],
    color_by: Annotated[
        str,
        typer.Option(
            "--color-by",
            help="normals (shading, default), labels, x/y/z, or any per-point attribute.",
        ),
    ] = "normals",
    title: Annotated[str | None, typer.Option("--title", help="Picture title.")] = None,
    size: Annotated[
        tuple[int, int], typer.Option("--render-size", help="Width and height (pixels).")
    ] = (1024, 1024),
    azimuth_deg: Annotated[float, typer.Option("--azimuth-deg", help="View azimuth.")] = 35.0,
    elevation_deg: Annotated[float, typer.Option("--elevation-deg", help="View elevation.")] = 25.0,
    up: Annotated[
        str, typer.Option("--up", help="Up axis: auto (z for LAS/LAZ, else y), x, y or z.")
    ] = "auto",
    cmap: Annotated[
        str, typer.Option("--cmap", help="Matplotlib colormap for scalars.")
    ] = "viridis",
    draw: Annotated[
        str, typer.Option("--as", help="auto (mesh when the file has faces), points or mesh.")
    ] = "auto",
    old_size: Annotated[
        tuple[int, int] | None, deprecated_option("--size", "--render-size")
    ] = None,
):
    """Render a point set or mesh to a PNG (offscreen, fixed camera)."""
    size = renamed_flag("--render-size", size, "--size", old_size)
    with progress_bar("rendering") as advance:
        path = render_file(
            in_path,
            out_path,
            color_by=color_by,
            title=title,
            size=size,
            azimuth_deg=azimuth_deg,
            elevation_deg=elevation_deg,
            up=up,
            cmap=cmap,
            draw=draw,
        )
        advance()
    say(f"wrote {path}")
