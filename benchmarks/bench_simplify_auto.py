"""``simplify_points(path="auto")`` on small inputs: how often the thesis path's mesh is
kept, what the attempt costs, and whether its cleaned complex predicts the outcome.

    nice -n 5 .venv/bin/python benchmarks/bench_simplify_auto.py \
        --models ../shared/data/collection --every 25 --sizes 2000 8000 16000

Inputs: every bundled model with normals (`pointatlas.data`), and every ``--every``-th
collection model sampled uniformly by area (`synth.sample_mesh`, seed 0, face
normals) with each of ``--sizes`` points. Per input: the path taken and why, seconds
(process time, one numba thread is up to the caller) of the whole run and of the
thesis attempt (`_thesis_mesh`: the complex, its repair, the vertex fit, the faces),
and the edges of the cleaned complex's region cycles shared by 1 (boundary) or by
3 or more cycles (non-manifold whatever the geometry). CSV to ``--out``.
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
import warnings
from pathlib import Path

import numpy as np

import pointatlas.simplify._pipeline as pipeline
import pointatlas.simplify._segmentation as segmentation
from pointatlas import data
from pointatlas.io import read_mesh
from pointatlas.simplify import SimplifyWarning, simplify_points
from pointatlas.synth import sample_mesh

MESH_SUFFIXES = (".obj", ".off", ".ply", ".stl")
FIELDS = [
    "input",
    "points",
    "path",
    "seconds",
    "thesis_seconds",
    "regions",
    "faces",
    "cycle_boundary_edges",
    "cycle_nonmanifold_edges",
    "reason",
]


class _Probe:
    """Times `_thesis_mesh` and keeps the last cleaned complex (wrapping the private
    steps of the pipeline for this measurement only)."""

    def __init__(self):
        self.thesis_seconds = 0.0
        self.complex = None
        self._thesis, self._clean = pipeline._thesis_mesh, segmentation.clean_regions

    def __enter__(self):
        def thesis(*a, **kw):
            t0 = time.process_time()
            try:
                return self._thesis(*a, **kw)
            finally:
                self.thesis_seconds += time.process_time() - t0

        def clean(*a, **kw):
            out = self._clean(*a, **kw)
            self.complex = out.surface_complex
            return out

        pipeline._thesis_mesh, segmentation.clean_regions = thesis, clean
        return self

    def __exit__(self, *exc):
        pipeline._thesis_mesh, segmentation.clean_regions = self._thesis, self._clean


def cycle_edge_counts(cplx) -> tuple[int, int]:
    """(edges in one region cycle, edges in three or more) of a surface complex."""
    edges = []
    for cyc_ids in cplx.region_cycles:
        for c in cyc_ids:
            lp = np.asarray(cplx.cycles[c], dtype=np.int64)
            if lp.size >= 3:
                edges.append(np.sort(np.stack([lp, np.roll(lp, -1)], axis=1), axis=1))
    if not edges:
        return 0, 0
    _, counts = np.unique(np.concatenate(edges), axis=0, return_counts=True)
    return int((counts == 1).sum()), int((counts >= 3).sum())


def run(name: str, points, normals) -> dict:
    row = {"input": name, "points": int(points.shape[0])}
    with _Probe() as probe, warnings.catch_warnings():
        warnings.simplefilter("ignore", SimplifyWarning)
        t0 = time.process_time()
        try:
            r = simplify_points(points, normals)
        except Exception as exc:  # noqa: BLE001 - a failure is a result here
            row.update(path="error", reason=repr(exc)[:120])
            return row
        row["seconds"] = round(time.process_time() - t0, 2)
    row["thesis_seconds"] = round(probe.thesis_seconds, 2)
    regions = int(np.max(r.segmentation.labels)) + 1 if r.segmentation is not None else 0
    row.update(path=r.path, reason=r.reason[:120], regions=regions, faces=r.mesh.n_faces)
    if probe.complex is not None:
        row["cycle_boundary_edges"], row["cycle_nonmanifold_edges"] = cycle_edge_counts(
            probe.complex
        )
    return row


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--models", type=Path, default=Path("../shared/data/collection"))
    ap.add_argument("--every", type=int, default=25)
    ap.add_argument("--sizes", type=int, nargs="+", default=[2000, 8000, 16000])
    ap.add_argument("--no-bundled", action="store_true")
    ap.add_argument("--out", type=Path, default=Path("bench-output/simplify_auto.csv"))
    args = ap.parse_args(argv)
    inputs = []
    if not args.no_bundled:
        for name in data.names():
            ps = data.load(name)
            if ps.has_normals and ps.n_points <= pipeline.AUTO_THESIS_POINTS:
                inputs.append((name, lambda ps=ps: (ps.points, ps.normals)))
    files = sorted(p for p in args.models.iterdir() if p.suffix.lower() in MESH_SUFFIXES)
    for path in files[:: args.every]:
        for n in args.sizes:

            def sampled(path=path, n=n):
                mesh = read_mesh(path)
                s = sample_mesh(mesh.vertices, np.asarray(mesh.triangles), n, rng=0)
                return np.asarray(s.points), np.asarray(s.normals)

            inputs.append((f"{path.name}@{n}", sampled))
    rows = []
    for name, load in inputs:
        p, n = load()
        row = run(name, np.asarray(p, dtype=np.float64), np.asarray(n, dtype=np.float64))
        rows.append(row)
        print(
            f"{name:42s} {row.get('path', ''):7s} {row.get('regions', 0):5d} regions "
            f"{row.get('seconds', 0):7.1f}s "
            f"thesis {row.get('thesis_seconds', 0):6.1f}s "
            f"cycles 1:{row.get('cycle_boundary_edges', '-')} "
            f">=3:{row.get('cycle_nonmanifold_edges', '-')}  {row.get('reason', '')[:60]}",
            flush=True,
        )
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with args.out.open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=FIELDS, restval="")
        w.writeheader()
        w.writerows(rows)
    kept = [r for r in rows if r.get("path") == "thesis"]
    thesis_s = sum(r.get("thesis_seconds", 0.0) for r in rows)
    wasted = sum(r.get("thesis_seconds", 0.0) for r in rows if r.get("path") != "thesis")
    total = sum(r.get("seconds", 0.0) for r in rows)
    print(
        f"\n{len(rows)} inputs: thesis mesh kept on {len(kept)} "
        f"({', '.join(r['input'] for r in kept)}); thesis attempts {thesis_s:.0f} s of "
        f"{total:.0f} s, of which {wasted:.0f} s on meshes not kept"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
