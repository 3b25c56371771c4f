"""``pointatlas deform``: move the points of a cloud surface with its cloud points."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Annotated

import numpy as np
import typer

from .._core import PointAtlasError
from ..complex import cloud_complex
from ._app import app, console, deprecated_option, guarded, read_input, renamed_flag, say
from ._outputs import check_outputs, write_summary_json
from ._reports import REPORT_EXTENSIONS, report_layer

__all__ = ["deform_command", "deform_report_table", "load_cloudsurface"]


def load_cloudsurface(folder: Path):
    """Read ``cloudsurface.npz`` of a cloudsurface folder: (complex, points, faces)."""
    path = Path(folder) / "cloudsurface.npz"
    if not Path(folder).is_dir():
        raise PointAtlasError(f"{folder}: not a folder (give the OUT_DIR of cloudsurface)")
    if not path.exists():
        raise PointAtlasError(f"{folder}: no cloudsurface.npz (give the OUT_DIR of cloudsurface)")
    try:
        with np.load(path, allow_pickle=False) as z:
            indptr, members = z["cloud_indptr"], z["cloud_members"]
            cp, pts, faces = z["cloud_points"], z["points"], z["faces"]
    except (OSError, ValueError, KeyError) as exc:
        raise PointAtlasError(f"{path}: unreadable ({exc})") from None
    clouds = np.split(members, indptr[1:-1])
    K = cloud_complex(clouds, n_points=pts.shape[0], cloud_points=np.nan_to_num(cp))
    return K, pts, faces


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
    from ..dynamics import deform_points

    points_path = renamed_flag("--move", points_path, "--points", old_points)
    json_path = output.with_suffix(".json")
    check_outputs(
        [surface_dir / "cloudsurface.npz", new_cloud_points, points_path],
        [
            ("OUT", output, (".ply",)),
            ("OUT's summary", json_path, None),
            ("--report", report, REPORT_EXTENSIONS),
        ],
    )
    K, pts0, faces = load_cloudsurface(surface_dir)
    new_cp = read_input(new_cloud_points, with_normals=False).points
    if new_cp.shape[0] != K.n_clouds:
        raise PointAtlasError(
            f"{new_cloud_points}: has {new_cp.shape[0]} points; the cloud surface has "
            f"{K.n_clouds} clouds (give one point per cloud, in the order of complex.ply)"
        )
    pts = pts0 if points_path is None else read_input(points_path, with_normals=False).points
    if pts.shape[0] != K.n_points:
        raise PointAtlasError(
            f"--move {points_path}: has {pts.shape[0]} points; the cloud surface has {K.n_points}"
        )
    t0 = time.perf_counter()
    res = deform_points(pts, K, new_cp, faces=faces, inverse=inverse)
    from ..io import write_point_set
    from ..viz import membership_colors

    colors = membership_colors(K.n_memberships)
    written = [
        write_point_set(
            output,
            res.points,
            attributes={
                "route": res.route.astype(np.int64),
                "n_clouds": np.asarray(K.n_memberships),
            },
            colors=colors,
        )
    ]
    payload = {
        "surface": str(surface_dir),
        "new_cloud_points": str(new_cloud_points),
        "inverse": inverse,
        "n_points": int(K.n_points),
        "routes": res.counts(),
        "unroutable": [int(i) for i in res.unroutable[:1000]],
        "seconds": round(time.perf_counter() - t0, 3),
    }
    if report is not None:
        moved_cp = np.asarray(K.cloud_points) if inverse else new_cp
        written.append(
            _write_deform_report(
                report,
                surface_dir,
                new_cloud_points,
                pts,
                res,
                K,
                payload,
                mesh=(moved_cp, faces),
                parameters={
                    "inverse": inverse,
                    "points": None if points_path is None else str(points_path),
                },
            )
        )
    write_summary_json(json_path, payload, written)
    c = res.counts()
    console.print(
        f"moved {K.n_points - c['unroutable']:,} of {K.n_points:,} points: "
        f"{c['triangle']:,} by triangles, {c['edge']:,} by edges, {c['vertex']:,} by vertices; "
        f"{c['unroutable']:,} unroutable (kept in place)"
    )
    for path in [*written, json_path]:
        say(f"wrote {path}")


def deform_report_table(payload: dict, displacement) -> dict:
    """The result table of ``deform --report``: OUT.json's numbers and the displacements."""
    table = {key: payload[key] for key in ("n_points", "inverse", "seconds")}
    table.update({f"routes: {key}": n for key, n in payload["routes"].items()})
    d = np.asarray(displacement, dtype=np.float64)
    table["mean displacement"] = float(d.mean()) if d.size else None
    table["max displacement"] = float(d.max()) if d.size else None
    return table


def _write_deform_report(
    path, surface_dir, new_cloud_points, pts, res, K, payload, *, mesh, parameters
) -> Path:
    """``deform --report``: the routes, the moved points coloured by displacement, and the
    complex at the moved cloud points as a surface (no surface when it has no triangles)."""
    from .._core import PointSet
    from ..viz import MeshLayer, write_report

    moved = PointSet(res.points, name=Path(surface_dir).name)
    displacement = np.linalg.norm(res.points - pts, axis=1)
    fields = {
        "displacement": displacement,
        "route": res.route.astype(np.int64),
        "n_clouds": np.asarray(K.n_memberships),
    }
    layers = [report_layer(moved, fields, color_by="displacement")]
    vertices, faces = mesh
    if len(faces):
        layers.append(
            MeshLayer(vertices, faces, name="complex at the new cloud points", opacity=0.35)
        )
    summary = {
        "cloud surface": str(surface_dir),
        "new cloud points": str(new_cloud_points),
        "points": int(pts.shape[0]),
        "clouds": int(K.n_clouds),
    }
    return write_report(
        path,
        title=f"pointatlas deform: {Path(surface_dir).name}",
        summary=summary,
        parameters=parameters,
        tables={"result": deform_report_table(payload, displacement)},
        layers=layers,
    )
