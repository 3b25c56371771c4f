"""What every command's ``--report OUT.html`` shares: the input summary, the point
layer of the 3-D view and its up axis (`pointatlas.viz.write_report` writes the page;
docs/decisions/viz_report.md)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from .._core import PointSet

__all__ = [
    "MAX_TILED_VIEW_POINTS",
    "REPORT_EXTENSIONS",
    "Z_UP_EXTENSIONS",
    "read_back_view",
    "report_layer",
    "report_summary",
    "report_up",
    "write_tiled_report",
]

#: Point-only formats whose data are conventionally z-up (LiDAR / GIS).
Z_UP_EXTENSIONS = (".las", ".laz")
#: Extensions of ``--report``.
REPORT_EXTENSIONS = (".html", ".htm")
#: Most points a tiled run's report reads back from OUT for its 3-D view.
MAX_TILED_VIEW_POINTS = 200_000


def report_summary(path, ps: PointSet) -> dict:
    """The input part of a command's ``--report``: file, size, normals, fields, box."""
    summary = {
        "file": str(path),
        "points": int(ps.n_points),
        "normals": "yes" if ps.has_normals else "no",
        "input fields": ", ".join(sorted(ps.attributes)) or "none",
    }
    if ps.n_points:
        summary["bounding box min"] = ps.points.min(axis=0).tolist()
        summary["bounding box max"] = ps.points.max(axis=0).tolist()
    return summary


def _scalar_fields(source, n_points: int) -> dict:
    """The fields of ``source`` with one number per point (what a view can colour by)."""
    arrays = {name: np.asarray(values) for name, values in source.items()}
    return {
        name: arr
        for name, arr in arrays.items()
        if arr.shape == (n_points,) and arr.dtype.kind in "biuf"
    }


def report_layer(ps: PointSet, ours: dict, *, color_by: str | None = None):
    """A `PointsLayer` of our per-point fields, then the input's numeric ones.

    Only one value per point is drawn (vectors such as colours are left out); an
    input field whose name one of ours uses is shown as ``input <name>``.
    """
    from ..viz import PointsLayer

    fields = {}
    for prefix, source in (("", ours), ("input ", ps.attributes)):
        for name, arr in _scalar_fields(source, ps.n_points).items():
            fields[name if name not in fields else prefix + name] = arr
    return PointsLayer(ps.points, fields, color_by=color_by if color_by in fields else None)


def report_up(path) -> str:
    """Up axis of a report's 3-D view: z for LAS/LAZ (lidar), else y."""
    return "z" if Path(path).suffix.lower() in Z_UP_EXTENSIONS else "y"


def read_back_view(path, max_points: int | None = None):
    """Every n-th point of a written point set (n = ceil(N / max_points)) with its
    one-value-per-point numeric fields; LAS/LAZ are streamed by chunks, so a tiled
    run's output is never loaded whole.

    Returns (points (M, 3), fields {name: (M,)}, N, n). ``max_points`` defaults to
    `MAX_TILED_VIEW_POINTS`.
    """
    max_points = MAX_TILED_VIEW_POINTS if max_points is None else int(max_points)
    path = Path(path)
    if path.suffix.lower() in Z_UP_EXTENSIONS:
        import laspy

        with laspy.open(path) as reader:
            n_total = int(reader.header.point_count)
            step = max(1, -(-n_total // max_points))
            chunks, fields, start = [], {}, 0
            for rec in reader.chunk_iterator(1_000_000):
                sel = np.arange((-start) % step, len(rec), step)
                start += len(rec)
                chunks.append(np.column_stack([rec.x, rec.y, rec.z])[sel])
                for name in rec.point_format.dimension_names:
                    if name in ("X", "Y", "Z"):
                        continue
                    arr = np.asarray(rec[name])
                    if arr.ndim == 1 and arr.dtype.kind in "biuf":
                        fields.setdefault(name, []).append(arr[sel])
        points = np.concatenate(chunks) if chunks else np.empty((0, 3))
        return points, {k: np.concatenate(v) for k, v in fields.items()}, n_total, step
    from ..io import read_point_set

    ps = read_point_set(path)
    step = max(1, -(-ps.n_points // max_points))
    fields = {k: v[::step] for k, v in _scalar_fields(ps.attributes, ps.n_points).items()}
    return ps.points[::step], fields, ps.n_points, step


def _plain_parameters(params) -> dict:
    """A tiled command's parameters (a dict, or an options dataclass such as
    `VSAOptions`) as scalars and strings for the report's table."""
    if dataclasses.is_dataclass(params):
        params = dataclasses.asdict(params)
    if not isinstance(params, dict):
        return {"parameters": str(params)}
    return {k: v if np.isscalar(v) or v is None else str(v) for k, v in params.items()}


def write_tiled_report(
    report, name: str, in_path, out_path, params, summary: dict, *, color_by=None
):
    """``--report`` of a tiled run of the command ``name``: the tiles' numbers and a
    3-D view of every n-th point read back from OUT, coloured by ``color_by`` when
    OUT has that field (the view only; the computation used every point)."""
    from ..viz import PointsLayer, write_report

    points, fields, n_total, step = read_back_view(out_path)
    tables = {"tiles": summary["tiles"]}
    if summary.get("quality"):
        tables["quality"] = summary["quality"]
    write_report(
        report,
        title=f"pointatlas {name} by tiles: {Path(in_path).name}",
        summary={
            "file": str(in_path),
            "output": str(out_path),
            "points": int(n_total),
            "view": f"1 point in {step} of OUT ({points.shape[0]:,} of {n_total:,}), "
            "read back after the tiled run",
            "scheduler": str(summary.get("scheduler", "")),
            "seconds": summary.get("seconds_total"),
        },
        parameters=_plain_parameters(params),
        tables=tables,
        layers=[PointsLayer(points, fields, color_by=color_by if color_by in fields else None)],
        up=report_up(out_path),
    )
    return Path(report)
