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


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=1_000_000)
    parser.add_argument("--k", type=int, default=20)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
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
