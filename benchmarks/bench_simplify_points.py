"""`simplify_points` on point sets sampled from the collection: how often is the mesh closed?

Run from the repository root::

    .venv/bin/python benchmarks/bench_simplify_points.py \
        --models ../shared/data/collection --every 5 --points 10000 \
        --out bench-output/simplify_points.csv

Every ``--every``-th model (sorted by name) is sampled uniformly by area with its
face normals (`pointatlas.synth.sample_mesh`, seed 0) and the points alone go through
`pointatlas.simplify.simplify_points` with default options (``path="auto"``: the
thesis path, and the robust path when that gives no closed, manifold, oriented mesh
with valid faces). One CSV row per model: path taken and why, faces, closed /
manifold / oriented, Euler characteristic of the output and of the input mesh, mean
and max distance of the points to the output (% of the bounding-box diagonal),
seconds. The summary prints the share of closed + manifold + oriented outputs, the
share with the input's Euler characteristic, and the times.
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
import warnings
from pathlib import Path

import numpy as np

from pointatlas._core import PointAtlasError
from pointatlas.io import read_mesh
from pointatlas.simplify import SimplifyWarning, mesh_checks, simplify_points
from pointatlas.synth import sample_mesh

MESH_SUFFIXES = (".obj", ".off", ".ply", ".stl")


def _euler(n_vertices: int, tri: np.ndarray) -> int:
    und = np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1)
    return int(n_vertices - np.unique(und, axis=0).shape[0] + tri.shape[0])


def run_model(path: Path, n_points: int) -> dict:
    mesh = read_mesh(path)
    tri = np.asarray(mesh.triangles, dtype=np.int64)
    used = np.unique(tri)
    euler_in = _euler(used.size, tri)
    sample = sample_mesh(mesh.vertices, tri, n_points, rng=0)
    p, n = np.asarray(sample.points), np.asarray(sample.normals)
    diag = float(np.linalg.norm(np.ptp(p, axis=0)))
    row = {"model": path.name, "points": n_points, "euler_input": euler_in}
    t0 = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", SimplifyWarning)
            r = simplify_points(p, n)
    except PointAtlasError as exc:
        row.update(seconds=time.perf_counter() - t0, path="error", reason=str(exc))
        return row
    seconds = time.perf_counter() - t0
    m = r.mesh
    closed, manifold, oriented = mesh_checks(m.n_vertices, np.asarray(m.triangles))
    row.update(
        path=r.path,
        reason=r.reason,
        faces=m.n_faces,
        vertices=m.n_vertices,
        triangles=int(np.asarray(m.triangles).shape[0]),
        closed=closed,
        manifold=manifold,
        oriented=oriented,
        euler=_euler(m.n_vertices, np.asarray(m.triangles)),
        mean_distance_pct=100.0 * m.distance_mean / diag,
        max_distance_pct=100.0 * m.distance_max / diag,
        seconds=seconds,
    )
    return row


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--models", type=Path, default=Path("../shared/data/collection"))
    ap.add_argument("--every", type=int, default=5)
    ap.add_argument("--points", type=int, default=10000)
    ap.add_argument("--out", type=Path, default=Path("bench-output/simplify_points.csv"))
    args = ap.parse_args(argv)
    files = sorted(p for p in args.models.iterdir() if p.suffix.lower() in MESH_SUFFIXES)
    files = files[:: args.every]
    rows = []
    for path in files:
        row = run_model(path, args.points)
        rows.append(row)
        print(
            f"{row['model']:40s} {row['path']:7s} faces={row.get('faces', '-')!s:>5} "
            f"closed={row.get('closed', '-')!s:5} manifold={row.get('manifold', '-')!s:5} "
            f"euler={row.get('euler', '-')!s:>3}/{row['euler_input']:<3} "
            f"mean={row.get('mean_distance_pct', float('nan')):.3f}% "
            f"{row['seconds']:.1f}s {row.get('reason', '')[:60]}",
            flush=True,
        )
    args.out.parent.mkdir(parents=True, exist_ok=True)
    keys = [
        "model", "points", "path", "faces", "vertices", "triangles", "closed", "manifold",
        "oriented", "euler", "euler_input", "mean_distance_pct", "max_distance_pct",
        "seconds", "reason",
    ]  # fmt: skip
    with open(args.out, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=keys)
        w.writeheader()
        for row in rows:
            w.writerow({k: row.get(k, "") for k in keys})
    ok = [r for r in rows if r.get("closed") and r.get("manifold") and r.get("oriented")]
    genus = [r for r in ok if r["euler"] == r["euler_input"]]
    secs = np.array([r["seconds"] for r in rows])
    robust = sum(r["path"] == "robust" for r in rows)
    print(
        f"\n{len(rows)} models, {args.points} points each: closed+manifold+oriented "
        f"{len(ok)}/{len(rows)} ({100.0 * len(ok) / len(rows):.1f} %), with the input's "
        f"Euler characteristic {len(genus)}/{len(rows)}; robust path {robust}, thesis path "
        f"{sum(r['path'] == 'thesis' for r in rows)}, errors "
        f"{sum(r['path'] == 'error' for r in rows)}; seconds median {np.median(secs):.1f}, "
        f"max {secs.max():.1f}, total {secs.sum():.0f}"
    )
    print(f"written: {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
