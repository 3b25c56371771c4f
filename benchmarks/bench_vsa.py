"""Speed and quality of VSA segmentation against peers (issue 4).

    python benchmarks/bench_vsa.py [--n 1000000] [--switch-n 100000] [--out bench-output/vsa]
                                   [--skip cgal,open3d,pcl,switch]

1. A raw cloud (no normals) of ``--n`` points from the CAD-like scene of
   ``benchmarks/scene.py``; per method the time of every stage, the region
   count, the share of points assigned and the MSE of the points to the
   least-squares plane of their region (over the assigned points):
   - ours: k-NN (k = 12), PCA normals, MST orientation, VSA from every point with
     split and merge (k = 8), with the thesis' global eta = 25, with a
     mean-deviation bound of 10 degrees (independent of N), and with an eta from
     Eq. 4.9 for regions of N / 100 points (`eq49_eta`);
   - CGAL (``pip install cgal``): pca_estimate_normals (k = 12) + region_growing;
   - Open3D: estimate_normals (k = 12) + repeated segment_plane, and
     detect_planar_patches;
   - PCL (``benchmarks/pcl_region_growing.cpp`` against Debian's libpcl-dev, built
     on the fly when g++ and pkg-config find PCL): NormalEstimationOMP + RegionGrowing
     with the PCL tutorial's parameters.
2. Our region growing against PCL's on a shared 100k cloud (same normals, same
   curvature, PCL's own neighbour lists): agreement and time.
3. Batch vs single-best switch on ``--switch-n`` points (200 random seeds, no
   split/merge): final energy and time.

Results go to ``OUT/bench_vsa.json`` and are printed as markdown.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from scene import cad_scene  # noqa: E402

from pointatlas.neighbors import query_knn  # noqa: E402
from pointatlas.normals import estimate_normals, orient_normals  # noqa: E402
from pointatlas.segment import (  # noqa: E402
    estimate_eta,
    region_growing,
    surface_curvature,
    vsa_segment,
)

REPO = Path(__file__).resolve().parents[1]


def plane_mse(points, labels):
    """MSE of assigned points to the least-squares plane of their region."""
    sel = labels >= 0
    lab = np.unique(labels[sel], return_inverse=True)[1]
    p = points[sel]
    m = lab.max() + 1
    cnt = np.bincount(lab, minlength=m).astype(float)
    cen = np.stack([np.bincount(lab, p[:, d], m) for d in range(3)], 1) / cnt[:, None]
    q = p - cen[lab]
    cov = np.zeros((m, 3, 3))
    for a in range(3):
        for b in range(a, 3):
            cov[:, a, b] = cov[:, b, a] = np.bincount(lab, q[:, a] * q[:, b], m)
    lam = np.linalg.eigvalsh(cov)[:, 0]
    return float(np.clip(lam, 0, None).sum() / sel.sum())


def quality(points, labels):
    labels = np.asarray(labels)
    assigned = labels >= 0
    return {
        "n_regions": int(np.unique(labels[assigned]).size),
        "assigned": float(assigned.mean()),
        "plane_mse": plane_mse(points, labels) if assigned.any() else float("nan"),
    }


def eq49_eta(normals, idx, n_target, k=8):
    """Eta from Eq. 4.9 (`estimate_eta`) for regions of ``n_target`` points.

    The scene is piecewise flat, so the paraboloid's curvature H stands for the
    normal noise: H is chosen (bisection) so that the model's mean per-point
    L21, estimate_eta(H, n_target) / n_target, equals the cloud's mean local
    normal scatter 2 (1 - n_i . nbar_i), nbar_i the mean of the oriented normals
    of the k nearest neighbours (measured on our own normals, no ground truth).
    Returns (eta, H, scatter).
    """
    mean = np.zeros_like(normals)
    for c in range(k):  # column by column: no (N, k, 3) temporary
        mean += normals[idx[:, c]]
    mean /= np.linalg.norm(mean, axis=1, keepdims=True)
    scatter = float(np.mean(2.0 * (1.0 - np.einsum("ij,ij->i", normals, mean))))
    lo, hi = 0.0, 4.0
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        if estimate_eta(mid, n_target) / n_target < scatter:
            lo = mid
        else:
            hi = mid
    h = 0.5 * (lo + hi)
    return estimate_eta(h, n_target), h, scatter


def run_ours(points, threshold):
    stages = {}
    t = time.perf_counter()
    idx, _ = query_knn(points, 12)
    stages["knn"] = time.perf_counter() - t
    t = time.perf_counter()
    nrm = estimate_normals(points, 12, neighbors=idx)
    stages["normals"] = time.perf_counter() - t
    t = time.perf_counter()
    nrm = orient_normals(points, nrm, k=12, neighbors=idx)
    stages["orient"] = time.perf_counter() - t
    extra = {}
    if "eq49_target" in threshold:
        t = time.perf_counter()
        eta, h, scatter = eq49_eta(nrm, idx, threshold["eq49_target"])
        stages["eq49"] = time.perf_counter() - t
        extra = {"eta": eta, "eq49_H": h, "normal_scatter": scatter, **threshold}
        threshold = {"eta": eta}
    t = time.perf_counter()
    res = vsa_segment(points, nrm, neighbors=np.ascontiguousarray(idx[:, :8]), **threshold)
    stages["vsa"] = time.perf_counter() - t
    for key in ("graph", "flood", "split", "merge", "switch", "update", "final_merge", "finalize"):
        stages[f"vsa.{key}"] = res.timings.get(key, 0.0)
    out = {"stages": stages, "total": stages["knn"] + stages["normals"] + stages["orient"]}
    out["total"] += stages["vsa"] + stages.get("eq49", 0.0)
    out.update(extra)
    out.update(quality(points, res.labels))
    counts = np.sort(res.region_counts)[::-1]
    out["region_size_quantiles"] = np.quantile(res.region_counts, [0.1, 0.5, 0.9]).tolist()
    out["points_in_largest_100"] = float(counts[:100].sum() / points.shape[0])
    out.update(
        {
            "eq47_mse": res.mse,
            "energy": res.energy,
            "n_iter": res.n_iter,
            "converged": res.converged,
            "stop_reason": res.stop_reason,
        }
    )
    return out


def run_cgal(points, tmp):
    from CGAL.CGAL_Point_set_3 import Point_set_3
    from CGAL.CGAL_Point_set_processing_3 import pca_estimate_normals
    from CGAL.CGAL_Shape_detection import region_growing as cgal_rg

    xyz = tmp / "cloud.xyz"
    np.savetxt(xyz, points, fmt="%.9g")
    ps = Point_set_3(str(xyz))
    ps.add_normal_map()
    stages = {}
    t = time.perf_counter()
    pca_estimate_normals(ps, 12)
    stages["normals"] = time.perf_counter() - t
    pm = ps.add_int_map("plane_index")
    t = time.perf_counter()
    cgal_rg(ps, pm, min_points=20, k=12)
    stages["region_growing"] = time.perf_counter() - t
    labels = np.fromiter((pm.get(i) for i in range(ps.size())), dtype=np.int64, count=ps.size())
    out = {"stages": stages, "total": sum(stages.values())}
    out.update(quality(points, labels))
    return out


def run_open3d(points):
    import open3d as o3d

    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    stages = {}
    t = time.perf_counter()
    pcd.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(12))
    stages["normals"] = time.perf_counter() - t
    # repeated RANSAC planes (at most 30) until < 5 % remain or a plane has < 200 points
    t = time.perf_counter()
    labels = np.full(points.shape[0], -1, dtype=np.int64)
    remaining = np.arange(points.shape[0])
    rest = pcd
    for plane in range(30):
        if remaining.size < 0.05 * points.shape[0]:
            break
        _, inliers = rest.segment_plane(distance_threshold=0.02, ransac_n=3, num_iterations=500)
        if len(inliers) < 200:
            break
        inliers = np.asarray(inliers)
        labels[remaining[inliers]] = plane
        keep = np.ones(remaining.size, dtype=bool)
        keep[inliers] = False
        remaining = remaining[keep]
        rest = rest.select_by_index(inliers, invert=True)
    stages["segment_plane"] = time.perf_counter() - t
    ransac = {"stages": dict(stages), "total": stages["normals"] + stages["segment_plane"]}
    ransac.update(quality(points, labels))
    t = time.perf_counter()
    boxes = pcd.detect_planar_patches()
    patches = {"stages": {"normals": stages["normals"], "detect": time.perf_counter() - t}}
    patches["total"] = sum(patches["stages"].values())
    labels = np.full(points.shape[0], -1, dtype=np.int64)
    for j, box in enumerate(boxes):
        inside = np.asarray(box.get_point_indices_within_bounding_box(pcd.points))
        free = inside[labels[inside] < 0]
        labels[free] = j
    patches.update(quality(points, labels))
    return {"segment_plane": ransac, "planar_patches": patches}


def build_pcl(out_dir: Path):
    exe = out_dir / "pcl_rg"
    if exe.exists():
        return exe
    if shutil.which("g++") is None or shutil.which("pkg-config") is None:
        return None
    flags = subprocess.run(
        ["pkg-config", "--cflags", "--libs"]
        + ["pcl_segmentation", "pcl_features", "pcl_search", "pcl_kdtree", "pcl_common"],
        capture_output=True,
        text=True,
    )
    if flags.returncode != 0:
        return None
    cmd = ["g++", "-O2", "-std=c++17", "-fopenmp", str(REPO / "benchmarks/pcl_region_growing.cpp")]
    cmd += ["-o", str(exe), *flags.stdout.split()]
    done = subprocess.run(cmd, capture_output=True, text=True)
    return exe if done.returncode == 0 else None


def _pcl_call(exe, rows, tmp, k, smooth_deg, curv, min_cluster, mode):
    src, dst = tmp / "pcl_in.bin", tmp / "pcl_out.bin"
    with src.open("wb") as fh:
        np.array(rows.shape, dtype=np.int64).tofile(fh)
        np.ascontiguousarray(rows, dtype=np.float64).tofile(fh)
    args = [str(exe), str(src), str(dst), str(k), str(smooth_deg), repr(curv), str(min_cluster)]
    res = subprocess.run([*args, mode], capture_output=True, text=True, check=True)
    raw = np.fromfile(dst, dtype=np.int32)
    n = rows.shape[0]
    table = raw[n:].reshape(n, k).astype(np.int64) if mode == "given" else None
    return json.loads(res.stdout.strip().splitlines()[-1]), raw[:n].astype(np.int64), table


def run_pcl(exe, points, tmp):
    # PCL tutorial parameters: k = 30, 3 degrees, curvature 1.0, clusters >= 50
    timing, labels, _ = _pcl_call(exe, points, tmp, 30, 3.0, 1.0, 50, "estimate")
    stages = {"normals": timing["normals_s"], "region_growing": timing["region_growing_s"]}
    out = {"stages": stages, "total": sum(stages.values())}
    out.update(quality(points, labels))
    return out


def compare_region_growing(exe, points, normals, tmp, k=8):
    """Ours vs PCL on the same cloud, normals and curvature (float32-rounded)."""
    p32 = points.astype(np.float32).astype(np.float64)
    n32 = normals.astype(np.float32).astype(np.float64)
    curv = surface_curvature(p32, k=k).astype(np.float32).astype(np.float64)
    thr = float(np.percentile(curv, 98))
    rows = np.hstack([p32, n32, curv[:, None]])
    timing, pcl_labels, table = _pcl_call(exe, rows, tmp, k, 15.0, thr, 1, "given")
    t = time.perf_counter()
    ours_pcl_knn = region_growing(
        p32,
        n32,
        k=k,
        smoothness_angle=math.radians(15),
        curvature_threshold=thr,
        curvature=curv,
        neighbors=table,
    )
    t_given = time.perf_counter() - t
    t = time.perf_counter()
    ours_own = region_growing(
        p32, n32, k=k, smoothness_angle=math.radians(15), curvature_threshold=thr, curvature=curv
    )
    t_own = time.perf_counter() - t

    def agreement(a, b):
        # share of points whose region corresponds one-to-one between a and b
        pairs, inv = np.unique(np.stack([a, b], 1), axis=0, return_inverse=True)
        _, ca = np.unique(pairs[:, 0], return_counts=True)
        _, cb = np.unique(pairs[:, 1], return_counts=True)
        one_a = dict(zip(np.unique(pairs[:, 0]), ca == 1, strict=True))
        one_b = dict(zip(np.unique(pairs[:, 1]), cb == 1, strict=True))
        good = np.array([one_a[x] and one_b[y] for x, y in pairs])
        return float(good[inv.ravel()].mean())

    return {
        "n_points": int(points.shape[0]),
        "pcl_regions": int(pcl_labels.max() + 1),
        "ours_regions": ours_pcl_knn.n_regions,
        "agreement_pcl_knn": agreement(ours_pcl_knn.labels, pcl_labels),
        "agreement_own_knn": agreement(ours_own.labels, pcl_labels),
        "identical_labels_pcl_knn": bool(np.array_equal(ours_pcl_knn.labels, pcl_labels)),
        "pcl_seconds": timing["region_growing_s"],
        "ours_seconds_given_knn": t_given,
        "ours_seconds_own_knn": t_own,
    }


def compare_switch(points, normals):
    out = {}
    for mode in ("batch", "single"):
        t = time.perf_counter()
        res = vsa_segment(
            points,
            normals,
            seeds=200,
            rng=0,
            split=False,
            merge=False,
            switch=mode,
            max_iter=10**7,
        )
        out[mode] = {
            "seconds": time.perf_counter() - t,
            "energy": res.energy,
            "n_iter": res.n_iter,
            "stop_reason": res.stop_reason,
            "n_regions": res.n_regions,
        }
    out["speedup"] = out["single"]["seconds"] / out["batch"]["seconds"]
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=1_000_000)
    ap.add_argument("--switch-n", type=int, default=100_000)
    ap.add_argument("--out", type=Path, default=REPO / "bench-output" / "vsa")
    ap.add_argument("--skip", default="", help="comma list of cgal,open3d,pcl,switch,ours")
    args = ap.parse_args(argv)
    skip = set(filter(None, args.skip.split(",")))
    args.out.mkdir(parents=True, exist_ok=True)
    points, exact, _ = cad_scene(args.n, rng=0)
    report = {"n_points": int(points.shape[0]), "scene": "benchmarks/scene.py cad_scene(n, rng=0)"}
    report["loadavg_start"] = list(os.getloadavg())
    with tempfile.TemporaryDirectory() as tmpdir:
        tmp = Path(tmpdir)
        if "ours" not in skip:
            # JIT warm-up (numba compiles on first use after a kernel change; the
            # on-disk cache makes later processes fast): not timed
            warm, _, _ = cad_scene(5000, rng=1)
            run_ours(warm, {"eta": 25.0})
            run_ours(warm, {"max_angle": math.radians(10)})
            report["ours_eta25"] = run_ours(points, {"eta": 25.0})
            print("ours eta=25", report["ours_eta25"], flush=True)
            report["ours_angle10"] = run_ours(points, {"max_angle": math.radians(10)})
            print("ours max_angle=10", report["ours_angle10"], flush=True)
            target = max(points.shape[0] // 100, 1)
            report["ours_eq49"] = run_ours(points, {"eq49_target": target})
            print("ours Eq. 4.9 eta", report["ours_eq49"], flush=True)
        if "cgal" not in skip:
            report["cgal"] = run_cgal(points, tmp)
            print("cgal", report["cgal"], flush=True)
        if "open3d" not in skip:
            report.update({f"open3d_{k}": v for k, v in run_open3d(points).items()})
            print("open3d", report["open3d_segment_plane"], report["open3d_planar_patches"])
        exe = None if "pcl" in skip else build_pcl(args.out)
        report["pcl_available"] = exe is not None
        if exe is not None:
            report["pcl"] = run_pcl(exe, points, tmp)
            print("pcl", report["pcl"], flush=True)
            sub = np.random.default_rng(1).permutation(points.shape[0])[:100_000]
            idx, _ = query_knn(points[sub], 12)
            nrm = orient_normals(points[sub], estimate_normals(points[sub], 12, neighbors=idx))
            report["rg_vs_pcl"] = compare_region_growing(exe, points[sub], nrm, tmp)
            print("region growing vs PCL", report["rg_vs_pcl"], flush=True)
        if "switch" not in skip:
            pool = points if points.shape[0] >= args.switch_n else cad_scene(args.switch_n)[0]
            sub = np.random.default_rng(2).permutation(pool.shape[0])[: args.switch_n]
            idx, _ = query_knn(pool[sub], 12)
            nrm = orient_normals(pool[sub], estimate_normals(pool[sub], 12, neighbors=idx))
            report["switch"] = compare_switch(pool[sub], nrm)
            print("switch", report["switch"], flush=True)
    report["loadavg_end"] = list(os.getloadavg())
    (args.out / "bench_vsa.json").write_text(json.dumps(report, indent=1))
    print(f"wrote {args.out / 'bench_vsa.json'}")


if __name__ == "__main__":
    main()
