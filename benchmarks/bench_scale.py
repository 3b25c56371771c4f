"""Scans too big for one process: tiled normals, features and segmentation of LAZ files.

1. Generates a synthetic lidar scan as LAZ (seeded; written by chunks): rolling
   terrain, box buildings with flat and gable roofs and walls, cylindrical
   tanks and poles, scattered vegetation-like noise, intensity and ASPRS
   classification, millimetre scales, UTM-like offsets, ~16 points per square metre.
2. Runs the commands end to end as a user would (``pointatlas normals``, ``features``,
   ``segment``, and ``features --normals``, both in one pass, MST-oriented or, step
   ``one-pass-up``, ``--orient up``, with ``--tile-size`` on a local dask cluster, LAZ
   decode and encode included) and reports wall time,
   throughput in points/s per core and points per CPU-second (user + sys of the
   command and its dask workers) and the peak memory of the whole process tree (the
   command plus its dask workers, sampled with psutil every 0.1 s).
3. ``--compare``: the same commands untiled on the same file; features and normals
   must be identical on every point, segmentation quality measures within 1 %
   (``--local``: both segment runs with ``--local``, the opt-in local VSA).
4. ``--halo-cost``: tiled / untiled compute time as tiles shrink (in one process, one
   worker thread at a time, no I/O), with the points sent per point.
5. ``--stages features,normals,one-pass,one-pass-up``: seconds of every stage of a tiled run
   (decode, first pass, halo estimate, spill, tile tasks, write pass, dask start/first
   tile/close) beside the untiled floor (one k-NN query and the kernels over all points).

Run (the issue's measures; the 10M case takes minutes on 2 cores):

    .venv/bin/python benchmarks/bench_scale.py --points 1000000 --compare --halo-cost
    .venv/bin/python benchmarks/bench_scale.py --points 10000000 --tile-size 200 \
        --steps normals,features,one-pass,one-pass-up
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

#: points per square metre of the synthetic scan (a typical airborne lidar density)
DENSITY = 16.0
#: edge of the generation blocks (metres); each block is generated from its own seed
BLOCK = 50.0
OFFSET = np.array([512_000.0, 4_100_000.0, 0.0])


# --------------------------------------------------------------------------- the scan


def _block(rng, x0, y0, n):
    """One BLOCK x BLOCK square: terrain, maybe a building, maybe a tank, poles, noise."""
    parts, cls = [], []

    def ground_z(x, y):  # continuous rolling terrain over the whole scan
        return 100.0 + 0.02 * x + 4.0 * np.sin(x / 160.0) * np.cos(y / 190.0)

    n_veg = int(0.05 * n)
    n_obj = int(0.35 * n)
    n_ground = n - n_veg - n_obj
    x = x0 + rng.uniform(0, BLOCK, n_ground)
    y = y0 + rng.uniform(0, BLOCK, n_ground)
    parts.append(np.column_stack([x, y, ground_z(x, y) + rng.normal(0, 0.02, n_ground)]))
    cls.append(np.full(n_ground, 2, np.uint8))
    # a building: box walls and a flat or gable roof
    n_b = int(0.7 * n_obj)
    w, d, h = rng.uniform(10, 20), rng.uniform(10, 20), rng.uniform(4, 12)
    bx, by = x0 + rng.uniform(5, BLOCK - 25), y0 + rng.uniform(5, BLOCK - 25)
    gz = ground_z(bx, by)
    n_roof = int(0.6 * n_b)
    u, v = rng.uniform(0, 1, n_roof), rng.uniform(0, 1, n_roof)
    if rng.random() < 0.5:
        rz = gz + h + 0.0 * u
    else:  # gable roof along x
        rz = gz + h + 3.0 * (1 - np.abs(2 * v - 1))
    parts.append(np.column_stack([bx + w * u, by + d * v, rz + rng.normal(0, 0.02, n_roof)]))
    cls.append(np.full(n_roof, 6, np.uint8))
    n_wall = n_b - n_roof
    t = rng.uniform(0, 2 * (w + d), n_wall)
    wx = np.where(
        t < w,
        bx + t,
        np.where(t < w + d, bx + w, np.where(t < 2 * w + d, bx + (2 * w + d - t), bx)),
    )
    wy = np.where(
        t < w,
        by,
        np.where(t < w + d, by + (t - w), np.where(t < 2 * w + d, by + d, by + (2 * (w + d) - t))),
    )
    parts.append(np.column_stack([wx, wy, gz + rng.uniform(0, h, n_wall)]))
    cls.append(np.full(n_wall, 6, np.uint8))
    # a tank (cylinder with a flat top) and poles
    n_t = n_obj - n_b
    r, th = rng.uniform(2, 5), rng.uniform(0, 2 * np.pi, n_t)
    cx, cy = x0 + rng.uniform(35, 45), y0 + rng.uniform(35, 45)
    hz = rng.uniform(0, 8, n_t)
    parts.append(np.column_stack([cx + r * np.cos(th), cy + r * np.sin(th), ground_z(cx, cy) + hz]))
    cls.append(np.full(n_t, 1, np.uint8))
    # vegetation-like scattered points
    vx, vy = x0 + rng.uniform(0, BLOCK, n_veg), y0 + rng.uniform(0, BLOCK, n_veg)
    parts.append(np.column_stack([vx, vy, ground_z(vx, vy) + rng.uniform(0.5, 10, n_veg)]))
    cls.append(np.full(n_veg, 5, np.uint8))
    pts = np.vstack(parts)
    klass = np.concatenate(cls)
    inside = (
        (pts[:, 0] >= x0) & (pts[:, 0] < x0 + BLOCK) & (pts[:, 1] >= y0) & (pts[:, 1] < y0 + BLOCK)
    )
    return pts[inside], klass[inside]


def generate_scan(path: Path, n_points: int, seed: int = 0) -> Path:
    """Write the synthetic scan of about ``n_points`` points as LAZ, block by block."""
    import laspy

    side = math.sqrt(n_points / DENSITY)
    nb = max(1, round(side / BLOCK))
    per_block = n_points // (nb * nb)
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.scales = np.array([0.001, 0.001, 0.001])
    header.offsets = OFFSET.copy()
    seeds = np.random.SeedSequence(seed).spawn(nb * nb)
    with laspy.open(path, mode="w", header=header, do_compress=True) as writer:
        for b, ss in enumerate(seeds):
            rng = np.random.default_rng(ss)
            i, j = b % nb, b // nb
            pts, klass = _block(rng, i * BLOCK, j * BLOCK, per_block)
            rec = laspy.ScaleAwarePointRecord.zeros(pts.shape[0], header=header)
            rec.x, rec.y, rec.z = (pts + OFFSET).T
            rec.classification = klass
            rec.intensity = np.clip(
                800 + 40 * (pts[:, 2] - 100) + rng.normal(0, 60, pts.shape[0]), 0, 65535
            ).astype(np.uint16)
            rec.return_number = np.ones(pts.shape[0], np.uint8)
            rec.number_of_returns = np.ones(pts.shape[0], np.uint8)
            rec.gps_time = b + rng.uniform(0, 1, pts.shape[0])
            writer.write_points(rec)
    return path


# --------------------------------------------------------------------------- measuring


class TreeMemory:
    """Peak of the summed RSS of a process and its descendants, and their CPU seconds
    (psutil, sampled every 0.1 s; a process's last sampled user + sys counts)."""

    def __init__(self, pid: int):
        import psutil

        self.proc = psutil.Process(pid)
        self.root = (pid, self.proc.create_time())
        self.peak = 0
        self.peak_single = 0
        self.cpu = {}  # pid -> last (user + sys) seen
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self):
        import psutil

        while not self._stop.is_set():
            try:
                procs = [self.proc, *self.proc.children(recursive=True)]
                rss = []
                for p in procs:
                    try:
                        rss.append(p.memory_info().rss)
                        t = p.cpu_times()
                        self.cpu[(p.pid, p.create_time())] = t.user + t.system
                    except psutil.Error:
                        pass
                self.peak = max(self.peak, sum(rss))
                self.peak_single = max(self.peak_single, max(rss, default=0))
            except psutil.Error:
                pass
            time.sleep(0.1)

    def stop(self):
        self._stop.set()
        self._thread.join()


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def run_cli(args: list, cores: int) -> dict:
    """Run ``pointatlas ARGS``: wall time, CPU seconds, peak tree memory, summary line.

    ``cpu_s``: user + sys of the command and every descendant it waited for (its dask
    workers: ``getrusage(RUSAGE_CHILDREN)`` after it ended), the honest per-core cost on
    a shared box: ``points_per_cpu_s`` does not fall when other jobs take the cores
    (``points_per_s_per_core`` = points / wall / cores does). ``cpu_s_sampled``: the
    same from psutil samples of the live tree (a lower bound; a check that no worker
    escaped the rusage count), ``cpu_s_command_process`` its share of the command's own
    process (passes, LAZ decode and encode, the scheduler); the rest is the workers'.
    """
    exe = Path(sys.executable).with_name("pointatlas")
    c0 = _children_cpu()
    t0 = time.perf_counter()
    proc = subprocess.Popen(
        [str(exe), *map(str, args)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    mem = TreeMemory(proc.pid)
    out, err = proc.communicate()
    mem.stop()
    wall = time.perf_counter() - t0
    cpu = _children_cpu() - c0
    if proc.returncode:
        raise SystemExit(f"pointatlas {' '.join(map(str, args))} failed:\n{err}")
    return {
        "cmd": " ".join(map(str, args)),
        "seconds": round(wall, 2),
        "cpu_s": round(cpu, 2),
        "cpu_s_sampled": round(sum(mem.cpu.values()), 2),
        "cpu_s_command_process": round(mem.cpu.get(mem.root, 0.0), 2),
        "peak_gib_tree": round(mem.peak / 2**30, 3),
        "peak_gib_one_process": round(mem.peak_single / 2**30, 3),
        "cores": cores,
        "load": round(os.getloadavg()[0], 2),
        "stdout": out.strip().splitlines()[:2],
    }


def _rates(r: dict, n: int, cores: int) -> dict:
    """Points/s per core (wall) and points per CPU-second of a run."""
    r["points_per_s_per_core"] = round(n / r["seconds"] / cores)
    r["points_per_cpu_s"] = round(n / max(r["cpu_s"], 1e-9))
    return r


def _las_fields(path, names):
    import laspy

    las = laspy.read(path)
    return {n: np.asarray(las[n]) for n in names}


def compare(laz: Path, tmp: Path, tile: float, workers: int, n: int, local: bool = False) -> dict:
    """Tiled vs untiled CLI runs on the same file: identical features and normals,
    segmentation measures within 1 %."""
    out = {}
    for what, args in (
        ("normals", ["normals", "--k", 20, "--orient", "none"]),
        ("features", ["features", "--k", 20, "--weights", "equal"]),
    ):
        t_path, u_path = tmp / f"{what}_t.laz", tmp / f"{what}_u.laz"
        rt = run_cli(
            [args[0], laz, t_path, *args[1:], "--tile-size", tile, "--workers", workers], workers
        )
        ru = run_cli([args[0], laz, u_path, *args[1:]], os.cpu_count() or 1)
        import laspy

        names = [d for d in laspy.read(u_path).point_format.extra_dimension_names]
        a, b = _las_fields(t_path, names), _las_fields(u_path, names)
        same = all(np.array_equal(a[k], b[k], equal_nan=True) for k in names)
        out[what] = {
            "tiled": rt,
            "untiled": ru,
            "identical": same,
            "fields": len(names),
            "time_ratio": round(rt["seconds"] / ru["seconds"], 3),
            "cpu_ratio": round(rt["cpu_s"] / ru["cpu_s"], 3),
        }
        print(json.dumps({what: out[what]}, indent=1), flush=True)
    t_path, u_path = tmp / "seg_t.laz", tmp / "seg_u.laz"
    # the same normals for both: the untiled normals file (PCA + MST)
    nrm = tmp / "normals_mst.laz"
    run_cli(["normals", laz, nrm, "--k", 20], os.cpu_count() or 1)
    mode = ["--local"] if local else []
    rt = run_cli(
        ["segment", nrm, t_path, *mode, "--tile-size", tile, "--workers", workers], workers
    )
    ru = run_cli(["segment", nrm, u_path, *mode], os.cpu_count() or 1)
    qt = json.loads((tmp / "seg_t_regions.json").read_text())["summary"]["quality"]
    su = json.loads((tmp / "seg_u_regions.json").read_text())["summary"]
    qu = {k: su[{"n_regions": "n_regions", "energy": "energy", "mse": "mse"}[k]] for k in qt}
    rel = {k: round(qt[k] / qu[k] - 1.0, 5) for k in qt}
    out["segment"] = {
        "local": local,
        "tiled": rt,
        "untiled": ru,
        "tiled_quality": qt,
        "untiled_quality": qu,
        "relative_difference": rel,
        "within_1pct": all(abs(v) <= 0.01 for v in rel.values()),
    }
    print(json.dumps({"segment": out["segment"]}, indent=1), flush=True)
    return out


def halo_cost(laz: Path, sizes) -> list:
    """Tiled / untiled compute time of features (k = 20) as tiles shrink, in one
    process with one tile at a time (no I/O, no cluster start)."""
    import distributed

    from pointatlas.batch import TileOptions, tiled_features
    from pointatlas.features import covariance_features
    from pointatlas.io import read_point_set

    pts = read_point_set(laz, with_normals=False).points
    params = {"mode": "fixed", "k": 20, "flatness": (8, 8)}
    covariance_features(pts[:50_000], 20)  # compile
    rows = []
    with distributed.Client(
        processes=False, n_workers=1, threads_per_worker=1, dashboard_address=None
    ) as client:
        for size in sizes:
            for _ in range(2):  # alternate, twice: the box is shared
                t0 = time.perf_counter()
                ref = covariance_features(pts, 20).scalar_fields()
                tu = time.perf_counter() - t0
                t0 = time.perf_counter()
                got, run = tiled_features(
                    pts, None, TileOptions(tile_size=size, scheduler=client), params
                )
                tt = time.perf_counter() - t0
            same = all(np.array_equal(got[k], ref[k], equal_nan=True) for k in ref)
            row = {
                "tile_size": size,
                "tiles": run.n_tiles,
                "halo": round(min(run.halos.values()), 3),
                "points_sent_per_point": round(run.halo_overhead, 3),
                "untiled_s": round(tu, 2),
                "tiled_s": round(tt, 2),
                "ratio": round(tt / tu, 2),
                "identical": same,
            }
            print(json.dumps(row), flush=True)
            rows.append(row)
    return rows


def _cpu_self() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)  # every thread of this process (numba's)
    return r.ru_utime + r.ru_stime


def _timed(out: dict, name: str, func, *args, **kwargs):
    """Run ``func``; ``out[name]`` = its wall seconds, ``out["cpu"][name]`` its CPU
    seconds (user + sys of this process)."""
    t0, c0 = time.perf_counter(), _cpu_self()
    result = func(*args, **kwargs)
    out[name] = round(time.perf_counter() - t0, 3)
    out.setdefault("cpu", {})[name] = round(_cpu_self() - c0, 3)
    return result


def warm_task(kind: str, params: dict, threads) -> None:
    """What a worker's first tile loads: imports and numba kernels (a tiny input)."""
    from pointatlas.batch._tiles_tasks import features_dispatch
    from pointatlas.normals import estimate_normals, orient_normals

    if threads:
        import numba

        numba.set_num_threads(int(threads))
    pts = np.random.default_rng(0).random((2000, 3))
    if kind == "features":
        features_dispatch(pts, None, params)
    else:
        orient_normals(pts, estimate_normals(pts, params["k"]), k=params["orient_k"], method="mst")


def _dask_costs(kind: str, params: dict) -> dict:
    """Seconds of dask's fixed costs: import (when not yet imported), a local cluster
    of 2 worker processes, their first tile's loading (`warm_task`), close; CPU
    seconds of this process per step and of the workers (start to close, together)."""
    import logging
    import warnings

    out: dict = {}
    t0, w0 = time.perf_counter(), _children_cpu()
    import distributed

    out["dask: import"] = round(time.perf_counter() - t0, 3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cluster = _timed(
            out,
            "dask: cluster start",
            distributed.LocalCluster,
            n_workers=2,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            silence_logs=logging.ERROR,
        )
        client = distributed.Client(cluster)
        t0 = time.perf_counter()
        client.gather(
            [
                client.submit(warm_task, kind, params, 1, pure=False, workers=[w])
                for w in client.nthreads()
            ]
        )
        out["dask: first tile per worker"] = round(time.perf_counter() - t0, 3)
        t0 = time.perf_counter()
        client.close()
        cluster.close()
        out["dask: close"] = round(time.perf_counter() - t0, 3)
    out["cpu"]["dask: workers (start to close)"] = round(_children_cpu() - w0, 3)
    return out


def stages(laz: Path, tile: float, kind: str) -> dict:
    """Seconds of every stage of a tiled ``kind`` run ("features": k = 20, equal
    weights; "normals": k = 20, MST; "one-pass": both, ``features --normals``;
    "one-pass-up": both, ``features --normals --orient up``) in one
    process on one numba thread, tiles one after the other, beside the untiled floor
    (one k-NN query and the kernels over all points). The LAZ passes are those of
    `las_tiled`: the first decodes every record once and keeps them
    (`LasSource.keep_records`), the spill and write passes read the kept records. The
    dask costs (import, cluster start, a worker's first tile, close) come from a local
    cluster of 2 workers running a trivial task."""
    import laspy
    import numba

    from pointatlas.batch import TileOptions
    from pointatlas.batch import _tiles as T
    from pointatlas.batch._tiles_combined import normals_features_task
    from pointatlas.batch._tiles_las import LAS_FEATURE_FLOAT, LasSource, write_streamed
    from pointatlas.batch._tiles_tasks import features_dispatch, run_task
    from pointatlas.features import classify_dimension, covariance_features
    from pointatlas.neighbors import query_knn
    from pointatlas.normals import estimate_normals, orient_normals

    fparams = {"mode": "fixed", "k": 20, "flatness": (8, 8)}
    nparams = {"k": 20, "orient": "mst", "orient_k": 10, "viewpoint": None}
    params = {
        "features": fparams,
        "normals": nparams,
        "one-pass": {"k": 20, "orient_k": 10, "features": fparams},
        "one-pass-up": {"k": 20, "orient_k": 10, "orient": "up", "features": fparams},
    }[kind]
    numba.set_num_threads(1)  # as a worker of the 2-worker local cluster runs its tiles
    out: dict = {"kind": kind, "tile_size": tile}
    sel = laspy.DecompressionSelection.XY_RETURNS_CHANNEL | laspy.DecompressionSelection.Z
    with laspy.open(laz, decompression_selection=sel) as reader:
        rec = _timed(out, "decode x, y, z (one pass)", reader.read_points, -1)
    xyz = np.column_stack([np.asarray(rec[c], dtype=np.float64) for c in "xyz"])
    with tempfile.TemporaryDirectory(dir=laz.parent) as keep:
        src = LasSource(laz)
        src.use_normals = False
        src.keep_records(keep)
        opts = TileOptions(tile_size=tile, progress=False)
        grid = _timed(
            out, "first pass: decode all, keep records, bounds + subsample", T._grid_for, src, opts
        )
        warm_task("normals", nparams, None)  # this process's kernels loaded (a warm worker)
        warm_task("features", fparams, None)
        halo, _ = _timed(out, "halo estimate", T._auto_halo, src, 20, opts)
        spill = T._Spill(None)
        _, sent = _timed(
            out,
            "spill pass (tile cut, kept records)",
            T._spill,
            src,
            grid,
            dict.fromkeys(range(grid.n_tiles), halo),
            spill,
        )
        out["tiles"] = len(spill.pieces)
        out["sent per point"] = round(sum(sent.values()) / src.n, 3)

        def tasks():
            for t in sorted(spill.pieces):
                spec = {"grid": grid, "tile": t, "halo": halo, "params": params, "threads": None}
                if kind.startswith("one-pass"):
                    res = normals_features_task(spec, spill.load(t))
                else:
                    res = run_task(kind, spec, spill.load(t))
                assert res["status"] == "ok"

        _timed(out, "tile tasks (sum)", tasks)
        table, _ = _timed(out, "untiled: k-NN query", query_knn, xyz, 20)
        fields, nrm = {}, None
        if kind in ("normals", "one-pass", "one-pass-up"):
            nrm = _timed(out, "untiled: PCA normals", estimate_normals, xyz, 20, neighbors=table)
        if kind == "one-pass-up":
            nrm = _timed(out, "untiled: up orientation", orient_normals, xyz, nrm, method="up")
        elif nrm is not None:
            nrm = _timed(
                out,
                "untiled: MST orientation",
                orient_normals,
                xyz,
                nrm,
                k=10,
                method="mst",
                neighbors=table,
            )
        if kind in ("features", "one-pass", "one-pass-up"):
            covariance_features(xyz[:1000], 20)
            res = _timed(
                out, "untiled: features kernel", features_dispatch, xyz, None, fparams, table
            )
            fields = {**res.scalar_fields(), "dimension_class": classify_dimension(res)}
        what = {
            "features": "19 float32 fields",
            "normals": "normals",
            "one-pass": "19 float32 fields + normals",
            "one-pass-up": "19 float32 fields + normals",
        }[kind]
        _timed(
            out,
            f"LAZ write pass (kept records, encode {what})",
            write_streamed,
            src,
            laz.with_name("stages.laz"),
            fields,
            normals=nrm,
            float_type=LAS_FEATURE_FLOAT,
        )
        laz.with_name("stages.laz").unlink(missing_ok=True)
    dask = _dask_costs(
        "normals" if kind.startswith("one-pass") else kind,
        fparams if kind == "features" else nparams,
    )
    out["cpu"].update(dask.pop("cpu"))
    out.update(dask)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=1_000_000)
    parser.add_argument("--tile-size", type=float, default=100.0)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--data", type=Path, default=None, help="Folder for the LAZ (kept).")
    parser.add_argument("--compare", action="store_true", help="Tiled vs untiled runs.")
    parser.add_argument(
        "--local",
        action="store_true",
        help="--compare: segment both ways with --local (local VSA).",
    )
    parser.add_argument("--halo-cost", action="store_true", help="Halo cost as tiles shrink.")
    parser.add_argument("--no-scale", action="store_true", help="Skip the tiled end-to-end runs.")
    parser.add_argument(
        "--steps",
        default="normals,features,segment",
        help="Tiled end-to-end runs to do (comma-separated): normals, "
        "features, segment, one-pass (features --normals: both in one "
        "command, one k-NN), one-pass-up (the same, --orient "
        "up).",
    )
    parser.add_argument(
        "--stages",
        default=None,
        help="Per-stage seconds of tiled KIND runs in one process (features, "
        "normals, one-pass, one-pass-up; comma-separated), beside the "
        "untiled floor.",
    )
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(dir=args.data) as tmp_name:
        tmp = Path(tmp_name)
        folder = args.data or tmp
        laz = Path(folder) / f"scan_{args.points}_{args.seed}.laz"
        if not laz.exists():
            t0 = time.perf_counter()
            generate_scan(laz, args.points, args.seed)
            print(f"generated {laz} in {time.perf_counter() - t0:.1f} s", flush=True)
        import laspy

        with laspy.open(laz) as r:
            n = int(r.header.point_count)
        print(
            json.dumps(
                {
                    "points": n,
                    "laz_mb": round(laz.stat().st_size / 2**20, 1),
                    "uptime": os.popen("uptime").read().strip(),
                }
            ),
            flush=True,
        )
        results = {"points": n}
        if not args.no_scale:
            w, ts = args.workers, args.tile_size
            steps = [
                ("normals", ["normals", laz, tmp / "n.laz", "--k", 20, "--orient", "mst"]),
                (
                    "features",
                    ["features", tmp / "n.laz", tmp / "f.laz", "--k", 20, "--weights", "equal"],
                ),
                ("segment", ["segment", tmp / "n.laz", tmp / "s.laz"]),
                (
                    "one-pass",
                    ["features", laz, tmp / "nf.laz", "--k", 20, "--weights", "equal", "--normals"],
                ),
                (
                    "one-pass-up",
                    [
                        "features",
                        laz,
                        tmp / "nfu.laz",
                        "--k",
                        20,
                        "--weights",
                        "equal",
                        "--normals",
                        "--orient",
                        "up",
                    ],
                ),
            ]
            wanted = set(args.steps.split(","))
            if wanted & {"features", "segment"}:
                wanted.add("normals")  # they read the normals' output
            for name, cmd in steps:
                if name not in wanted:
                    continue
                r = _rates(run_cli([*cmd, "--tile-size", ts, "--workers", w], w), n, w)
                results[name] = r
                print(json.dumps({name: r}), flush=True)
        if not args.no_scale and {"normals", "features"} <= set(results):
            both = results["normals"]["seconds"] + results["features"]["seconds"]
            cpu = results["normals"]["cpu_s"] + results["features"]["cpu_s"]
            results["normals+features"] = {
                "seconds": round(both, 2),
                "cpu_s": round(cpu, 2),
                "points_per_s_per_core": round(n / both / w),
                "points_per_cpu_s": round(n / cpu),
                "peak_gib_tree": max(
                    results["normals"]["peak_gib_tree"], results["features"]["peak_gib_tree"]
                ),
            }
            print(json.dumps({"normals+features": results["normals+features"]}), flush=True)
        if args.compare:
            results["compare"] = compare(laz, tmp, args.tile_size, args.workers, n, args.local)
        if args.stages:
            results["stages"] = [
                stages(laz, args.tile_size, kind) for kind in args.stages.split(",")
            ]
            for row in results["stages"]:
                print(json.dumps(row, indent=1), flush=True)
        if args.halo_cost:
            side = math.sqrt(n / DENSITY)
            results["halo_cost"] = halo_cost(laz, [side / 2, side / 4, side / 8, side / 16])
        print(json.dumps({"uptime": os.popen("uptime").read().strip()}))


if __name__ == "__main__":
    main()
