"""What every command's ``--report OUT.html`` shares: the input summary, the point
layer of the 3-D view and its up axis (`pointatlas.viz.write_report` writes the page;
docs/decisions/viz_report.md)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .._core import PointSet

__all__ = ["REPORT_EXTENSIONS", "Z_UP_EXTENSIONS", "report_layer", "report_summary", "report_up"]

#: Point-only formats whose data are conventionally z-up (LiDAR / GIS).
Z_UP_EXTENSIONS = (".las", ".laz")
#: Extensions of ``--report``.
REPORT_EXTENSIONS = (".html", ".htm")


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


def report_layer(ps: PointSet, ours: dict, *, color_by: str | None = None):
    """A `PointsLayer` of our per-point fields, then the input's numeric ones.

    Only one value per point is drawn (vectors such as colours are left out); an
    input field whose name one of ours uses is shown as ``input <name>``.
    """
    from ..viz import PointsLayer

    fields = {}
    for prefix, source in (("", ours), ("input ", ps.attributes)):
        for name, values in source.items():
            arr = np.asarray(values)
            if arr.shape != (ps.n_points,) or arr.dtype.kind not in "biuf":
                continue
            fields[name if name not in fields else prefix + name] = arr
    return PointsLayer(ps.points, fields, color_by=color_by if color_by in fields else None)


def report_up(path) -> str:
    """Up axis of a report's 3-D view: z for LAS/LAZ (lidar), else y."""
    return "z" if Path(path).suffix.lower() in Z_UP_EXTENSIONS else "y"
