"""The steps of ``pointatlas demo`` below the commands: what each step computes and
writes into the demo's folder, on the demo model's `PointSet` (points and mesh
normals, with the fields earlier steps added).

The command modules register the steps (`pointatlas.cli._app.demo_step`) and print
what these functions return; the files are named after the model
(``fandisk_segments.ply``, ...).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from ..._core import PointAtlasError, PointSet
from ...io import write_json, write_mesh, write_point_set
from ._console import progress_bar
from ._normals import compute_normals
from ._simplify import simplify_quietly
from ._simplify_report import distance_shares, render_simplification

__all__ = [
    "DEMO_ETA",
    "features_files",
    "info_file",
    "normals_files",
    "picture_file",
    "segment_files",
    "simplify_files",
]

#: Segmentation of the demo model before simplifying: VSA from every point,
#: split/merge threshold eta.
DEMO_ETA = 20.0


def info_file(ps: PointSet, out_dir: Path) -> dict:
    """The model's summary (`point_set_info`, k = 8), written to ``<name>_info.json``."""
    from ...neighbors import point_set_info

    info = point_set_info(ps, k=8)
    write_json(out_dir / f"{ps.name}_info.json", info, indent=2)
    return info


def normals_files(ps: PointSet, out_dir: Path):
    """PCA normals (k = 20, MST orientation) compared with the model's mesh normals:
    ``<name>_normals.ply`` (the estimate, the error in degrees per point) and
    ``<name>_normals.json`` (the comparison). Returns (comparison, per-point error in
    degrees, seconds of the estimate, the PLY's path)."""
    from ...normals import angle_error, compare_normals

    if not ps.has_normals:
        raise PointAtlasError("the demo model has no reference normals")
    t0 = time.perf_counter()
    with progress_bar("normals", total=2) as advance:
        estimated = compute_normals(
            ps.points, k=20, orient="mst", orient_k=10, viewpoint=None, advance=advance
        )
    seconds = time.perf_counter() - t0
    stats = compare_normals(estimated, ps.normals)
    error = np.degrees(angle_error(estimated, ps.normals))
    path = write_point_set(
        out_dir / f"{ps.name}_normals.ply",
        ps.replace(normals=estimated),
        attributes={"normal_error_deg": error},
    )
    write_json(out_dir / f"{ps.name}_normals.json", stats, indent=2)
    return stats, error, seconds, path


def picture_file(ps: PointSet, out_dir: Path) -> Path:
    """``<name>.png``: the model's mesh (its points when it has none) beside the
    points coloured by the PCA normal error, when a step measured it."""
    from ...viz import MeshPanel, PointsPanel, fit_camera, render_side_by_side

    panels = []
    try:
        from ... import data

        mesh = data.load_mesh(ps.name)
    except (ImportError, AttributeError, PointAtlasError, ValueError, OSError):
        mesh = None
    if mesh is not None:
        panels.append(
            MeshPanel(mesh.vertices, mesh.faces, face_offsets=mesh.face_offsets, title="mesh")
        )
    else:
        panels.append(PointsPanel(ps.points, normals=ps.normals, title="points"))
    if "normal_error_deg" in ps.attributes:
        panels.append(
            PointsPanel(
                ps.points,
                normals=ps.normals,
                scalars=ps.attributes["normal_error_deg"],
                scalar_name="PCA normal error (deg)",
                cmap="YlOrRd",
                clim=(0.0, 30.0),
                title="points: normal error (k = 20, MST)",
            )
        )
    camera = fit_camera(ps.points)
    return render_side_by_side(
        out_dir / f"{ps.name}.png",
        panels,
        title=f"{ps.name}: {ps.n_points:,} points",
        view=camera,
        size=(900 * len(panels), 900),
    )


def features_files(ps: PointSet, out_dir: Path):
    """Fig. 5.3 on the model (`pointatlas.experiments.weightings.fig_5_3`: its
    pictures) and ``<name>_features.ply`` (the optimal normal-weighted
    neighbourhoods' fields and the dimension class). Returns (Fig. 5.3's statistics
    per weighting, seconds of Fig. 5.3)."""
    from ...experiments.weightings import fig_5_3
    from ...features import classify_dimension, optimal_neighborhood

    if not ps.has_normals:
        raise PointAtlasError("the demo model has no normals")
    t0 = time.perf_counter()
    stats, _ = fig_5_3(ps.points, ps.normals, out_dir, name=ps.name)
    seconds = time.perf_counter() - t0
    best = optimal_neighborhood(ps.points, ps.normals)
    fields = best.scalar_fields()
    fields["dimension_class"] = classify_dimension(best)
    write_point_set(out_dir / f"{ps.name}_features.ply", ps, attributes=fields)
    return stats, seconds


def segment_files(ps: PointSet, out_dir: Path):
    """VSA from every point with split and merge (k = 8, eta = 25):
    ``<name>_segments.ply`` (the labels, coloured) and ``<name>_segments.png``.
    Returns (the `VSAResult`, the picture's path)."""
    from ...segment import vsa_segment
    from ...viz import label_colors, render_points

    res = vsa_segment(ps.points, ps.normals, k=8, eta=25.0)
    colors = (label_colors(res.labels) * 255).round().astype(np.uint8)
    write_point_set(
        out_dir / f"{ps.name}_segments.ply",
        ps.points,
        normals=ps.normals,
        attributes={"label": np.asarray(res.labels)},
        colors=colors,
    )
    path = render_points(
        out_dir / f"{ps.name}_segments.png",
        ps.points,
        normals=ps.normals,
        labels=res.labels,
        title=f"{ps.name}: VSA, eta = 25, {res.n_regions} regions",
    )
    return res, path


def simplify_files(ps: PointSet, out_dir: Path):
    """The points path on the model (VSA with eta = `DEMO_ETA`): ``<name>_simplified``
    .obj (the polygons), .png (segmentation beside the mesh) and .json (the mesh's
    summary, its distances also in % of the points' diagonal). Returns (the
    `simplify_points` result, the OBJ's and the PNG's paths, the diagonal)."""
    if not ps.has_normals:
        raise PointAtlasError("the demo model has no normals")
    result = simplify_quietly(ps.points, ps.normals, eta=DEMO_ETA)
    mesh = result.mesh
    obj = write_mesh(
        out_dir / f"{ps.name}_simplified.obj", mesh.vertices, [p.tolist() for p in mesh.polygons]
    )
    png = render_simplification(
        out_dir / f"{ps.name}_simplified.png",
        ps.points,
        ps.normals,
        mesh,
        title=f"{ps.name}: VSA (eta = {DEMO_ETA:g}) and the simplified mesh",
    )
    summary = mesh.summary()
    diagonal = float(np.linalg.norm(np.ptp(ps.points, axis=0)))
    summary.update(distance_shares(summary, diagonal))
    write_json(out_dir / f"{ps.name}_simplified.json", summary, indent=2)
    return result, obj, png, diagonal
