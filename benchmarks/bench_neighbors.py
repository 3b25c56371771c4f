"""k-NN benchmark: pointatlas.neighbors.query_knn against the usual peers.

Run from the repository root (after ``pip install -e .[bench]``)::

    .venv/bin/python benchmarks/bench_neighbors.py [--n 1000000] [--k 20] [--repeat 3]

Two seeded clouds of N points: uniform in the unit cube, and a surface sample
(half on a unit sphere, half on a plane through it). Each method is timed best
of ``--repeat`` after one warm-up call (JIT compile, page faults) and gets the
same float64 points (float32 for pgeof, which requires it). Peers that fail to
import are reported as "not installed". The table lists seconds and the ratio to
the fastest peer. Also provides asv-style ``TimeKnn`` classes (``setup``,
``time_*``) at several N.

CPU time per point (``--cpu``; run with ``NUMBA_NUM_THREADS=1``): user + sys seconds
of ``NeighborIndex(p).knn(k)`` beside scipy ``cKDTree`` (build + query, workers=1) and
Open3D ``KDTreeFlann`` (build + one ``search_knn_vector_3d`` per point), least of
``--repeat``, on the synthetic lidar scan of ``bench_scale.py`` (``--lidar N``, read
back from its LAZ, millimetre coordinates) and on mesh vertices (``--model PATH``)::

    NUMBA_NUM_THREADS=1 .venv/bin/python benchmarks/bench_neighbors.py --cpu \
        --lidar 1000000 --k 20
    NUMBA_NUM_THREADS=1 .venv/bin/python benchmarks/bench_neighbors.py --cpu --k 48 \
        --model ../shared/data/models/fandisk_6475.obj
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from pointatlas.neighbors import knn_graph, query_knn, query_radius


def uniform_cube(n: int, seed: int = 0) -> np.ndarray:
    """n seeded uniform points in the unit cube."""
    return np.random.default_rng(seed).random((n, 3))


def sphere_and_plane(n: int, seed: int = 0) -> np.ndarray:
    """n seeded points: half on the unit sphere, half on the plane z = 0.3."""
    rng = np.random.default_rng(seed)
    m = n // 2
    v = rng.normal(size=(m, 3))
    sphere = v / np.linalg.norm(v, axis=1, keepdims=True)
    plane = np.c_[rng.uniform(-2.0, 2.0, size=(n - m, 2)), np.full(n - m, 0.3)]
    return np.concatenate([sphere, plane])


def _peers(k: int):
    """Name -> (prepare(points) -> state, run(state)) for every importable peer."""
    peers = {}
    try:
        from scipy.spatial import cKDTree

        peers["scipy cKDTree (workers=-1)"] = (
            lambda p: p,
            lambda p: cKDTree(p).query(p, k=k, workers=-1),
        )
    except ImportError:
        peers["scipy cKDTree (workers=-1)"] = None
    try:
        from pykdtree.kdtree import KDTree

        peers["pykdtree"] = (lambda p: p, lambda p: KDTree(p).query(p, k=k))
    except ImportError:
        peers["pykdtree"] = None
    try:
        import pgeof

        peers["pgeof knn_search (float32)"] = (
            lambda p: np.ascontiguousarray(p, dtype=np.float32),
            lambda p: pgeof.knn_search(p, p, k),
        )
    except ImportError:
        peers["pgeof knn_search (float32)"] = None
    try:
        import open3d as o3d
        import open3d.core as o3c

        def o3d_prepare(p):
            return o3c.Tensor.from_numpy(np.ascontiguousarray(p))

        def o3d_run(t):
            nns = o3c.nns.NearestNeighborSearch(t)
            nns.knn_index()
            return nns.knn_search(t, k)

        peers[f"Open3D {o3d.__version__} core.nns knn_search"] = (o3d_prepare, o3d_run)
    except ImportError:
        peers["Open3D core.nns knn_search"] = None
    return peers


def _best_of(run, state, repeat: int) -> float:
    run(state)  # warm-up: JIT compile, first-touch page faults
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        run(state)
        best = min(best, time.perf_counter() - t0)
    return best


def compare(points: np.ndarray, k: int, repeat: int) -> dict[str, float | None]:
    """Best-of-``repeat`` seconds for ours and every peer on ``points``."""
    times: dict[str, float | None] = {
        "pointatlas query_knn": _best_of(lambda p: query_knn(p, k), points, repeat)
    }
    for name, peer in _peers(k).items():
        if peer is None:
            times[name] = None
            continue
        prepare, run = peer
        times[name] = _best_of(run, prepare(points), repeat)
    return times


def _table(title: str, times: dict[str, float | None]) -> str:
    peers = {k: v for k, v in times.items() if k != "pointatlas query_knn" and v is not None}
    fastest = min(peers.values()) if peers else None
    lines = [f"### {title}", "", "| method | best time [s] | ratio to ours |", "|---|---:|---:|"]
    ours = times["pointatlas query_knn"]
    for name, t in times.items():
        if t is None:
            lines.append(f"| {name} | not installed | |")
        else:
            lines.append(f"| {name} | {t:.3f} | {t / ours:.2f} |")
    if fastest is not None:
        lines += ["", f"ours / fastest peer = {ours / fastest:.3f}"]
    return "\n".join(lines)


def lidar_scan(n: int, seed: int = 0) -> np.ndarray:
    """The synthetic lidar scan of ``bench_scale.py`` (about n points), as read back
    from its LAZ (millimetre coordinates, UTM-like offsets)."""
    import sys
    import tempfile
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).parent))
    from bench_scale import generate_scan

    from pointatlas.io import read_point_set

    with tempfile.TemporaryDirectory() as tmp:
        path = generate_scan(Path(tmp) / "scan.laz", n, seed)
        return np.asarray(read_point_set(path, with_normals=False).points)


def _cpu_best(run, repeat: int) -> float:
    run()  # warm-up
    best = np.inf
    for _ in range(repeat):
        t0 = time.process_time()
        run()
        best = min(best, time.process_time() - t0)
    return best


def cpu_compare(points: np.ndarray, k: int, repeat: int, *, flann: bool) -> dict:
    """CPU seconds (user + sys, least of ``repeat``) of ours, cKDTree (workers=1) and,
    with ``flann``, Open3D's KDTreeFlann, all from the points (index build included)."""
    from scipy.spatial import cKDTree

    from pointatlas.neighbors import NeighborIndex

    centred = points - 0.5 * (points.min(axis=0) + points.max(axis=0))
    times = {
        "pointatlas NeighborIndex.knn": _cpu_best(lambda: NeighborIndex(points).knn(k), repeat),
        "scipy cKDTree (workers=1)": _cpu_best(
            lambda: cKDTree(centred).query(centred, k=k, workers=1), repeat
        ),
    }
    if flann:
        try:
            import open3d as o3d
        except ImportError:
            times["Open3D KDTreeFlann"] = None
        else:

            def run_flann():
                pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(centred))
                tree = o3d.geometry.KDTreeFlann(pcd)
                for q in centred:
                    tree.search_knn_vector_3d(q, k)

            times[f"Open3D {o3d.__version__} KDTreeFlann"] = _cpu_best(run_flann, repeat)
    return times


def _cpu_table(title: str, n: int, times: dict) -> str:
    ours = times["pointatlas NeighborIndex.knn"]
    lines = [
        f"### {title}",
        "",
        "| method | CPU s | us per point | points per CPU-s | time / ours |",
        "|---|---:|---:|---:|---:|",
    ]
    for name, t in times.items():
        if t is None:
            lines.append(f"| {name} | not installed | | | |")
        else:
            lines.append(
                f"| {name} | {t:.4f} | {t / n * 1e6:.2f} | {n / t:,.0f} | {t / ours:.2f} |"
            )
    return "\n".join(lines)


def main_cpu(args) -> None:
    """The ``--cpu`` tables."""
    import numba

    print(
        f"CPU time, k = {args.k}, least of {args.repeat}; numba threads "
        f"{numba.get_num_threads()}, load average {os.getloadavg()}"
    )
    cases = []
    if args.lidar:
        cases.append(
            (f"synthetic lidar scan (bench_scale), N = {args.lidar}", lidar_scan(args.lidar))
        )
    for path in args.model or []:
        from pointatlas.io import read_point_set

        cases.append(
            (f"{path} vertices", np.asarray(read_point_set(path, with_normals=False).points))
        )
    for title, pts in cases:
        times = cpu_compare(pts, args.k, args.repeat, flann=len(pts) <= 200_000)
        print()
        print(_cpu_table(f"{title} ({len(pts)} points), k = {args.k}", len(pts), times))
    print(f"\nload average after: {os.getloadavg()}")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=1_000_000)
    parser.add_argument("--k", type=int, default=20)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--cpu", action="store_true", help="CPU time per point (see above).")
    parser.add_argument("--lidar", type=int, default=0, help="--cpu: the lidar scan's N.")
    parser.add_argument("--model", action="append", help="--cpu: mesh or point file (repeatable).")
    args = parser.parse_args(argv)
    if args.cpu:
        main_cpu(args)
        return
    import numba

    print(
        f"N = {args.n}, k = {args.k}, best of {args.repeat}; cpu count {os.cpu_count()}, "
        f"numba threads {numba.get_num_threads()}, load average {os.getloadavg()}"
    )
    for title, maker in (("uniform unit cube", uniform_cube), ("sphere + plane", sphere_and_plane)):
        pts = maker(args.n, args.seed)
        print()
        print(_table(f"{title}, N = {args.n}, k = {args.k}", compare(pts, args.k, args.repeat)))
    print(f"\nload average after: {os.getloadavg()}")


class TimeKnn:
    """asv-style: query_knn, query_radius and knn_graph at several N."""

    params = ([10_000, 100_000, 1_000_000], ["uniform", "surface"])
    param_names = ["n", "cloud"]

    def setup(self, n, cloud):
        maker = uniform_cube if cloud == "uniform" else sphere_and_plane
        self.points = maker(n)
        self.radius = 2.0 * (20.0 / n) ** (1.0 / 3.0) if cloud == "uniform" else 4.0 / n**0.5
        query_knn(self.points[:1000], 20)

    def time_query_knn_k20(self, n, cloud):
        query_knn(self.points, 20)

    def time_query_radius(self, n, cloud):
        query_radius(self.points, self.radius)

    def time_knn_graph_k10(self, n, cloud):
        knn_graph(self.points, 10)


if __name__ == "__main__":
    main()
