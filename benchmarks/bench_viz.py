"""Rendering speed of ``pointatlas.viz``: point clouds up to 1e6 points, meshes.

A seeded torus sample (uniform in its two angles, exact normals) is rendered to a
1024 x 1024 PNG shaded by normals, coloured by a scalar field (with colour bar)
and plain; a triangulated torus mesh is rendered with polygon edges. Times include
everything (spacing estimate, z-buffer, matplotlib composition, PNG encoding).

Run: ``.venv/bin/python benchmarks/bench_viz.py [--n 1000000] [--repeat 3]``
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from pointatlas.viz import render_mesh, render_points, render_points_array


def torus_sample(n: int, seed: int = 0):
    """n points on a torus (R = 1, r = 0.35, y up) with exact normals."""
    rng = np.random.default_rng(seed)
    u, v = rng.random(n) * 2 * np.pi, rng.random(n) * 2 * np.pi
    big, small = 1.0, 0.35
    ring = big + small * np.cos(v)
    pts = np.stack([ring * np.cos(u), small * np.sin(v), ring * np.sin(u)], axis=1)
    nrm = np.stack([np.cos(v) * np.cos(u), np.sin(v), np.cos(v) * np.sin(u)], axis=1)
    return pts, nrm


def torus_mesh(n_u: int, n_v: int):
    """A triangulated torus grid with 2 n_u n_v faces."""
    u = np.linspace(0, 2 * np.pi, n_u, endpoint=False)
    v = np.linspace(0, 2 * np.pi, n_v, endpoint=False)
    uu, vv = np.meshgrid(u, v, indexing="ij")
    ring = 1.0 + 0.35 * np.cos(vv)
    verts = np.stack([ring * np.cos(uu), 0.35 * np.sin(vv), ring * np.sin(uu)], -1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(n_u), np.arange(n_v), indexing="ij")
    a = i * n_v + j
    b = ((i + 1) % n_u) * n_v + j
    c = ((i + 1) % n_u) * n_v + (j + 1) % n_v
    d = i * n_v + (j + 1) % n_v
    faces = np.concatenate([np.stack([a, b, c], -1), np.stack([a, c, d], -1)]).reshape(-1, 3)
    return verts, faces


def best_of(repeat: int, func) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        func()
        times.append(time.perf_counter() - t0)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=1_000_000)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    render_points_array(np.eye(3), size=(32, 32))  # imports, font cache
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        for n in sorted({10_000, 100_000, args.n}):
            pts, nrm = torus_sample(n)
            cases = {
                "normals": {"normals": nrm},
                "scalars": {"scalars": pts[:, 1], "scalar_name": "y"},
                "plain": {},
            }
            for label, kw in cases.items():
                seconds = best_of(
                    args.repeat,
                    lambda kw=kw, label=label, pts=pts: render_points(
                        out / f"{label}.png", pts, title=label, **kw
                    ),
                )
                print(f"points  N={n:>9,}  {label:8s} {seconds:6.2f} s")
        for n_u, n_v in ((100, 50), (250, 200)):
            verts, faces = torus_mesh(n_u, n_v)
            seconds = best_of(
                args.repeat, lambda v=verts, f=faces: render_mesh(out / "m.png", v, f)
            )
            print(f"mesh    F={len(faces):>9,}  edges    {seconds:6.2f} s")


if __name__ == "__main__":
    main()
