"""Benchmark of pointatlas.features against pgeof 0.3.4 and jakteristics 0.6.2.

Run (the ``bench`` extra installed)::

    .venv/bin/python benchmarks/bench_features.py --n 1000000 --repeat 3

Timings are the best of ``--repeat`` runs, peers timed in the same process on the
same seeded cloud (points on a torus with exact normals). Peak memory is the
largest numpy allocation footprint (tracemalloc) during each of our calls. The
asv-style ``FeaturesSuite`` (``setup``/``time_*``) is used by the runner below.
"""

from __future__ import annotations

import argparse
import gc
import math
import sys
import time
import tracemalloc

import numpy as np

from pointatlas.features import covariance_features, optimal_k_features, optimal_neighborhood
from pointatlas.neighbors import query_knn


def torus_cloud(n: int, *, seed: int = 0, big_r: float = 1.0, small_r: float = 0.3):
    """``n`` points uniformly on a torus (by area) with exact outward normals."""
    rng = np.random.default_rng(seed)
    u = rng.random(n) * 2 * math.pi
    # area element ~ (R + r cos v): rejection-free inverse by sampling v with weights
    v = rng.random(4 * n) * 2 * math.pi
    keep = rng.random(4 * n) < (big_r + small_r * np.cos(v)) / (big_r + small_r)
    v = v[keep][:n]
    cu, su, cv, sv = np.cos(u), np.sin(u), np.cos(v), np.sin(v)
    pts = np.column_stack([(big_r + small_r * cv) * cu, (big_r + small_r * cv) * su, small_r * sv])
    nrm = np.column_stack([cv * cu, cv * su, sv])
    return pts, nrm


def best_of(fn, repeat: int) -> tuple[float, object]:
    best = math.inf
    out = None
    for _ in range(repeat):
        gc.collect()
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def peak_mib(fn) -> float:
    gc.collect()
    tracemalloc.start()
    fn()
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return peak / 2**20


class FeaturesSuite:
    """asv-style suite: ``setup`` builds the cloud and neighbour tables once."""

    def setup(self, n=1_000_000, k=20):
        self.n, self.k = n, k
        self.points, self.normals = torus_cloud(n)
        self.idx20 = query_knn(self.points, k)[0]
        self.idx50 = query_knn(self.points, 50)[0]

    def time_knn(self):
        return query_knn(self.points, self.k)

    def time_fixed_k_given(self):
        return covariance_features(self.points, self.k, neighbors=self.idx20)

    def time_fixed_k_end_to_end(self):
        return covariance_features(self.points, self.k)

    def time_optimal_k_given(self):
        return optimal_k_features(self.points, k_range=(10, 50), neighbors=self.idx50)

    def time_full_search_given(self):
        return optimal_neighborhood(self.points, self.normals, neighbors=self.idx20)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=1_000_000)
    ap.add_argument("--k", type=int, default=20)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--no-peers", action="store_true")
    args = ap.parse_args(argv)
    n, k, rep = args.n, args.k, args.repeat

    suite = FeaturesSuite()
    t0 = time.perf_counter()
    suite.setup(n, k)
    print(f"setup ({n} points, k-NN 20 and 50): {time.perf_counter() - t0:.1f} s")
    # warm the JIT (cache load) on a small input
    small = FeaturesSuite()
    small.setup(2000, k)
    for name in ("fixed_k_given", "optimal_k_given", "full_search_given"):
        getattr(small, f"time_{name}")()

    rows = {}
    peers = {}
    rounds = {}

    def pair(name_ours, fn_ours, name_peer, fn_peer, repeat):
        """Alternate ours and the peer round by round (the machine's load drifts)."""
        best_o = best_p = math.inf
        rounds[name_ours] = []
        for _ in range(repeat):
            t_o = best_of(fn_ours, 1)[0]
            best_o = min(best_o, t_o)
            if fn_peer is not None:
                t_p = best_of(fn_peer, 1)[0]
                best_p = min(best_p, t_p)
                rounds[name_ours].append(t_o / t_p)
        rows[name_ours] = min(rows.get(name_ours, math.inf), best_o)
        print(f"ours  {name_ours:22s} {rows[name_ours]:8.3f} s", flush=True)
        if fn_peer is not None:
            peers[name_peer] = best_p
            print(f"peer  {name_peer:32s} {best_p:8.3f} s", flush=True)

    if args.no_peers:
        for name in (
            "knn",
            "fixed_k_given",
            "fixed_k_end_to_end",
            "optimal_k_given",
            "full_search_given",
        ):
            pair(name, getattr(suite, f"time_{name}"), None, None, rep)
    else:
        import jakteristics
        import pgeof

        xyz = np.ascontiguousarray(suite.points, dtype=np.float32)
        nn20 = np.ascontiguousarray(suite.idx20.ravel(), dtype=np.uint32)
        ptr20 = np.arange(0, n * k + 1, k, dtype=np.uint32)
        nn50 = np.ascontiguousarray(suite.idx50.ravel(), dtype=np.uint32)
        ptr50 = np.arange(0, n * 50 + 1, 50, dtype=np.uint32)

        def pg_e2e():
            nn, _ = pgeof.knn_search(xyz, xyz, k)
            return pgeof.compute_features(xyz, np.ascontiguousarray(nn.ravel()), ptr20, k_min=1)

        area = 4 * math.pi**2 * 1.0 * 0.3
        radius = 1.5 * math.sqrt(k * area / (math.pi * n))
        pair("knn", suite.time_knn, "pgeof knn_search", lambda: pgeof.knn_search(xyz, xyz, k), rep)
        pair(
            "fixed_k_given",
            suite.time_fixed_k_given,
            "pgeof compute_features",
            lambda: pgeof.compute_features(xyz, nn20, ptr20, k_min=1),
            rep,
        )
        pair("fixed_k_end_to_end", suite.time_fixed_k_end_to_end, "pgeof end-to-end", pg_e2e, rep)
        pair(
            "optimal_k_given",
            suite.time_optimal_k_given,
            "pgeof compute_features_optimal",
            lambda: pgeof.compute_features_optimal(
                xyz, nn50, ptr50, k_min=10, k_step=1, k_min_search=10
            ),
            1,
        )
        pair(
            "fixed_k_end_to_end",
            suite.time_fixed_k_end_to_end,
            "jakteristics end-to-end",
            lambda: jakteristics.compute_features(
                suite.points,
                search_radius=radius,
                max_k_neighbors=k,
                num_threads=2,
                feature_names=list(jakteristics.FEATURE_NAMES),
            ),
            1,
        )
        # our search against our fixed k, alternated as well (at least five rounds:
        # the per-round ratio cancels the VM's drift, its median is the robust one)
        pair(
            "full_search_given",
            suite.time_full_search_given,
            "ours fixed_k_given (again)",
            suite.time_fixed_k_given,
            max(rep, 5),
        )
        rows["fixed_k_given"] = min(rows["fixed_k_given"], peers.pop("ours fixed_k_given (again)"))

    print("\nratios (> 1 means pointatlas is faster):")
    if peers:
        r1 = peers["pgeof compute_features"] / rows["fixed_k_given"]
        r2 = peers["pgeof end-to-end"] / rows["fixed_k_end_to_end"]
        r3 = peers["pgeof compute_features_optimal"] / rows["optimal_k_given"]
        r4 = peers["jakteristics end-to-end"] / rows["fixed_k_end_to_end"]
        print(f"  fixed k={k}, neighbours given, vs pgeof:        {r1:6.2f}  (target >= 1)")
        print(f"  fixed k={k}, end to end, vs pgeof:               {r2:6.2f}  (target >= 1)")
        print(f"  optimal k 10..50 (eigenentropy) vs pgeof:       {r3:6.2f}  (target >= 5)")
        print(f"  fixed k={k}, end to end, vs jakteristics:        {r4:6.2f}")
        print(
            f"  pgeof throughput (given): {n / peers['pgeof compute_features'] / 1e6:.2f} M pts/s"
        )
    print(f"  ours throughput (given):  {n / rows['fixed_k_given'] / 1e6:.2f} M pts/s")
    r5 = rows["full_search_given"] / rows["fixed_k_given"]
    print(f"  full 28 x 15 search / our fixed-k time:        {r5:6.2f}  (target <= 8)")
    if rounds.get("full_search_given"):
        per_round = sorted(rounds["full_search_given"])
        rr = ", ".join(f"{x:.2f}" for x in per_round)
        print(f"    per round (search, then fixed k right after): {rr}")
        print(f"    median per round:                            {np.median(per_round):6.2f}")

    print("\npeak numpy memory (tracemalloc):")
    for name in ("fixed_k_end_to_end", "optimal_k_given", "full_search_given"):
        mib = peak_mib(getattr(suite, f"time_{name}"))
        print(f"  {name:22s} {mib:8.0f} MiB  (target < 3 GB)")

    print("\nprecision: shift by 1e6 (same neighbour table), max |difference|:")
    shifted = suite.points + 1e6
    a = covariance_features(suite.points, k, neighbors=suite.idx20)
    b = covariance_features(shifted, k, neighbors=suite.idx20)
    for name in ("linearity", "planarity", "scattering", "verticality", "e_dim"):
        d = np.nanmax(np.abs(getattr(a, name) - getattr(b, name)))
        print(f"  ours  {name:12s} {d:.2e}")
    if not args.no_peers:
        f0 = pgeof.compute_features(xyz, nn20, ptr20, k_min=1)
        f1 = pgeof.compute_features(
            np.ascontiguousarray(shifted, dtype=np.float32), nn20, ptr20, k_min=1
        )
        for j, name in enumerate(("linearity", "planarity", "scattering", "verticality")):
            print(f"  pgeof {name:12s} {np.nanmax(np.abs(f0[:, j] - f1[:, j])):.2e}")
        zeros = int((np.abs(f1[:, :3]).sum(axis=1) == 0).sum())
        print(f"  pgeof points with all-zero L/P/S after the shift: {zeros}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
