"""`simplify_points` on point sets sampled from the collection: closed, compact, near?

Run from the repository root::

    .venv/bin/python benchmarks/bench_simplify_points.py \
        --models ../shared/data/collection --every 3 --points 20000 \
        --out bench-output/simplify_points.csv
    # raw points: normals estimated (`surface_normals`: PCA k = 20, the least-entropy
    # size in 10..30 where not flat), oriented, made sharp beside edges
    # (`sharpen_normals`) and turned outward (`outward_normals`), as the CLI does,
    # and again at k = 30 and 40 where the output misses the points
    # (`simplify_estimated`: the nearest kept; the peer given the kept normals)
    .venv/bin/python benchmarks/bench_simplify_points.py --every 6 --estimate-normals
    # a scanner's noise: Gaussian, sigma 0.1 % of the diagonal (seeded)
    .venv/bin/python benchmarks/bench_simplify_points.py --every 6 --noise 0.1
    # a scanner's uneven density: ten times sparser at the far end of x (seeded)
    .venv/bin/python benchmarks/bench_simplify_points.py --every 6 --falloff 10
    # a part scanned standing on a table: no points where the surface faces down
    .venv/bin/python benchmarks/bench_simplify_points.py --every 6 --no-bottom
    # one scanner view: points only where the surface faces it and nothing hides them
    .venv/bin/python benchmarks/bench_simplify_points.py --every 3 --no-peer --view
    # a scanner's stray returns: 1 % of the points moved off (seeded)
    .venv/bin/python benchmarks/bench_simplify_points.py --every 6 --outliers 1

Every ``--every``-th model (sorted by name) is sampled uniformly by area with its
face normals (`pointatlas.synth.sample_mesh`, seed 0; with ``--falloff R`` at a
density falling R times along x, `uneven_sample`) and the points alone go through
`pointatlas.simplify.simplify_points` with default options (``path="auto"``: the
thesis path, and the robust path when that gives no closed, manifold, oriented mesh
with valid faces). One CSV row per model: path taken and why, faces, closed /
manifold / oriented, Euler characteristic of the output and of the input mesh, its
triangles of zero area (at most 1e-12 of the diagonal squared), mean and max
distance of the points to the output, the report's two-sided Hausdorff distance,
and measured here against the truth: the two-sided Hausdorff distance between the
output and the mesh the points were sampled from (its vertices and
20,000 samples each way; % of the points' bounding-box diagonal), whether a vertex
lies outside the points' box grown by 1 % of its diagonal (a spike), seconds; on the
robust path also its faces of flat regions, how many bend by more than 1e-6 of the
diagonal (all of a face's vertices to their plane) and the largest bend. The
summary prints the shares closed + manifold + oriented, with the input's Euler
characteristic, within 1 % of the truth both ways, with a spike, and the times. An
untimed run of the first model comes first (`warm_up`: numba's compile or cache
load is no model's time).
"""

from __future__ import annotations

import argparse
import csv
import functools
import multiprocessing
import sys
import time
import warnings
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from bench_simplify_rd import both_ways, kinds, open3d_quadric, zero_area_triangles

from pointatlas.io import read_mesh
from pointatlas.neighbors import point_mesh_distance
from pointatlas.normals import orient_normals
from pointatlas.simplify import (
    SimplifyWarning,
    mesh_checks,
    outward_normals,
    self_intersections,
    sharpen_normals,
    simplify_estimated,
    simplify_points,
    surface_normals,
)
from pointatlas.synth import sample_mesh

MESH_SUFFIXES = (".obj", ".off", ".ply", ".stl")
#: Poisson depths tried for the peer (the better one per model is kept)
PEER_DEPTHS = (8, 9)
#: ``--no-bottom``: a part standing on a table is not seen where its surface faces
#: down more steeply than this (the z of the true normal below minus this)
BOTTOM_Z = 0.2
#: ... where the peer's Poisson surface, closed over the missing side, is trimmed of
#: its vertices below these quantiles of the points' density (Open3D's tutorial step;
#: the best per model is kept, as the depth is)
PEER_TRIMS = (0.05, 0.1, 0.2)
#: ``--view``: the direction to a scanner far away (orthographic), and the least cosine
#: between a surface's normal and it where the scanner still sees the surface
VIEW = np.array([0.3, -0.5, 0.81]) / np.linalg.norm([0.3, -0.5, 0.81])
VIEW_COS = 0.1
#: ``--outliers``: the moved points go off along every axis by a Gaussian of this
#: sigma, in % of the diagonal (their normals kept, or estimated with the others)
OUTLIER_SIGMA = 10.0
#: ``--estimate-normals``: the first estimate's neighbourhood size (the CLI's
#: ``--normal-k``); `simplify_estimated` estimates again at its `RETRY_K` sizes where
#: the output misses the points
ESTIMATE_K = 20


@dataclass(frozen=True)
class Sampling:
    """How the points are made from a model: ``points`` of them, uniform by area or at
    a density falling ``falloff`` times along x (`uneven_sample`), with Gaussian
    ``noise`` (sigma in % of the diagonal), none where the surface faces down
    (``no_bottom``: a part scanned on a table) or where a scanner at `VIEW` does not
    see it (``view``: one scan), ``outliers`` % of them moved off by a Gaussian of
    `OUTLIER_SIGMA` % of the diagonal (stray returns), their normals the true ones or
    estimated (``estimate``: `surface_normals`, oriented, sharpened and turned
    outward as the CLI does)."""

    points: int = 20000
    estimate: bool = False
    noise: float = 0.0
    falloff: float = 1.0
    no_bottom: bool = False
    view: bool = False
    outliers: float = 0.0

    @property
    def partial(self) -> bool:
        """Whether the points see only part of the surface."""
        return self.no_bottom or self.view

    def seen(self, vertices, triangles, p, n) -> np.ndarray:
        """Which of the points ``p`` (normals ``n``) on the mesh the scan sees: not
        facing down (``no_bottom``), or facing `VIEW` with no triangle between them
        and the scanner (``view``: a ray from each cast with Open3D), else all."""
        if self.no_bottom:
            return n[:, 2] > -BOTTOM_Z
        if not self.view:
            return np.ones(p.shape[0], dtype=bool)
        import open3d as o3d

        scene = o3d.t.geometry.RaycastingScene()
        scene.add_triangles(np.asarray(vertices, np.float32), np.asarray(triangles, np.uint32))
        off = 1e-4 * float(np.linalg.norm(np.ptp(p, axis=0)))  # off the point's own face
        rays = np.hstack([p + off * VIEW, np.broadcast_to(VIEW, p.shape)]).astype(np.float32)
        hit = scene.cast_rays(o3d.core.Tensor(rays))["t_hit"].numpy()
        return np.isinf(hit) & (n @ VIEW > VIEW_COS)

    def sample(self, vertices, triangles):
        """The points and their normals (true, or estimated)."""
        # a partial scan: more points sampled (twice, four times for one view), those
        # seen kept, then as many
        many = (4 if self.view else 2 if self.no_bottom else 1) * self.points
        p, n = uneven_sample(vertices, triangles, many, self.falloff)
        if self.partial:
            seen = np.flatnonzero(self.seen(vertices, triangles, p, n))
            seen = seen[np.random.default_rng(3).permutation(seen.size)[: self.points]]
            p, n = p[seen], n[seen]
        if self.noise > 0:
            # a scanner's noise: Gaussian along every axis, sigma noise % of the diagonal
            sigma = self.noise / 100.0 * float(np.linalg.norm(np.ptp(p, axis=0)))
            p = p + np.random.default_rng(2).normal(0.0, sigma, p.shape)
        if self.outliers > 0:
            # stray returns: every point moved with this chance, far off (seeded)
            rng = np.random.default_rng(4)
            moved = rng.random(p.shape[0]) < self.outliers / 100.0
            sigma = OUTLIER_SIGMA / 100.0 * float(np.linalg.norm(np.ptp(p, axis=0)))
            p = p.copy()
            p[moved] += rng.normal(0.0, sigma, (int(moved.sum()), 3))
        if self.estimate:
            n = self.estimate_normals(p, ESTIMATE_K)
        return p, n

    @staticmethod
    def estimate_normals(p, k: int):
        """The points' normals as the CLI estimates them at neighbourhoods of ``k``."""
        n = sharpen_normals(p, orient_normals(p, surface_normals(p, k=k)))
        return outward_normals(p, n)


KINDS = kinds()


def _euler(n_vertices: int, tri: np.ndarray) -> int:
    und = np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1)
    return int(n_vertices - np.unique(und, axis=0).shape[0] + tri.shape[0])


def _both_ways(v, t, v2, t2) -> float:
    """Two-sided Hausdorff distance between two meshes (vertices and 20,000 samples)."""
    a = np.vstack([v, sample_mesh(v, t, 20000, rng=1).points])
    b = np.vstack([v2, sample_mesh(v2, t2, 20000, rng=1).points])
    return float(max(point_mesh_distance(a, v2, t2).max(), point_mesh_distance(b, v, t).max()))


def _seen_both_ways(v, t, v2, t2, sampling: Sampling) -> dict:
    """`_both_ways` and `both_ways`' mean for a truth ``v``, ``t`` seen only in part
    (``--no-bottom``, ``--view``): from the truth, those of its 20,000 samples the scan
    sees (`Sampling.seen`); back, every vertex and sample of ``v2``, ``t2`` to the
    whole truth. Returns ``hausdorff`` and ``mean`` (mean of the two directions'
    means), in the truth's units."""
    truth = sample_mesh(v, t, 20000, rng=1)
    a, normals = np.asarray(truth.points), np.asarray(truth.normals)
    a = a[sampling.seen(v, t, a, normals)]
    b = np.vstack([v2, sample_mesh(v2, t2, 20000, rng=1).points])
    there, back = point_mesh_distance(a, v2, t2), point_mesh_distance(b, v, t)
    return {
        "hausdorff": float(max(there.max(), back.max())),
        "mean": 0.5 * float(there.mean() + back.mean()),
    }


def truth_distances(v, t, v2, t2, diag: float, sampling: Sampling) -> dict:
    """``truth_hausdorff_pct`` and ``truth_mean_pct`` of an output ``v2``, ``t2`` against
    the truth ``v``, ``t`` (% of ``diag``; `_both_ways` and `both_ways`' mean, or
    `_seen_both_ways` for a partial scan)."""
    if sampling.partial:
        d = _seen_both_ways(v, t, v2, t2, sampling)
        return {
            "truth_hausdorff_pct": 100.0 * d["hausdorff"] / diag,
            "truth_mean_pct": 100.0 * d["mean"] / float(np.linalg.norm(np.ptp(v, axis=0))),
        }
    return {
        "truth_hausdorff_pct": 100.0 * _both_ways(v, t, v2, t2) / diag,
        "truth_mean_pct": both_ways(v, t, v2, t2)["mean"],
    }


def poisson_decimated(points, normals, n_triangles: int, depth: int, trim: float = 0.0):
    """What a user does today: Open3D's screened Poisson at ``depth``, its vertices of
    density below the ``trim`` quantile removed (Open3D's tutorial step for a surface
    the points do not close; 0: none), then its quadric decimation to ``n_triangles``
    (vertices, triangles)."""
    import open3d as o3d

    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.array(points, dtype=float)))
    cloud.normals = o3d.utility.Vector3dVector(np.array(normals, dtype=float))
    mesh, density = o3d.geometry.TriangleMesh.create_from_point_cloud_poisson(cloud, depth=depth)
    if trim > 0.0:
        density = np.asarray(density)
        mesh.remove_vertices_by_mask(density < np.quantile(density, trim))
    v, t = np.asarray(mesh.vertices), np.asarray(mesh.triangles, dtype=np.int64)
    return open3d_quadric(v, t, n_triangles)


def _timed_poisson(p, n, n_triangles: int, depth: int, trim: float):
    t0 = time.perf_counter()
    pv, pt = poisson_decimated(p, n, n_triangles, depth, trim)
    return pv, pt, time.perf_counter() - t0


def peer_row(v_true, t_true, p, n, n_triangles: int, diag: float, sampling=None) -> dict:
    """The better of Poisson depth 8 and 9 + decimation (lower mean distance both ways;
    for a partial scan, ``sampling.partial``, also over the density trims of
    `PEER_TRIMS`, measured against the truth as the points see it: ``peer_trim``);
    ``peer_depth`` "crashed" when Open3D crashed at every depth. Its Euler characteristic
    (the vertices its triangles use) and its two-sided Hausdorff distance to the truth
    measured as ours (`truth_distances`, % of the points' diagonal ``diag``)."""
    sampling = Sampling() if sampling is None else sampling
    best = {"peer_depth": "crashed"}
    trims = PEER_TRIMS if sampling.partial else (0.0,)
    for depth, trim in [(d, q) for d in PEER_DEPTHS for q in trims]:
        # in a child process: Open3D's Poisson can segfault (seen on a sensor cover
        # with estimated normals), which is the peer's result, not the end of the run
        ctx = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(max_workers=1, mp_context=ctx) as pool:
            try:
                job = pool.submit(_timed_poisson, p, n, n_triangles, depth, trim)
                pv, pt, took = job.result()
            except BrokenProcessPool:
                continue
        if sampling.partial:  # the truth seen as the points see it
            truth = truth_distances(v_true, t_true, pv, pt, diag, sampling)
            d = {"mean": truth["truth_mean_pct"], "hausdorff": truth["truth_hausdorff_pct"]}
        else:
            d = both_ways(v_true, t_true, pv, pt)
            truth = {"truth_hausdorff_pct": 100.0 * _both_ways(v_true, t_true, pv, pt) / diag}
        if d["mean"] < best.get("peer_mean_pct", np.inf):
            best = {
                "peer_depth": depth,
                "peer_trim": trim,
                "peer_triangles": int(pt.shape[0]),
                "peer_closed": all(mesh_checks(len(pv), pt)) if len(pt) else False,
                "peer_euler": _euler(np.unique(pt).size, pt) if len(pt) else "",
                "peer_truth_hausdorff_pct": truth["truth_hausdorff_pct"],
                "peer_mean_pct": d["mean"],
                "peer_hausdorff_pct": d["hausdorff"],
                "peer_seconds": took,
                "peer_crossings": len(self_intersections(pv, pt)) if len(pt) else "",
            }
    return best


def uneven_sample(vertices, triangles, n_points: int, falloff: float):
    """``n_points`` points and normals on the mesh, uniform by area where ``falloff``
    is 1, else with a density falling ``falloff`` times from the lowest x to the
    highest (a scanner at -x): 3 ``n_points`` uniform samples, each kept with
    probability ``falloff`` ** -u (u: its x from 0 to 1), ``n_points`` of those."""
    if falloff == 1.0:
        sample = sample_mesh(vertices, triangles, n_points, rng=0)
        return np.asarray(sample.points), np.asarray(sample.normals)
    sample = sample_mesh(vertices, triangles, 3 * n_points, rng=0)
    p, n = np.asarray(sample.points), np.asarray(sample.normals)
    u = (p[:, 0] - p[:, 0].min()) / max(float(np.ptp(p[:, 0])), 1e-300)
    keep = np.random.default_rng(1).random(p.shape[0]) < falloff ** (-u)
    pick = np.random.default_rng(2).permutation(int(keep.sum()))[:n_points]
    return p[keep][pick], n[keep][pick]


def run_model(path: Path, sampling: Sampling, peer: bool = True) -> dict:
    mesh = read_mesh(path)
    tri = np.asarray(mesh.triangles, dtype=np.int64)
    used = np.unique(tri)
    euler_in = _euler(used.size, tri)
    p, n = sampling.sample(mesh.vertices, tri)
    # the scale of every % below: the points' box (the truth's where outliers stretch it)
    box = mesh.vertices[used] if sampling.outliers > 0 else p
    diag = float(np.linalg.norm(np.ptp(box, axis=0)))
    kind = KINDS.get(path.stem, "organic")
    row = {"model": path.name, "kind": kind, "points": sampling.points, "euler_input": euler_in}
    t0 = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", SimplifyWarning)
            if sampling.estimate:  # estimated again where the output misses the points
                estimate = functools.partial(Sampling.estimate_normals, p)
                kept = simplify_estimated(p, estimate, normal_k=ESTIMATE_K, normals=n)
                r, n, normal_k = kept.result, kept.normals, kept.k
            else:
                r, normal_k = simplify_points(p, n), ""
    except Exception as exc:  # noqa: BLE001 - a crash is a result here
        row.update(seconds=time.perf_counter() - t0, path="error", reason=repr(exc))
        return row
    seconds = time.perf_counter() - t0
    m = r.mesh
    mv, mt = np.asarray(m.vertices), np.asarray(m.triangles)
    closed, manifold, oriented = mesh_checks(m.n_vertices, mt)
    lo, hi = p.min(axis=0) - 0.01 * diag, p.max(axis=0) + 0.01 * diag
    row.update(
        path=r.path,
        reason=r.reason,
        normal_k=normal_k,
        faces=m.n_faces,
        polygons=len(m.polygons),
        vertices=m.n_vertices,
        triangles=int(mt.shape[0]),
        closed=closed,
        manifold=manifold,
        oriented=oriented,
        euler=_euler(m.n_vertices, mt),
        degenerate=zero_area_triangles(mv, mt, diag),
        mean_distance_pct=100.0 * m.distance_mean / diag,
        max_distance_pct=100.0 * m.distance_max / diag,
        hausdorff_pct=100.0 * max(m.distance_max, m.back_distance_max) / diag,
        spike=bool(((mv < lo) | (mv > hi)).any()),
        crossings=len(self_intersections(mv, mt)),
        seconds=seconds,
        **truth_distances(mesh.vertices, tri, mv, mt, diag, sampling),
    )
    if hasattr(m, "face_flat"):  # the robust path's faces of flat regions, planar?
        bend = np.asarray(m.planarity_error)[m.face_flat]
        row.update(
            flat_faces=int(bend.size),
            flat_faces_bent=int((bend > 1e-6 * diag).sum()),
            max_flat_planarity_pct=100.0 * float(bend.max(initial=0.0)) / diag,
        )
    if peer:
        row.update(peer_row(mesh.vertices, tri, p, n, int(mt.shape[0]), diag, sampling))
    return row


def warm_up(path: Path, sampling: Sampling) -> None:
    """The first model once untimed (`run_model` without the peer), so that no model's
    time holds numba's compile or cache load (the peer's is timed in a child process
    after Open3D's import): the same kernels, signatures and code paths as the timed
    runs (a smaller sample can take other branches)."""
    run_model(path, sampling, peer=False)


def peer_summary(rows: list[dict]) -> list[str]:
    """Geometric means of ours / Poisson + decimation per kind (distances below 1e-4 %
    of the diagonal count as equal, as in bench_simplify_rd.py)."""
    lines = []
    for kind in ("cad", "organic"):
        mine = [r for r in rows if r["kind"] == kind and "peer_mean_pct" in r]
        if not mine:
            continue

        def gm(ours, theirs, rows=mine):
            x = [(r[ours] + 1e-4) / (r[theirs] + 1e-4) for r in rows]
            return float(np.exp(np.mean(np.log(x))))

        over = sum((r["truth_mean_pct"] + 1e-4) / (r["peer_mean_pct"] + 1e-4) > 1.5 for r in mine)
        lines.append(
            f"{kind} ({len(mine)}): ours / Poisson + decimation at our triangle count: mean "
            f"distance {gm('truth_mean_pct', 'peer_mean_pct'):.2f}x, two-sided Hausdorff "
            f"{gm('truth_hausdorff_pct', 'peer_hausdorff_pct'):.2f}x, time "
            f"{gm('seconds', 'peer_seconds'):.2f}x; {over} over 1.5x (mean); peer closed "
            f"{sum(bool(r['peer_closed']) for r in mine)}/{len(mine)}, crashed "
            f"{sum(r['kind'] == kind and r.get('peer_depth') == 'crashed' for r in rows)}"
        )
    peer = [r for r in rows if "peer_euler" in r]
    if peer:
        lines.append(
            f"peer with the input's Euler characteristic "
            f"{sum(r['peer_euler'] == r['euler_input'] for r in peer)}/{len(peer)} (ours "
            f"{sum(r['euler'] == r['euler_input'] for r in peer)}), within 1 % of the truth "
            f"both ways {sum(r['peer_truth_hausdorff_pct'] <= 1.0 for r in peer)}/{len(peer)} "
            f"(ours {sum(r['truth_hausdorff_pct'] <= 1.0 for r in peer)})"
        )
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--models", type=Path, default=Path("../shared/data/collection"))
    ap.add_argument("--every", type=int, default=3)
    ap.add_argument("--points", type=int, default=20000)
    ap.add_argument("--estimate-normals", action="store_true")
    ap.add_argument("--no-peer", action="store_true", help="skip Poisson + decimation")
    ap.add_argument(
        "--noise", type=float, default=0.0, help="Gaussian noise, sigma in %% of the diagonal"
    )
    ap.add_argument(
        "--falloff",
        type=float,
        default=1.0,
        help="density falling this many times along x (1: uniform by area)",
    )
    ap.add_argument(
        "--no-bottom",
        action="store_true",
        help="no points where the surface faces down (a part scanned on a table)",
    )
    ap.add_argument(
        "--view",
        action="store_true",
        help="points only where one scanner (far away, along VIEW) sees the surface",
    )
    ap.add_argument(
        "--outliers",
        type=float,
        default=0.0,
        help="%% of the points moved off by a Gaussian of OUTLIER_SIGMA %% of the diagonal",
    )
    ap.add_argument("--out", type=Path, default=Path("bench-output/simplify_points.csv"))
    ap.add_argument(
        "--only", nargs="+", default=None, help="of the selected models, only these (file stems)"
    )
    ap.add_argument(
        "--shard", default=None, help="I/N: the I-th (from 0) of N interleaved parts of the models"
    )
    args = ap.parse_args(argv)
    files = sorted(p for p in args.models.iterdir() if p.suffix.lower() in MESH_SUFFIXES)
    files = files[:: args.every]
    if args.only:
        files = [p for p in files if p.stem in set(args.only)]
    if args.shard:
        part, n_parts = (int(x) for x in args.shard.split("/"))
        files = files[part::n_parts]
    sampling = Sampling(
        args.points,
        args.estimate_normals,
        args.noise,
        args.falloff,
        args.no_bottom,
        args.view,
        args.outliers,
    )
    if files:
        warm_up(files[0], sampling)
    rows = []
    for path in files:
        row = run_model(path, sampling, not args.no_peer)
        rows.append(row)
        print(
            f"{row['model']:40s} {row['path']:7s} faces={row.get('faces', '-')!s:>5} "
            f"closed={row.get('closed', '-')!s:5} manifold={row.get('manifold', '-')!s:5} "
            f"euler={row.get('euler', '-')!s:>3}/{row['euler_input']:<3} "
            f"tri={row.get('triangles', '-')!s:>5} "
            f"H={row.get('hausdorff_pct', float('nan')):.2f}% "
            f"truth={row.get('truth_hausdorff_pct', float('nan')):.2f}% "
            f"{row['seconds']:.1f}s {row.get('reason', '')[:60]}",
            flush=True,
        )
    args.out.parent.mkdir(parents=True, exist_ok=True)
    keys = [
        "model",
        "points",
        "path",
        "faces",
        "polygons",
        "vertices",
        "triangles",
        "closed",
        "manifold",
        "oriented",
        "euler",
        "euler_input",
        "degenerate",
        "mean_distance_pct",
        "max_distance_pct",
        "hausdorff_pct",
        "truth_hausdorff_pct",
        "truth_mean_pct",
        "spike",
        "seconds",
        "kind",
        "peer_depth",
        "peer_trim",
        "peer_triangles",
        "peer_closed",
        "peer_euler",
        "peer_truth_hausdorff_pct",
        "peer_mean_pct",
        "peer_hausdorff_pct",
        "peer_seconds",
        "flat_faces",
        "flat_faces_bent",
        "max_flat_planarity_pct",
        "reason",
        "normal_k",
        "crossings",
        "peer_crossings",
    ]
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
    done = [r for r in rows if r["path"] != "error"]
    if done:
        truth = np.array([r["truth_hausdorff_pct"] for r in done])
        ours = np.array([r["hausdorff_pct"] for r in done])
        tris = np.array([r["triangles"] for r in done])
        print(
            f"within 1 % of the truth both ways: {int((truth <= 1.0).sum())}/{len(rows)}; "
            f"truth Hausdorff median {np.median(truth):.2f} %, max {truth.max():.2f} %; "
            f"reported Hausdorff median {np.median(ours):.2f} %; spikes "
            f"{sum(r['spike'] for r in done)}; triangles median {np.median(tris):.0f}, "
            f"max {tris.max()}; faces median {np.median([r['faces'] for r in done]):.0f}; "
            f"with a zero-area triangle: {sum(r['degenerate'] > 0 for r in done)}"
        )
        flat = [r for r in done if "flat_faces" in r]
        if flat:
            print(
                f"faces of flat regions: {sum(r['flat_faces'] for r in flat)}, bent by more "
                f"than 1e-6 of the diagonal: {sum(r['flat_faces_bent'] for r in flat)} in "
                f"{sum(r['flat_faces_bent'] > 0 for r in flat)} models, largest "
                f"{max(r['max_flat_planarity_pct'] for r in flat):.3f} %"
            )
        crossed = [r for r in done if r["crossings"] > 0]
        line = (
            f"self-intersecting outputs: {len(crossed)}/{len(done)} "
            f"({sum(r['crossings'] for r in done)} triangle pairs)"
        )
        peer = [r for r in done if r.get("peer_crossings", "") != ""]
        if peer:
            line += (
                f"; the peer's {sum(r['peer_crossings'] > 0 for r in peer)}/{len(peer)} "
                f"({sum(r['peer_crossings'] for r in peer)})"
            )
        print(line)
        for line in peer_summary(done):
            print(line)
    print(f"written: {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
