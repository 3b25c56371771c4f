"""How often a ball cover (Algorithm 2, Prop. 4) gives a closed cloud surface on a
whole folder of meshes: the vertices, and a uniform sample of the surface.

Run from the repository root::

    .venv/bin/python benchmarks/bench_cover_sweep.py --models ../shared/data/collection \
        [--sample 20000] [--rotations 3] [--offsets 2]

Every mesh of the folder (OBJ, OFF, PLY, STL) is read; its point set is the vertices
(``--sample 0``) or ``--sample N`` points drawn uniformly by area (seed 0). The scale
search tries ``--scales`` grid scales spaced geometrically from ``--smin`` to
``--smax`` times the bounding-box diagonal, each with the identity and ``--rotations``
seeded rotations, each with offset 0 and ``--offsets`` seeded lattice offsets
(`pointatlas.cover.search_cover_scale`, accept="closed"). One row per model: the
smallest accepted scale (relative to the diagonal), how many settings were accepted,
the share of points the best setting leaves unsupported, seconds. The summary prints
how many models have at least one closed cloud surface.
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
from pathlib import Path

import numpy as np

from pointatlas.cover import search_cover_scale
from pointatlas.io import read_mesh
from pointatlas.synth import sample_mesh

MESH_SUFFIXES = (".obj", ".off", ".ply", ".stl")


def sweep_model(points: np.ndarray, rel_scales: np.ndarray, rotations: int, offsets: int):
    """The search on one point set; a dict of the row's numbers."""
    diag = float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)))
    t0 = time.perf_counter()
    res = search_cover_scale(
        points, rel_scales * diag, n_rotations=rotations, n_offsets=offsets, rng=0, accept="closed"
    )
    seconds = time.perf_counter() - t0
    ok = np.asarray(res.is_accepted)
    rel = np.asarray(res.scales) / diag
    pick = res.chosen
    return {
        "points": points.shape[0],
        "accepted_settings": int(ok.sum()),
        "settings": int(ok.size),
        "smallest_accepted_rel_scale": float(rel[ok].min()) if ok.any() else "",
        "best_unsupported_share": float(res.n_unsupported[pick]) / points.shape[0],
        "best_clouds": int(res.n_clouds[pick]),
        "seconds": round(seconds, 3),
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--models", type=Path, default=Path("../shared/data/collection"))
    ap.add_argument("--out", type=Path, default=Path("bench-output/cover_sweep.csv"))
    ap.add_argument("--sample", type=int, default=0, help="points per model (0: vertices)")
    ap.add_argument("--smin", type=float, default=0.04)
    ap.add_argument("--smax", type=float, default=0.5)
    ap.add_argument("--scales", type=int, default=16)
    ap.add_argument("--rotations", type=int, default=3)
    ap.add_argument("--offsets", type=int, default=0)
    ap.add_argument("--limit", type=int, default=0, help="only the first N models")
    args = ap.parse_args(argv)
    files = sorted(p for p in args.models.iterdir() if p.suffix.lower() in MESH_SUFFIXES)
    files = files[: args.limit] if args.limit else files
    if not files:
        print(f"no meshes in {args.models}", file=sys.stderr)
        return 1
    rel = np.geomspace(args.smin, args.smax, args.scales)
    rows = []
    for i, path in enumerate(files):
        mesh = read_mesh(path)
        if args.sample:
            pts = sample_mesh(mesh.vertices, mesh.triangles, args.sample, rng=0).points
        else:
            pts = np.asarray(mesh.vertices, dtype=np.float64)
        row = {"model": path.name, **sweep_model(pts, rel, args.rotations, args.offsets)}
        rows.append(row)
        print(
            f"{i + 1:3d}/{len(files)} {path.name:40s} accepted {row['accepted_settings']:3d}"
            f"/{row['settings']} smallest s/diag {row['smallest_accepted_rel_scale']}"
            f" unsupported {row['best_unsupported_share']:.3f}",
            flush=True,
        )
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with open(args.out, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    hit = [r for r in rows if r["accepted_settings"]]
    secs = np.array([r["seconds"] for r in rows])
    print(
        f"models with a closed cloud surface: {len(hit)} / {len(rows)} "
        f"(scales {args.smin:g}-{args.smax:g} x diagonal, {args.scales} scales, "
        f"{args.rotations} rotations, {args.offsets} offsets; "
        f"{'vertices' if not args.sample else f'{args.sample} samples'})"
    )
    print(
        f"median unsupported share of the best setting: "
        f"{np.median([r['best_unsupported_share'] for r in rows]):.3f}; "
        f"time median {np.median(secs):.2f} s, total {secs.sum():.1f} s"
    )
    print(f"table: {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
