"""Layer 5: offscreen pictures of point sets and meshes (numpy renderer + matplotlib Agg).

One fixed orthographic camera (azimuth 35 deg, elevation 25 deg, y up, the
projected bounding box fitted to the frame) is shared by every panel of a model;
point clouds are drawn by a z-buffered software splatter (discs in the tangent
plane when normals are given) that handles 1e6 points in seconds, triangle and
polygon meshes by a numpy z-buffer rasteriser with polygon outlines. Titles,
colour bars and label counts are added with matplotlib (Agg, no pyplot). Output
PNGs are written atomically.

`write_report` writes a self-contained HTML report (tables, embedded PNGs and an
interactive three.js 3-D view of `PointsLayer` / `MeshLayer` layers; the viewer
bundle ``assets/viewer.min.js`` is built by ``tools/viewer/build.sh``).
"""

from ._camera import Camera, fit_camera
from ._colors import label_colors, membership_colors, scalar_colors
from ._figure import MeshPanel, PointsPanel, render_mesh, render_points, render_side_by_side
from ._mesh import render_mesh_array
from ._points import render_points_array
from ._report import ReportSection, write_report
from ._view3d import MeshLayer, PointsLayer

__all__ = [
    "Camera",
    "MeshLayer",
    "MeshPanel",
    "PointsLayer",
    "PointsPanel",
    "ReportSection",
    "fit_camera",
    "label_colors",
    "membership_colors",
    "render_mesh",
    "render_mesh_array",
    "render_points",
    "render_points_array",
    "render_side_by_side",
    "scalar_colors",
    "write_report",
]
