"""Cloud surfaces at scan sizes: cover + complex + topology report, and the scale search.

Times (best of ``--repeat``) of ``ball_cover`` (Algorithm 2, Prop. 4) + the cloud
complex + ``surface_report`` on ``--n`` points (default 10**6) of a noisy sphere of
radius 10 at grid scale 1, and of ``search_cover_scale`` over 20 scales on
``--n-search`` points (default 10**5). With gudhi installed (dev extra) the anchor
is gudhi's ``CoverComplex`` nerve of the same clouds (given as the cover, so gudhi
only builds the nerve and computes Betti numbers; it checks no surface condition).

Run: ``.venv/bin/python benchmarks/bench_cover.py [--n 1000000] [--n-search 100000]``
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from pointatlas.complex import surface_report
from pointatlas.cover import ball_cover, search_cover_scale


def best_of(func, repeat: int):
    """Smallest wall time of ``repeat`` calls (seconds) and the last result."""
    times, result = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        result = func()
        times.append(time.perf_counter() - t0)
    return min(times), result


def noisy_sphere(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    p = rng.normal(size=(n, 3))
    p /= np.linalg.norm(p, axis=1, keepdims=True)
    return p * (10.0 + rng.normal(scale=0.02, size=(n, 1)))


def gudhi_nerve(cov, max_points: int):
    """gudhi nerve of the same clouds: every point's cloud set inserted into a SimplexTree
    (what ``CoverComplex``/``NerveComplex`` build; those need scikit-learn), then Betti
    numbers. Returns (seconds, betti) or None without gudhi."""
    try:
        import gudhi
    except ImportError:
        return None
    K = cov.cloud_complex
    sel = range(min(K.n_points, max_points))
    t0 = time.perf_counter()
    st = gudhi.SimplexTree()
    for p in sel:
        st.insert(K.clouds_of(p).tolist())
    st.compute_persistence(persistence_dim_max=True)
    return time.perf_counter() - t0, st.betti_numbers()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=1_000_000)
    ap.add_argument("--n-search", type=int, default=100_000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--no-gudhi", action="store_true")
    args = ap.parse_args()
    print(
        f"cores available: {os.cpu_count()}, numba threads: {__import__('numba').get_num_threads()}"
    )
    pts = noisy_sphere(args.n)
    ball_cover(pts[:1000], 1.0)  # JIT warm-up

    def run():
        cov = ball_cover(pts, 1.0)
        return cov, surface_report(cov.cloud_complex)

    t, (cov, rep) = best_of(run, args.repeat)
    print(
        f"cover + complex + report, {args.n:,} points: {t:.2f} s "
        f"({cov.n_clouds} clouds, {rep.n_faces} triangles, chi {rep.euler_characteristic}, "
        f"closed {rep.is_closed})"
    )
    q = pts[: args.n_search]
    scales = np.linspace(0.5, 2.4, 20)
    t, res = best_of(lambda: search_cover_scale(q, scales), args.repeat)
    print(
        f"scale search, 20 scales, {q.shape[0]:,} points: {t:.2f} s "
        f"({res.accepted.size} accepted: {res.scales[res.accepted].round(2).tolist()})"
    )
    if not args.no_gudhi:
        out = gudhi_nerve(ball_cover(q, 1.0), q.shape[0])
        if out is None:
            print("gudhi not installed: no anchor")
        else:
            print(
                f"gudhi SimplexTree nerve of the same clouds, {q.shape[0]:,} points: "
                f"{out[0]:.2f} s (Betti {out[1]}; no surface checks)"
            )


if __name__ == "__main__":
    main()
