"""Normals (estimate + orient) on a 10**6-point surface sample: pointatlas vs Open3D.

Scene: a sphere, a torus and a cube (three separate components, area-uniform
random samples drawn with numpy, seeded) with exact outward normals. Times, in one
run and on the same points:

- ours: one ``query_knn(points, k)`` call, ``estimate_normals(..., neighbors=idx)``
  and ``orient_normals(..., k=k_orient, neighbors=idx)`` (default method "outward"),
  reported split into k-NN / covariance+eigen / orientation;
- Open3D: ``estimate_normals(KDTreeSearchParamKNN(k))`` +
  ``orient_normals_consistent_tangent_plane(k_orient)``.

It prints the time ratio ours / Open3D and both normal fields' mean angle errors
(oriented and unoriented) and flipped fractions against the exact normals, then
the same error comparison on bundled meshes (vertices with area-weighted vertex
normals, ``../shared/data/models``).

Run: ``.venv/bin/python benchmarks/bench_normals.py [--n 1000000] [--k 20]
[--k-orient 10] [--skip-open3d-orient-above N] [--models ...]``
"""

from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path

import numba
import numpy as np

from pointatlas.neighbors import query_knn
from pointatlas.normals import angle_error, estimate_normals, flipped_fraction, orient_normals

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "models"
MODELS = (
    "fandisk_12494.obj",
    "torus_4350.stl",
    "eight_766.off",
    "hand_open_810.obj",
    "bunny_3301.obj",
    "armadillo_14587.obj",
    "block_8771.obj",
    "sharp_sphere_10443.obj",
    "dragon_50002.ply",
    "twelve_4610.obj",
)


def scene(n: int, seed: int = 0, jitter: float = 1e-6):
    """Sphere + torus + cube, about n/3 points each, exact outward normals.

    ``jitter``: Gaussian offset along the normal (standard deviation, absolute;
    the mean spacing at 10**6 points is ~7e-3). Exactly coplanar cube faces make
    the Qhull Delaunay step inside Open3D's consistent-tangent-plane orientation
    degenerate and extremely slow (10**4 cube points: 17.5 s instead of 1.1 s).
    """
    rng = np.random.default_rng(seed)
    m = n // 3
    # sphere, radius 1 at the origin
    s = rng.normal(size=(m, 3))
    s /= np.linalg.norm(s, axis=1, keepdims=True)
    # torus (R = 1, r = 0.35) around z at x = 4, area-uniform by rejection
    big, small = 1.0, 0.35
    u = rng.uniform(0, 2 * np.pi, 3 * m)
    v = rng.uniform(0, 2 * np.pi, 3 * m)
    keep = rng.uniform(0, big + small, 3 * m) < big + small * np.cos(v)
    u, v = u[keep][:m], v[keep][:m]
    tn = np.stack([np.cos(v) * np.cos(u), np.cos(v) * np.sin(u), np.sin(v)], axis=1)
    tp = np.stack([big * np.cos(u), big * np.sin(u), np.zeros_like(u)], axis=1) + small * tn
    tp += [4.0, 0.0, 0.0]
    # cube [-1, 1]^3 at x = 8
    rest = n - 2 * m
    face = rng.integers(0, 6, rest)
    axis, sign = face // 2, np.where(face % 2 == 0, -1.0, 1.0)
    cp = rng.uniform(-1, 1, (rest, 3))
    cp[np.arange(rest), axis] = sign
    cn = np.zeros((rest, 3))
    cn[np.arange(rest), axis] = sign
    cp += [8.0, 0.0, 0.0]
    points, normals = np.vstack([s, tp, cp]), np.vstack([s, tn, cn])
    if jitter:
        points = points + normals * rng.normal(scale=jitter, size=(points.shape[0], 1))
    return points, normals


def ours(points, k, k_orient):
    t0 = time.perf_counter()
    idx, _ = query_knn(points, max(k, k_orient))
    t1 = time.perf_counter()
    est = estimate_normals(points, k, neighbors=idx)
    t2 = time.perf_counter()
    oriented = orient_normals(points, est, k=k_orient, neighbors=idx)
    t3 = time.perf_counter()
    return oriented, {"knn": t1 - t0, "estimate": t2 - t1, "orient": t3 - t2}


def open3d_normals(points, k, k_orient, orient=True):
    import open3d as o3d

    pc = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.array(points)))
    t0 = time.perf_counter()
    pc.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(k))
    t1 = time.perf_counter()
    if orient:
        pc.orient_normals_consistent_tangent_plane(k_orient)
    t2 = time.perf_counter()
    return np.asarray(pc.normals).copy(), {"estimate": t1 - t0, "orient": t2 - t1}


def errors(normals, exact):
    return (
        np.degrees(angle_error(normals, exact).mean()),
        np.degrees(angle_error(normals, exact, unoriented=True).mean()),
        flipped_fraction(normals, exact),
    )


def compare_scene(args) -> None:
    """Time ours and Open3D on the synthetic scene; print split, errors, ratio."""
    pts, exact = scene(args.n, jitter=args.jitter)
    print(
        f"scene: {pts.shape[0]} points (sphere + torus + cube, jitter {args.jitter:g}), "
        f"k = {args.k}, "
        f"k_orient = {args.k_orient}, numba threads = {numba.get_num_threads()}"
    )
    normals, t = ours(pts, args.k, args.k_orient)
    total = sum(t.values())
    e = errors(normals, exact)
    print(
        f"ours    : knn {t['knn']:.2f} s + estimate {t['estimate']:.2f} s + orient "
        f"{t['orient']:.2f} s = {total:.2f} s | mean angle {e[0]:.3f} deg "
        f"(unoriented {e[1]:.3f}), flipped {e[2]:.4f}"
    )
    do_orient = args.skip_open3d_orient_above is None or args.n <= args.skip_open3d_orient_above
    o_normals, ot = open3d_normals(pts, args.k, args.k_orient, orient=do_orient)
    o_total = ot["estimate"] + ot["orient"]
    oe = errors(o_normals, exact)
    label = "orient" if do_orient else "orient (skipped)"
    print(
        f"open3d  : estimate {ot['estimate']:.2f} s + {label} {ot['orient']:.2f} s = "
        f"{o_total:.2f} s | mean angle {oe[0]:.3f} deg (unoriented {oe[1]:.3f}), "
        f"flipped {oe[2]:.4f}"
    )
    print(f"ratio ours / open3d (estimate + orient): {total / o_total:.3f}")
    print(
        f"ratio without k-NN: {(t['estimate'] + t['orient']) / o_total:.3f}; "
        f"estimate only (ours incl. k-NN): {(t['knn'] + t['estimate']) / ot['estimate']:.3f}"
    )


class TimeNormals:
    """asv-style timings of the three stages on the seeded scene at several N."""

    params = [10_000, 100_000, 1_000_000]
    param_names = ["n"]

    def setup(self, n):
        self.points, _ = scene(n)
        self.idx, _ = query_knn(self.points, 20)
        self.normals = estimate_normals(self.points, 20, neighbors=self.idx)

    def time_knn(self, n):
        query_knn(self.points, 20)

    def time_estimate(self, n):
        estimate_normals(self.points, 20, neighbors=self.idx)

    def time_orient(self, n):
        orient_normals(self.points, self.normals, k=10, neighbors=self.idx)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=1_000_000, help="0 skips the scene")
    parser.add_argument("--k", type=int, default=20)
    parser.add_argument("--k-orient", type=int, default=10)
    parser.add_argument(
        "--skip-open3d-orient-above",
        type=int,
        default=None,
        help="time Open3D's orientation only up to this many points",
    )
    parser.add_argument("--jitter", type=float, default=1e-6)
    parser.add_argument("--models", nargs="*", default=list(MODELS))
    args = parser.parse_args()
    warnings.simplefilter("ignore", numba.NumbaWarning)  # TBB layer notice after open3d

    # JIT warm-up (kernels are cached on disk; this loads them)
    warm, _ = scene(3000)
    ours(warm, args.k, args.k_orient)

    if args.n > 0:
        compare_scene(args)
    if not args.models:
        return
    from pointatlas.io import read_point_set

    print("\nmean angle error vs mesh vertex normals, degrees: oriented (unoriented)")
    print(f"{'model':26s} {'n':>6s} | {'k':>3s} {'ours':>16s} {'open3d':>16s}")
    for name in args.models:
        path = DATA / name
        if not path.exists():
            print(f"{name:26s} missing, skipped")
            continue
        ps = read_point_set(path, zero_normals="drop")
        p, ref = np.asarray(ps.points), np.asarray(ps.normals)
        for k in (10, 20):
            mine, _ = ours(p, k, args.k_orient)
            theirs, _ = open3d_normals(p, k, args.k_orient)
            a, b = errors(mine, ref), errors(theirs, ref)
            print(
                f"{name:26s} {p.shape[0]:6d} | {k:3d} {a[0]:7.2f} ({a[1]:5.2f}) "
                f"{b[0]:7.2f} ({b[1]:5.2f})"
            )


if __name__ == "__main__":
    main()
