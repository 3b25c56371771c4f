"""Reading a 1,000,000-point binary PLY: bare plyfile vs ``pointatlas.io.read_point_set``.

Generates two binary little-endian PLY files in a temporary folder -- x, y, z,
nx, ny, nz and one scalar field (float32), and x, y, z only -- then times, in the
same run (best of ``--repeat``, wall clock and process CPU time):

- bare: ``plyfile.PlyData.read(path)`` + ``np.column_stack`` of x, y, z;
- bare+normals: the same plus what ``read_point_set`` also delivers, done with
  plain plyfile/numpy (stack and normalise the normals, copy the scalar);
- ours: ``read_point_set(path)`` (points, unit normals, the scalar attribute, all
  validated, in a read-only PointSet).

Run: ``.venv/bin/python benchmarks/bench_io.py [--n 1000000] [--repeat 3]``
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
import plyfile

from pointatlas.io import read_point_set


def make_ply(path: Path, n: int, *, with_normals: bool = True, seed: int = 0) -> None:
    """Write a benchmark file: Gaussian points, unit normals and a scalar (optional)."""
    rng = np.random.default_rng(seed)
    pts = rng.normal(size=(n, 3))
    nrm = pts / np.linalg.norm(pts, axis=1, keepdims=True)
    names = ("x", "y", "z", "nx", "ny", "nz", "curvature") if with_normals else ("x", "y", "z")
    rec = np.empty(n, dtype=[(k, "<f4") for k in names])
    for c, k in enumerate("xyz"):
        rec[k] = pts[:, c]
        if with_normals:
            rec["n" + k] = nrm[:, c]
    if with_normals:
        rec["curvature"] = rng.random(n)
    plyfile.PlyData([plyfile.PlyElement.describe(rec, "vertex")]).write(str(path))


def bare_read(path: Path) -> np.ndarray:
    """The reference: plyfile's reader plus stacking the coordinates."""
    v = plyfile.PlyData.read(str(path))["vertex"]
    return np.column_stack([v["x"], v["y"], v["z"]])


def bare_read_normals(path: Path):
    """plyfile + numpy doing the same work as read_point_set (no validation)."""
    v = plyfile.PlyData.read(str(path))["vertex"]
    points = np.column_stack([v["x"], v["y"], v["z"]])
    normals = np.column_stack([v["nx"], v["ny"], v["nz"]]).astype(np.float64)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    return points, normals, np.array(v["curvature"])


def best_of(func, repeat: int) -> tuple[float, float]:
    """Smallest wall time and smallest process CPU time of ``repeat`` calls (seconds)."""
    wall, cpu = [], []
    for _ in range(repeat):
        w0, c0 = time.perf_counter(), time.process_time()
        func()
        wall.append(time.perf_counter() - w0)
        cpu.append(time.process_time() - c0)
    return min(wall), min(cpu)


def _row(label: str, t: tuple[float, float], ref: tuple[float, float]) -> str:
    return (
        f"  {label:<28} wall {t[0] * 1e3:7.1f} ms  cpu {t[1] * 1e3:7.1f} ms  "
        f"ratio wall {t[0] / ref[0]:5.2f}  cpu {t[1] / ref[1]:5.2f}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=1_000_000)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        full, xyz = Path(tmp) / "normals.ply", Path(tmp) / "xyz.ply"
        make_ply(full, args.n)
        make_ply(xyz, args.n, with_normals=False)
        for path in (full, xyz):  # warm the page cache and imports, check agreement
            ps = read_point_set(path)
            np.testing.assert_array_equal(ps.points, bare_read(path))
        assert ps.n_points == args.n
        results = {}
        for path in (full, xyz):
            results[path.name] = {
                "bare": best_of(lambda p=path: bare_read(p), args.repeat),
                "ours": best_of(lambda p=path: read_point_set(p), args.repeat),
            }
        results[full.name]["bare+normals"] = best_of(lambda: bare_read_normals(full), args.repeat)
    print(f"binary PLY, {args.n:,} points, best of {args.repeat}")
    print("x y z nx ny nz curvature (float32, 28 MB):")
    r = results[full.name]
    print(_row("bare plyfile + stack xyz", r["bare"], r["bare"]))
    print(_row("bare + normals + scalar", r["bare+normals"], r["bare"]))
    print(_row("pointatlas read_point_set", r["ours"], r["bare"]))
    print("x y z only (float32, 12 MB):")
    r = results[xyz.name]
    print(_row("bare plyfile + stack xyz", r["bare"], r["bare"]))
    print(_row("pointatlas read_point_set", r["ours"], r["bare"]))


if __name__ == "__main__":
    main()
