"""The files of ``pointatlas cloudsurface`` in OUT_DIR: their paths, the clouds, the
curve's OBJ, cloudsurface.npz (read back by ``deform``), search.csv, the picture and
the HTML report."""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from ..._core import PointAtlasError
from .._outputs import write_point_output, write_text

__all__ = [
    "load_cloudsurface",
    "out_paths",
    "picture",
    "search_csv",
    "write_clouds",
    "write_cloudsurface_report",
    "write_curve_obj",
    "write_npz",
]


def out_paths(out_dir: Path, dim: int) -> dict:
    """The files of a run in OUT_DIR (``complex.obj``, with line elements, for a 2-D
    curve)."""
    return {
        "clouds": out_dir / "clouds.ply",
        "complex": out_dir / ("complex.ply" if dim == 3 else "complex.obj"),
        "npz": out_dir / "cloudsurface.npz",
        "table": out_dir / "report.txt",
        "search": out_dir / "search.csv",
        "picture": out_dir / "cloudsurface.png",
        "json": out_dir / "report.json",
    }


def write_npz(path: Path, K, points: np.ndarray, faces: np.ndarray, meta: dict) -> Path:
    """cloudsurface.npz: the cloud set (CSR), the cloud points, the points, the
    complex's triangles and the run's settings (`load_cloudsurface` reads it)."""
    from ...io import atomic_write

    with atomic_write(path, "wb") as fh:
        np.savez(
            fh,
            cloud_indptr=K.cloud_indptr,
            cloud_members=K.cloud_members,
            cloud_points=K.cloud_points,
            points=points,
            faces=faces,
            meta=np.array(repr(meta)),
        )
    return path


def load_cloudsurface(folder: Path):
    """Read ``cloudsurface.npz`` of a cloudsurface folder: (complex, points, faces)."""
    from ...complex import cloud_complex

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


def write_curve_obj(path: Path, vertices: np.ndarray, edges: np.ndarray) -> Path:
    """The complex of a 2-D cover: one vertex per cloud, one OBJ line per 1-simplex."""
    buf = io.StringIO()
    buf.write("# cloud complex of a 2-D cover: one vertex per cloud, one line per 1-simplex\n")
    for v in vertices:
        buf.write(f"v {v[0]:.17g} {v[1]:.17g} {v[2]:.17g}\n")
    for a, b in edges.tolist():
        buf.write(f"l {a + 1} {b + 1}\n")
    return write_text(path, buf.getvalue())


def write_clouds(path: Path, ps, counts: np.ndarray) -> Path:
    """clouds.ply: the points with every input field, ``n_clouds`` and Example 2's
    colours."""
    from ...viz import membership_colors

    return write_point_output(
        path, ps, {"n_clouds": np.asarray(counts, np.int64), "colors": membership_colors(counts)}
    )


def picture(path: Path, points, counts, vertices, faces, edges, title: str) -> Path:
    """cloudsurface.png: the points by number of clouds beside the complex (a curve's
    edges sampled densely)."""
    from ...viz import MeshPanel, PointsPanel, membership_colors, render_side_by_side

    colors = membership_colors(counts)
    panels = [PointsPanel(points, colors=colors, title="points by number of clouds (Example 2)")]
    if faces.shape[0]:
        panels.append(MeshPanel(vertices, faces, title=f"complex: {faces.shape[0]} triangles"))
    else:  # a curve: sample the edges densely
        t = np.linspace(0.0, 1.0, 24)[None, :, None]
        a, b = vertices[edges[:, 0]][:, None, :], vertices[edges[:, 1]][:, None, :]
        seg = (a + t * (b - a)).reshape(-1, 3)
        pts = np.concatenate([seg, vertices[np.isfinite(vertices).all(axis=1)]])
        panels.append(PointsPanel(pts, title=f"complex: {edges.shape[0]} edges", lighting=False))
    return render_side_by_side(path, panels, title=title, size=(1200, 600))


def search_csv(path: Path, rows: list[dict]) -> Path:
    """search.csv: one row per setting tried."""
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=list(rows[0]), lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    return write_text(path, buf.getvalue())


def write_cloudsurface_report(path, in_path, payload, points, counts, verts, faces, written, seed):
    """The HTML report: the numbers, the picture, a 3-D view of clouds and complex."""
    from ...viz import MeshLayer, PointsLayer, write_report

    numbers = {k: v for k, v in payload.items() if isinstance(v, int | float | str | bool)}
    numbers.update(
        {k: v for k, v in payload["report"].items() if isinstance(v, int | float | str | bool)}
    )
    layers = [PointsLayer(points, {"n_clouds": np.asarray(counts)}, name="points")]
    if faces is not None and len(faces):
        layers.append(MeshLayer(np.nan_to_num(verts), faces, name="cloud complex", opacity=0.6))
    return write_report(
        path,
        title=f"pointatlas cloudsurface: {Path(str(in_path)).name}",
        summary={"file": str(in_path), "points": int(points.shape[0])},
        parameters={k: payload[k] for k in ("mode", "seed") if k in payload},
        tables={"result": numbers},
        pictures=[p for p in written if Path(p).suffix.lower() == ".png"],
        layers=layers,
        seed=seed,
    )
