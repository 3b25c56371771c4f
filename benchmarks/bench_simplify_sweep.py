"""`pointatlas simplify` on a whole collection with default options, CGAL VSA beside it.

Run from the repository root::

    .venv/bin/python benchmarks/bench_simplify_sweep.py \
        --models ../shared/data/collection --out bench-output/simplify_sweep [--cgal 1]

Every model goes through the same code as ``pointatlas simplify MODEL OUT.obj`` with
default options (a mesh input takes the mesh path: `decimate_mesh`, the fewest
triangles within 0.5 % of the diagonal both ways; ``--regions``: `simplify_mesh`, one
face per region). One CSV row per model: faces, polygons, triangles (and the share of
the input's kept), vertices, closed / manifold / oriented, Euler characteristic, faces
that kept their input triangles, mean and max distance of the input vertices to the
output and the two-sided Hausdorff distance (% of the bounding-box diagonal), largest
polygon planarity error, triangles of zero area (at most 1e-12 of the diagonal
squared), seconds, path taken. With ``--cgal K`` every K-th model is
also given to CGAL's ``Surface_mesh_approximation`` (benchmarks/cgal_vsa.cpp,
compiled with Debian's libcgal-dev, see bench_simplify.py) with as many proxies as
our output has faces, and its output is measured the same way (one metric for all:
`pointatlas.simplify.point_mesh_distance`); the summary prints the ratio of mean
distances (ours / CGAL's) and how often each output is a closed manifold. With
``--soup`` every model is given as a triangle soup (each triangle its own three
vertices, as an STL or a flat-shaded export writes it): the input checks stay those of
the indexed file.
"""

from __future__ import annotations

import argparse
import csv
import importlib.util
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from bench_simplify_rd import zero_area_triangles

from pointatlas.io import read_mesh
from pointatlas.simplify import SimplifyWarning, decimate_mesh, mesh_checks, simplify_mesh

HERE = Path(__file__).resolve().parent
MESH_SUFFIXES = (".obj", ".off", ".ply", ".stl")


def _bench_simplify():
    spec = importlib.util.spec_from_file_location("bench_simplify", HERE / "bench_simplify.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def as_soup(vertices, triangles):
    """Every triangle with its own three vertices, as an STL export or a flat-shaded
    PLY / OBJ gives them (``--soup``)."""
    v = np.asarray(vertices)[np.asarray(triangles).reshape(-1)]
    return v, np.arange(v.shape[0], dtype=np.int64).reshape(-1, 3)


def run_ours(mesh, soup: bool = False, regions: bool = False) -> dict:
    v, tri = mesh.vertices, mesh.triangles
    if soup:
        v, tri = as_soup(v, tri)
    diag = float(np.linalg.norm(v.max(axis=0) - v.min(axis=0)))
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SimplifyWarning)  # the repairs of a soup
        res = simplify_mesh(v, tri) if regions else decimate_mesh(v, tri)
    seconds = time.perf_counter() - t0
    return {
        "faces": res.n_faces,
        "polygons": len(res.polygons),
        "triangles": len(res.triangles),
        "triangles_kept_pct": 100.0 * len(res.triangles) / max(len(tri), 1),
        "vertices": res.n_vertices,
        "closed": res.is_closed,
        "manifold": res.is_manifold,
        "oriented": res.is_oriented,
        "euler": res.euler_characteristic,
        "faces_kept_as_input": int(res.face_kept_input.sum()),
        "mean_distance_pct": 100.0 * res.distance_mean / diag,
        "max_distance_pct": 100.0 * res.distance_max / diag,
        "hausdorff_pct": 100.0 * max(res.distance_max, res.back_distance_max) / diag,
        "max_polygon_planarity_pct": 100.0 * float(res.polygon_planarity.max(initial=0.0)) / diag,
        "max_planarity_pct": 100.0 * float(res.planarity_error.max(initial=0.0)) / diag,
        "flat_faces": int(res.face_flat.sum()),
        "flat_faces_bent": int((res.planarity_error[res.face_flat] > 1e-6 * diag).sum()),
        "max_flat_planarity_pct": 100.0
        * float(res.planarity_error[res.face_flat].max(initial=0.0))
        / diag,
        "degenerate": zero_area_triangles(res.vertices, res.triangles, diag),
        "seconds": seconds,
        "path": "regions" if regions else "decimate",
    }


def run_cgal(bench, mesh, n_proxies: int, build_dir: Path) -> dict:
    """CGAL VSA with ``n_proxies``; its output checked and measured as ours."""
    import subprocess
    import tempfile

    from pointatlas.io import write_mesh
    from pointatlas.simplify import point_mesh_distance

    exe, why = bench._cgal_binary(build_dir)
    if exe is None:
        return {"cgal_note": why}
    v = mesh.vertices
    diag = float(np.linalg.norm(v.max(axis=0) - v.min(axis=0)))
    with tempfile.TemporaryDirectory() as tmp:
        src = write_mesh(Path(tmp) / "in.off", v, mesh.triangles)
        dst = Path(tmp) / "out.off"
        res = subprocess.run(
            [str(exe), str(src), str(dst), str(int(n_proxies))],
            capture_output=True,
            text=True,
            timeout=1200,
        )
        if res.returncode != 0:
            return {"cgal_note": f"failed: {res.stderr.strip()[:200]}"}
        seconds, _ = res.stdout.split()
        out = read_mesh(dst)
    tri = out.triangles
    if tri.shape[0] == 0:
        return {"cgal_note": "no triangles"}
    closed, manifold, oriented = mesh_checks(out.n_vertices, tri)
    d = point_mesh_distance(v, out.vertices, tri)
    return {
        "cgal_faces": int(n_proxies),
        "cgal_mean_distance_pct": 100.0 * float(d.mean()) / diag,
        "cgal_max_distance_pct": 100.0 * float(d.max()) / diag,
        "cgal_closed": closed,
        "cgal_manifold": manifold and closed and oriented,
        "cgal_seconds": float(seconds),
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", type=Path, default=HERE.parent / "../shared/data/collection")
    parser.add_argument("--out", type=Path, default=Path("bench-output/simplify_sweep"))
    parser.add_argument("--cgal", type=int, default=0, help="every K-th model also to CGAL")
    parser.add_argument("--limit", type=int, default=0, help="only the first N models")
    parser.add_argument(
        "--soup",
        action="store_true",
        help="give every model as a triangle soup (each triangle its own "
        "three vertices, as STL and flat-shaded exports)",
    )
    parser.add_argument("--regions", action="store_true", help="one face per VSA region")
    args = parser.parse_args(argv)
    files = sorted(p for p in args.models.iterdir() if p.suffix.lower() in MESH_SUFFIXES)
    if args.limit:
        files = files[: args.limit]
    if not files:
        print(f"no meshes in {args.models}", file=sys.stderr)
        return 1
    args.out.mkdir(parents=True, exist_ok=True)
    bench = _bench_simplify() if args.cgal else None
    rows = []
    for i, path in enumerate(files):
        mesh = read_mesh(path)
        row = {"model": path.name, "input_faces": mesh.n_faces}
        row["input_closed_manifold"] = all(mesh_checks(mesh.n_vertices, mesh.triangles))
        row.update(run_ours(mesh, soup=args.soup, regions=args.regions))
        if args.cgal and i % args.cgal == 0:
            row.update(run_cgal(bench, mesh, row["faces"], args.out.parent / "cgal-build"))
        rows.append(row)
        print(
            f"{i + 1:3d}/{len(files)} {path.name:45s} {row['faces']:5d} faces "
            f"closed+manifold+oriented={row['closed'] and row['manifold'] and row['oriented']} "
            f"tri {row['triangles_kept_pct']:.1f} % H {row['hausdorff_pct']:.3f} % "
            f"{row['seconds']:.2f} s"
            + (
                f" | CGAL mean {row['cgal_mean_distance_pct']:.3f} % "
                f"closed+manifold+oriented={row['cgal_manifold']}"
                if "cgal_mean_distance_pct" in row
                else ""
            ),
            flush=True,
        )
    fields = sorted(
        {k for r in rows for k in r}, key=lambda k: list(rows[0]).index(k) if k in rows[0] else 99
    )
    with open(args.out / "sweep.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=fields, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
    closed_in = [r for r in rows if r["input_closed_manifold"]]
    good = [r for r in closed_in if r["closed"] and r["manifold"] and r["oriented"]]
    planar = [r for r in good if r["faces_kept_as_input"] == 0]
    seconds = np.array([r["seconds"] for r in rows])
    print(f"models: {len(rows)}, closed manifold inputs: {len(closed_in)}")
    print(
        f"closed + manifold + oriented outputs: {len(good)} / {len(closed_in)} "
        f"({100.0 * len(good) / max(len(closed_in), 1):.1f} %); of them every face a "
        f"planar polygon (none kept as input triangles): {len(planar)}"
    )
    kept = np.array([r["triangles_kept_pct"] for r in rows])
    print(
        f"faces median {np.median([r['faces'] for r in rows]):.0f}, triangles kept: "
        f"geometric mean {np.exp(np.mean(np.log(kept))):.1f} % of the input's; mean "
        f"distance median {np.median([r['mean_distance_pct'] for r in rows]):.3f} %, "
        f"Hausdorff (both ways) median {np.median([r['hausdorff_pct'] for r in rows]):.3f} %,"
        f" max {max(r['hausdorff_pct'] for r in rows):.3f} % of the diagonal; largest "
        f"polygon planarity error {max(r['max_polygon_planarity_pct'] for r in rows):.2g} %"
    )
    flat = sum(r["flat_faces"] for r in rows)
    bent = [r for r in rows if r["flat_faces_bent"]]
    print(
        f"faces of flat regions: {flat}, planar within 1e-6 of the diagonal: "
        f"{flat - sum(r['flat_faces_bent'] for r in bent)}; models with a bent one: "
        f"{len(bent)}, largest {max(r['max_flat_planarity_pct'] for r in rows):.2g} % "
        f"({max(rows, key=lambda r: r['max_flat_planarity_pct'])['model']})"
    )
    print(
        f"outputs with a zero-area triangle (<= 1e-12 of the diagonal squared): "
        f"{sum(r['degenerate'] > 0 for r in rows)}, {sum(r['degenerate'] for r in rows)} in all"
    )
    print(
        f"time: median {np.median(seconds):.2f} s, max {seconds.max():.2f} s, "
        f"total {seconds.sum():.1f} s"
    )
    both = [r for r in rows if "cgal_mean_distance_pct" in r]
    if both:
        n_ours = sum(r["manifold"] for r in both)
        n_cgal = sum(bool(r["cgal_manifold"]) for r in both)
        ratio = np.array([r["mean_distance_pct"] / r["cgal_mean_distance_pct"] for r in both])
        print(
            f"CGAL VSA at the same face count on {len(both)} models: mean distance ours / "
            f"CGAL median {np.median(ratio):.2f}x (max {ratio.max():.2f}x, <= 1 on "
            f"{int((ratio <= 1.0).sum())}); closed manifold oriented outputs: ours "
            f"{n_ours}, CGAL {n_cgal}"
        )
    print(f"table: {args.out / 'sweep.csv'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
