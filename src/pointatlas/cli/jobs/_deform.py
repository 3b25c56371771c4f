"""The job of ``pointatlas deform``: move the points of a cloud surface with its cloud
points (Algorithm 3, thesis Chapter A)."""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..._core import PointAtlasError
from .._outputs import check_outputs, write_summary_json
from .._reports import REPORT_EXTENSIONS, report_layer
from ._cloud_files import load_cloudsurface
from ._inputs import read_input

__all__ = ["DeformOptions", "DeformResult", "deform_report_table", "run_deform"]


@dataclass(frozen=True)
class DeformOptions:
    """The settings of ``pointatlas deform``: ``new_cloud_points`` (NEW_CLOUD_POINTS:
    a point file with one point per cloud, in the order of complex.ply), ``inverse``
    (map points at time 1 back to time 0), ``move`` (``--move``: the points to move;
    None: the cloud surface's own) and ``report`` (HTML)."""

    new_cloud_points: Path
    inverse: bool = False
    move: Path | None = None
    report: Path | None = None


@dataclass(frozen=True)
class DeformResult:
    """What `run_deform` did: the points of the cloud surface, how many each route
    moved (`DeformResult.counts` of `pointatlas.dynamics`) and the files written
    (OUT.json last)."""

    n_points: int
    routes: dict
    written: list


def run_deform(in_path, out_path, options: DeformOptions, tiles=None) -> DeformResult:
    """``pointatlas deform``: the cloud surface of the folder ``in_path`` (the OUT_DIR
    of ``cloudsurface``) deformed to the new cloud points; OUT (.ply) holds the moved
    points with ``route`` and ``n_clouds``, then the report and, last, OUT.json.
    There is no tiled run: ``tiles`` must be None."""
    from ...dynamics import deform_points

    o = options
    if tiles is not None:
        raise PointAtlasError("deform has no tiled run (--tile-size)")
    surface_dir, new_cloud_points, points_path = Path(in_path), o.new_cloud_points, o.move
    json_path = out_path.with_suffix(".json")
    check_outputs(
        [surface_dir / "cloudsurface.npz", new_cloud_points, points_path],
        [
            ("OUT", out_path, (".ply",)),
            ("OUT's summary", json_path, None),
            ("--report", o.report, REPORT_EXTENSIONS),
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
    res = deform_points(pts, K, new_cp, faces=faces, inverse=o.inverse)
    written = [_write_moved(out_path, res, K)]
    payload = {
        "surface": str(surface_dir),
        "new_cloud_points": str(new_cloud_points),
        "inverse": o.inverse,
        "n_points": int(K.n_points),
        "routes": res.counts(),
        "unroutable": [int(i) for i in res.unroutable[:1000]],
        "seconds": round(time.perf_counter() - t0, 3),
    }
    if o.report is not None:
        moved_cp = np.asarray(K.cloud_points) if o.inverse else new_cp
        written.append(
            _write_deform_report(
                o.report,
                surface_dir,
                new_cloud_points,
                pts,
                res,
                K,
                payload,
                mesh=(moved_cp, faces),
                parameters={
                    "inverse": o.inverse,
                    "points": None if points_path is None else str(points_path),
                },
            )
        )
    write_summary_json(json_path, payload, written)
    return DeformResult(K.n_points, res.counts(), [*written, json_path])


def _write_moved(path: Path, res, K) -> Path:
    """OUT: the moved points with their ``route`` and ``n_clouds``, coloured as
    Example 2."""
    from ...io import write_point_set
    from ...viz import membership_colors

    colors = membership_colors(K.n_memberships)
    return write_point_set(
        path,
        res.points,
        attributes={
            "route": res.route.astype(np.int64),
            "n_clouds": np.asarray(K.n_memberships),
        },
        colors=colors,
    )


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
    from ..._core import PointSet
    from ...viz import MeshLayer, write_report

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
