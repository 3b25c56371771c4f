"""The report of ``pointatlas simplify``: the console tables, the side-by-side pictures
and the HTML report."""

from __future__ import annotations

from pathlib import Path

from rich.table import Table

__all__ = [
    "distance_shares",
    "render_simplification",
    "render_surface",
    "simplification_table",
    "surface_table",
    "write_html_report",
]


def simplification_table(
    mesh, seg=None, *, title: str | None = None, diagonal: float | None = None
) -> Table:
    """A rich table of the mesh's quality report; with the input's bounding-box
    ``diagonal``, the two-sided Hausdorff distance also as a share of it (the unit of
    ``--max-error 0.5%``)."""
    s = mesh.summary()
    table = Table(title=title, show_header=False, title_justify="left")
    table.add_column("property", style="bold")
    table.add_column("value")
    if seg is not None:
        table.add_row("VSA regions", str(seg.n_regions))
    table.add_row("faces (regions meshed)", f"{s['n_faces']} ({s['n_regions']} regions)")
    _written_rows(table, s)
    table.add_row("vertex method", s["vertex_method"] + (" (fallback)" if s["fallback"] else ""))
    table.add_row("guarded vertices", str(s["n_guarded_vertices"]))
    table.add_row("closed / manifold / oriented", _checks(s))
    table.add_row("faces not ok", str(s["faces_not_ok"]))
    table.add_row("max planarity error (faces)", f"{s['max_planarity_error']:.3g}")
    table.add_row("max planarity error (polygons)", f"{s['max_polygon_planarity_error']:.3g}")
    _distance_rows(table, s, diagonal)
    return table


def render_simplification(
    path: Path, points, normals, mesh, *, title: str | None = None, labels=None
):
    """Side-by-side picture: the segmented points and the simplified mesh."""
    from ...viz import MeshPanel, PointsPanel, fit_camera, render_side_by_side

    camera = fit_camera(points)
    labels = mesh.labels if labels is None else labels
    panels = [
        PointsPanel(points, normals=normals, labels=labels, title="regions meshed"),
        MeshPanel(
            mesh.vertices,
            [p.tolist() for p in mesh.polygons],
            face_labels=mesh.face_region[mesh.polygon_face],
            title=f"simplified mesh: {mesh.n_faces} faces",
        ),
    ]
    return render_side_by_side(path, panels, title=title, view=camera, size=(1800, 900))


def surface_table(
    res,
    *,
    title: str | None = None,
    path: str = "mesh (regions of the input's triangles)",
    diagonal: float | None = None,
) -> Table:
    """A rich table of a mesh-path result's quality report (``diagonal``: as in
    `simplification_table`)."""
    s = res.summary()
    table = Table(title=title, show_header=False, title_justify="left")
    table.add_column("property", style="bold")
    table.add_column("value")
    table.add_row("path", path)
    table.add_row("faces (regions)", str(s["n_faces"]))
    _written_rows(table, s)
    table.add_row("faces kept as input triangles", str(s["n_faces_kept_as_input_triangles"]))
    table.add_row("closed / manifold / oriented", _checks(s))
    table.add_row("Euler characteristic", str(s["euler_characteristic"]))
    table.add_row("self-intersections", f"{s['n_self_intersections']} triangle pairs")
    table.add_row(
        "max planarity error (flat faces)",
        f"{s['max_flat_planarity_error']:.3g} ({s['n_flat_faces']} flat faces, "
        f"{s['n_flat_faces_bent']} bent; {s['n_triangles_set_apart']} triangles set apart)",
    )
    table.add_row("max planarity error (polygons)", f"{s['max_polygon_planarity_error']:.3g}")
    _distance_rows(table, s, diagonal)
    return table


def render_surface(path: Path, mesh_in, res, *, title: str | None = None):
    """Side-by-side picture: the input's triangles by region and the simplified mesh."""
    from ...viz import MeshPanel, fit_camera, render_side_by_side

    camera = fit_camera(mesh_in.vertices)
    panels = [
        MeshPanel(
            mesh_in.vertices,
            mesh_in.triangles,
            face_labels=res.face_labels,
            edges=False,
            title=f"input: {mesh_in.n_faces:,} triangles, {res.n_faces} regions",
        ),
        MeshPanel(
            res.vertices,
            [p.tolist() for p in res.polygons],
            face_labels=res.polygon_face,
            title=f"simplified mesh: {res.n_faces} faces",
        ),
    ]
    return render_side_by_side(path, panels, title=title, view=camera, size=(1800, 900))


def write_html_report(path, infile, info: dict, written, layers, seed: int):
    """The HTML report of ``simplify``: the numbers, the pictures written, a 3-D view."""
    from ...viz import write_report

    numbers = {
        k: v for k, v in info.items() if not isinstance(v, dict | list | tuple) and k != "input"
    }
    pictures = [p for p in written if Path(p).suffix.lower() == ".png"]
    return write_report(
        path,
        title=f"pointatlas simplify: {Path(str(infile)).name}",
        summary={"file": str(infile), "files written": ", ".join(str(p) for p in written)},
        parameters={k: info[k] for k in ("seed",) if k in info},
        tables={"result": numbers},
        pictures=pictures,
        layers=layers,
        seed=seed,
    )


def _written_rows(table: Table, s: dict) -> None:
    """The rows both tables share: what the polygon file holds."""
    table.add_row("polygons / triangles written", f"{s['n_polygons']} / {s['n_triangles']}")
    table.add_row("vertices", str(s["n_vertices"]))
    table.add_row("faces with holes", str(s["n_faces_with_holes"]))


def distance_shares(summary: dict, diagonal: float) -> dict:
    """The report's keys that put its distances on the scale of the input: the
    bounding-box ``diagonal`` (of the points, or of the mesh's used vertices: the one
    ``--max-error 0.5%`` reads) and ``hausdorff_pct``, the two-sided Hausdorff
    distance in % of it.

    Examples
    --------
    >>> distance_shares({"hausdorff": 0.05}, 10.0)
    {'diagonal': 10.0, 'hausdorff_pct': 0.5}
    """
    share = 100.0 * summary["hausdorff"] / diagonal if diagonal > 0 else 0.0
    return {"diagonal": float(diagonal), "hausdorff_pct": float(share)}


def _distance_rows(table: Table, s: dict, diagonal: float | None = None) -> None:
    """Both ways: input to output, output to input, and the larger maximum (with
    ``diagonal``, also in % of it)."""
    table.add_row("mean / max distance", f"{s['distance_mean']:.4g} / {s['distance_max']:.4g}")
    table.add_row(
        "mean / max distance back (output to input)",
        f"{s['back_distance_mean']:.4g} / {s['back_distance_max']:.4g}",
    )
    hausdorff = f"{s['hausdorff']:.4g}"
    if diagonal is not None:
        hausdorff += f" ({distance_shares(s, diagonal)['hausdorff_pct']:.2f} % of the diagonal)"
    table.add_row("two-sided Hausdorff", hausdorff)


def _checks(s: dict) -> str:
    return f"{s['is_closed']} / {s['is_manifold']} / {s['is_oriented']}"
