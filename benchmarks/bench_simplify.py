"""Simplified meshes: pointatlas (from the points alone) vs mesh decimation / VSA peers.

Run from the repository root::

    .venv/bin/python benchmarks/bench_simplify.py [--models fandisk block twelve]
    .venv/bin/python benchmarks/bench_simplify.py --scene 1000000   # raw scan to mesh

For every model, pointatlas segments the *points* (mesh vertices with area-weighted
normals; VSA from every point, eta = 20) and builds the simplified polygon
mesh; the peers get the original *triangle mesh*:

* Open3D ``simplify_quadric_decimation`` and pymeshlab
  ``meshing_decimation_quadric_edge_collapse`` to the same number of triangles;
* CGAL ``Surface_mesh_approximation::approximate_triangle_mesh`` (VSA on the mesh,
  CGAL 5.5 from Debian's ``libcgal-dev``, compiled here; installed with apt-get when
  missing) with as many proxies as pointatlas has faces.

Reported: triangles, closed, mean and max distance from the original vertices to the
result (one metric for all: pointatlas.simplify.point_mesh_distance), wall time of
the simplification itself (file reading excluded). Peers that are not installed
are reported as such.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from pointatlas._core import PointAtlasError
from pointatlas.io import read_mesh, read_point_set, write_mesh
from pointatlas.simplify import mesh_checks, point_mesh_distance, simplify_points

ROOT = Path(__file__).resolve().parents[1]
MODELS = {
    "fandisk": ROOT / "src/pointatlas/data/models/fandisk_12494.obj",
    "block": ROOT / "../shared/data/models/block_8771.obj",
    "twelve": ROOT / "../shared/data/models/twelve_4610.obj",
}
#: VSA split/merge threshold for pointatlas (from every point as a seed).
ETA = 20.0
CGAL_SRC = Path(__file__).resolve().with_name("cgal_vsa.cpp")


def _version(dist: str) -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version(dist)
    except PackageNotFoundError:
        return "?"


def _tri(mesh) -> np.ndarray:
    """The (F, 3) triangles of a triangle mesh read by pointatlas.io."""
    if not (np.asarray(mesh.face_sizes) == 3).all():
        raise ValueError("the benchmark needs triangle meshes")
    return np.array(mesh.faces, dtype=np.int64).reshape(-1, 3)


def _row(name, points, vertices, triangles, seconds, note=""):
    tri = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    if tri.shape[0] == 0:
        return {"method": name, "note": note or "no triangles"}
    d = point_mesh_distance(points, vertices, tri)
    closed, manifold, oriented = mesh_checks(len(vertices), tri)
    return {
        "method": name,
        "triangles": int(tri.shape[0]),
        "closed": closed,
        "mean_distance": float(d.mean()),
        "max_distance": float(d.max()),
        "seconds": seconds,
        "note": note,
    }


def run_ours(ps):
    t0 = time.perf_counter()
    r = simplify_points(ps.points, ps.normals, eta=ETA)
    seconds = time.perf_counter() - t0
    m = r.mesh
    row = _row(
        "pointatlas (points only)",
        ps.points,
        m.vertices,
        m.triangles,
        seconds,
        note=f"{m.n_faces} polygon faces, {r.segmentation.n_regions} VSA regions",
    )
    return row, m


def run_open3d(mesh, points, target):
    try:
        import open3d as o3d
    except ImportError:
        return {"method": "Open3D quadric decimation", "note": "open3d not installed"}
    tm = o3d.geometry.TriangleMesh(
        o3d.utility.Vector3dVector(np.array(mesh.vertices, dtype=np.float64)),
        o3d.utility.Vector3iVector(_tri(mesh).astype(np.int32)),
    )
    t0 = time.perf_counter()
    out = tm.simplify_quadric_decimation(target_number_of_triangles=int(target))
    seconds = time.perf_counter() - t0
    return _row(
        "Open3D quadric decimation",
        points,
        np.asarray(out.vertices),
        np.asarray(out.triangles),
        seconds,
        note=f"open3d {o3d.__version__}",
    )


def run_pymeshlab(mesh, points, target):
    try:
        import pymeshlab
    except ImportError:
        return {"method": "pymeshlab quadric edge collapse", "note": "pymeshlab not installed"}
    ms = pymeshlab.MeshSet()
    ms.add_mesh(
        pymeshlab.Mesh(np.asarray(mesh.vertices, dtype=np.float64), _tri(mesh).astype(np.int32))
    )
    t0 = time.perf_counter()
    ms.meshing_decimation_quadric_edge_collapse(targetfacenum=int(target), preservetopology=True)
    seconds = time.perf_counter() - t0
    out = ms.current_mesh()
    return _row(
        "pymeshlab quadric edge collapse",
        points,
        out.vertex_matrix(),
        out.face_matrix(),
        seconds,
        note=f"pymeshlab {_version('pymeshlab')}",
    )


def _cgal_binary(build_dir: Path):
    exe = build_dir / "cgal_vsa"
    if exe.exists():
        return exe, ""
    if not Path("/usr/include/CGAL/Surface_mesh_approximation").exists():
        if shutil.which("apt-get") is None:
            return None, "libcgal-dev missing and no apt-get"
        try:
            subprocess.run(
                ["apt-get", "install", "-y", "--no-install-recommends", "libcgal-dev"],
                check=True,
                capture_output=True,
                timeout=900,
            )
        except (subprocess.SubprocessError, OSError) as exc:
            return None, f"apt-get install libcgal-dev failed: {exc}"
    build_dir.mkdir(parents=True, exist_ok=True)
    cmd = [
        "g++",
        "-O3",
        "-DNDEBUG",
        "-std=c++17",
        str(CGAL_SRC),
        "-o",
        str(exe),
        "-I/usr/include/eigen3",
        "-lgmp",
        "-lmpfr",
    ]
    try:
        subprocess.run(cmd, check=True, capture_output=True, timeout=1200)
    except (subprocess.SubprocessError, OSError) as exc:
        return None, f"compiling {CGAL_SRC.name} failed: {exc}"
    return exe, ""


def run_cgal(mesh, points, n_proxies, build_dir):
    name = "CGAL Surface_mesh_approximation (VSA)"
    exe, why = _cgal_binary(build_dir)
    if exe is None:
        return {"method": name, "note": why}
    with tempfile.TemporaryDirectory() as tmp:
        src = write_mesh(Path(tmp) / "in.off", mesh.vertices, _tri(mesh))
        dst = Path(tmp) / "out.off"
        res = subprocess.run(
            [str(exe), str(src), str(dst), str(int(n_proxies))],
            capture_output=True,
            text=True,
            timeout=1200,
        )
        if res.returncode != 0:
            return {"method": name, "note": f"failed: {res.stderr.strip()[:200]}"}
        seconds, manifold = res.stdout.split()
        out = read_mesh(dst)
        faces = np.asarray(out.faces, dtype=np.int64).reshape(-1, 3)
        return _row(
            name,
            points,
            out.vertices,
            faces,
            float(seconds),
            note=f"CGAL 5.5, {n_proxies} proxies, manifold={manifold == '1'}",
        )


def run_scene(n_points: int, path: str = "robust") -> dict:
    """Raw scan points of benchmarks/scene.py (normals estimated) to a mesh, timed.

    Normals: `surface_normals` (PCA with k = 20, the least-entropy size in 10..30
    where not flat), MST orientation, `sharpen_normals` and `outward_normals` (as
    ``pointatlas simplify --estimate-normals``); then `simplify_points` with ``path``
    (``"robust"``: the points' surface on a voxel grid, then the mesh path). The scene is open (a
    ground plane), so the mesh's boundary follows the ground's outline.
    """
    from pointatlas.neighbors import query_knn
    from pointatlas.normals import orient_normals
    from pointatlas.simplify import outward_normals, sharpen_normals, surface_normals

    spec = importlib.util.spec_from_file_location("scene", ROOT / "benchmarks/scene.py")
    scene = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(scene)
    points, _, _ = scene.cad_scene(n_points, rng=0)
    t0 = time.perf_counter()
    table = query_knn(points, 30)  # one table for the three steps, as the CLI's
    normals = surface_normals(points, k=20, neighbors=table)
    normals = orient_normals(points, normals, k=10, method="mst", neighbors=table)
    normals = sharpen_normals(points, normals, 20, neighbors=table)
    normals = outward_normals(points, normals, neighbors=table)
    t1 = time.perf_counter()
    res = simplify_points(points, normals, path=path)
    t2 = time.perf_counter()
    m = res.mesh
    tri = np.asarray(m.triangles)
    closed, manifold, oriented = mesh_checks(m.n_vertices, tri)
    diag = float(np.linalg.norm(np.ptp(points, axis=0)))
    return {
        "points": int(points.shape[0]),
        "path": res.path,
        "reason": res.reason,
        "faces": m.n_faces,
        "triangles": int(tri.shape[0]),
        "closed": closed,
        "manifold": manifold,
        "oriented": oriented,
        "mean_distance_pct": 100.0 * m.distance_mean / diag,
        "max_distance_pct": 100.0 * m.distance_max / diag,
        "normals_seconds": t1 - t0,
        "simplify_seconds": t2 - t1,
        "total_seconds": t2 - t0,
    }


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--scene",
        type=int,
        default=None,
        help="instead: N raw scan points of benchmarks/scene.py to a mesh (normals "
        "estimated), timed against the 60-second target",
    )
    parser.add_argument("--scene-path", default="robust", help="simplify_points path")
    parser.add_argument("--models", nargs="*", default=list(MODELS))
    parser.add_argument("--json", type=Path, default=None, help="also write rows as JSON")
    parser.add_argument(
        "--build", type=Path, default=Path(tempfile.gettempdir()) / "pointatlas-bench-cgal"
    )
    args = parser.parse_args(argv)
    if args.scene is not None:
        row = run_scene(args.scene, args.scene_path)
        for key, value in row.items():
            print(f"{key}: {value}")
        print(f"under 60 s: {row['total_seconds'] < 60.0} (machine: {os.cpu_count()} CPUs)")
        return
    rows = []
    for model in args.models:
        path = MODELS[model]
        if not path.exists():
            print(f"skipping {model}: {path} not found", file=sys.stderr)
            continue
        ps = read_point_set(path)
        mesh = read_mesh(path)
        try:
            ours, m = run_ours(ps)
        except PointAtlasError as exc:
            rows.append({"model": model, "method": "pointatlas (points only)", "note": str(exc)})
            continue
        peers = [
            run_open3d(mesh, ps.points, m.triangles.shape[0]),
            run_pymeshlab(mesh, ps.points, m.triangles.shape[0]),
            run_cgal(mesh, ps.points, m.n_faces, args.build),
        ]
        for r in [ours, *peers]:
            r["model"] = f"{model} ({ps.n_points} points)"
            rows.append(r)
    print("| model | method | triangles | closed | mean dist | max dist | time (s) | note |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        if "triangles" not in r:
            print(f"| {r['model']} | {r['method']} | - | - | - | - | - | {r['note']} |")
            continue
        print(
            f"| {r['model']} | {r['method']} | {r['triangles']} | {r['closed']} | "
            f"{r['mean_distance']:.4g} | {r['max_distance']:.4g} | {r['seconds']:.3f} | "
            f"{r['note']} |"
        )
    if args.json is not None:
        args.json.write_text(json.dumps(rows, indent=2))
    print(
        f"\nmachine: {os.cpu_count()} CPUs; distances from the original vertices "
        "(point_mesh_distance); pointatlas builds its mesh from the points alone."
    )


if __name__ == "__main__":
    main()
