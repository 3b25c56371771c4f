"""Where the time of `simplify_points` goes on one sampled collection model.

Run from the repository root::

    .venv/bin/python benchmarks/profile_simplify_points.py cad_a_a21.obj
    .venv/bin/python benchmarks/profile_simplify_points.py cad_a_a21.obj --top 30
    .venv/bin/python benchmarks/profile_simplify_points.py cad_a_a38.obj --timeline

The model is sampled as `bench_simplify_points.py` samples it (20,000 points with
face normals, `pointatlas.synth.sample_mesh` seed 0); one untimed run compiles the
kernels, then a second run of `simplify_points` (default options) goes under
cProfile. Prints the seconds (cumulative, with what they call) of the points path's
steps, each with its share of the whole run, then the functions that take the most
time themselves (``--top``). Steps nest: the field is part of the surface, the
collapse loop part of the decimation. cProfile sees the calling thread only; with
``--timeline`` the second run goes without it and prints the wall-clock span of each
step on each thread instead (the winding number, the fit and the collapses run on
threads of their own: which step waits for which).
"""

from __future__ import annotations

import argparse
import cProfile
import functools
import importlib
import pstats
import threading
import time
import warnings
from pathlib import Path

import numpy as np

from pointatlas.io import read_mesh
from pointatlas.simplify import SimplifyWarning, simplify_points
from pointatlas.synth import sample_mesh

#: (label, module file, function name), in the order the path runs them; indented
#: labels are parts of the step above.
STEPS = (
    ("segmentation (VSA)", "segment/_vsa.py", "vsa_segment"),
    ("robust path", "simplify/_reconstruct.py", "robust_mesh"),
    ("  surface (voxel grid)", "simplify/_reconstruct.py", "reconstruct_surface"),
    ("    field", "simplify/_reconstruct.py", "_field"),
    ("      band values", "simplify/_reconstruct.py", "_band_values"),
    ("      winding number sides", "simplify/_reconstruct.py", "_winding_sides"),
    ("    marching cubes", "skimage/measure/_marching_cubes_lewiner.py", "marching_cubes"),
    ("  fit to the points' planes", "simplify/_snap.py", "fit_to_points"),
    ("  decimation: collapses", "simplify/_decimate_mesh.py", "__init__"),
    ("  decimation: level search", "simplify/_decimate_mesh.py", "steps_for"),
    ("  decimation: result", "simplify/_decimate_mesh.py", "result"),
)


#: (module, attribute) of the steps `--timeline` times, on whichever thread runs them.
TIMED = (
    ("pointatlas.simplify._reconstruct", "reconstruct_surface"),
    ("pointatlas.simplify._reconstruct", "_field"),
    ("pointatlas.simplify._reconstruct", "_band_sides"),
    ("pointatlas.simplify._reconstruct", "_winding_sides"),
    ("pointatlas.simplify._reconstruct", "cut_handles"),
    ("pointatlas.simplify._snap", "fit_to_points"),
    ("pointatlas.simplify._surface_regions", "transfer_labels"),
    ("pointatlas.simplify._surface_regions", "region_planes"),
    ("pointatlas.simplify._level_search", "start_collapses"),
    ("pointatlas.simplify._decimate_mesh", "collapse_all"),
    ("pointatlas.simplify._level_search", "default_steps"),
    ("pointatlas.simplify._decimate_mesh", "Decimation.placed"),
    ("pointatlas.simplify._point_distances", "PointDistances.floor_at"),
    ("pointatlas.simplify._snap", "PointsDecimation.steps_within"),
    ("pointatlas.simplify._snap", "PointsDecimation.result"),
)


def _timed(spans: list, t0: list, module: str, attr: str) -> None:
    """Replace ``module.attr`` (a function or ``Class.method``) by a wrapper that
    appends ``(attr, thread, start, end)`` to ``spans`` (seconds from ``t0[0]``)."""
    owner = importlib.import_module(module)
    *path, name = attr.split(".")
    for part in path:
        owner = getattr(owner, part)
    fn = getattr(owner, name)

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        start = time.perf_counter()
        try:
            return fn(*args, **kwargs)
        finally:
            end = time.perf_counter()
            thread = threading.current_thread().name
            spans.append((attr, thread, start - t0[0], end - t0[0]))

    setattr(owner, name, wrapper)


def timeline(p, n) -> float:
    """One run of `simplify_points` with the `TIMED` steps' spans printed in the order
    they start; returns its seconds."""
    spans, t0 = [], [0.0]
    for module, attr in TIMED:
        _timed(spans, t0, module, attr)
    t0[0] = time.perf_counter()
    simplify_points(p, n)
    total = time.perf_counter() - t0[0]
    print(f"{'step':34s} {'thread':22s} {'start':>6s} {'end':>6s} {'span':>6s}")
    for attr, thread, start, end in sorted(spans, key=lambda s: s[2]):
        print(f"{attr:34s} {thread[:22]:22s} {start:6.2f} {end:6.2f} {end - start:6.2f}")
    return total


def _sample(path: Path, n_points: int):
    mesh = read_mesh(path)
    tri = np.asarray(mesh.triangles, dtype=np.int64)
    s = sample_mesh(mesh.vertices, tri, n_points, rng=0)
    return np.asarray(s.points), np.asarray(s.normals)


def _cumulative(stats: pstats.Stats, module: str, name: str) -> float | None:
    """Cumulative seconds of ``name`` in a file ending with ``module`` (None: not run)."""
    found = [
        v[3]
        for (file, _, func), v in stats.stats.items()
        if func == name and file.replace("\\", "/").endswith(module)
    ]
    return sum(found) if found else None


def _queries(stats: pstats.Stats, module: str | None = None, name: str | None = None) -> float:
    """Seconds of threaded k-NN queries (cKDTree with ``workers=-1``: the caller waits
    in ``Thread.join``), called from ``name`` in ``module``, or from anywhere."""
    total = 0.0
    for (file, _, func), v in stats.stats.items():
        if func != "join" or not file.endswith("threading.py"):
            continue
        for (cfile, _, caller), c in v[4].items():
            if name is None or (caller == name and cfile.replace("\\", "/").endswith(module)):
                total += c[3]
    return total


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("model", help="file name in --models (e.g. cad_a_a21.obj)")
    ap.add_argument("--models", type=Path, default=Path("../shared/data/collection"))
    ap.add_argument("--points", type=int, default=20000)
    ap.add_argument("--top", type=int, default=15, help="functions by own time")
    ap.add_argument("--timeline", action="store_true", help="wall-clock spans per thread")
    args = ap.parse_args(argv)
    p, n = _sample(args.models / args.model, args.points)
    warnings.simplefilter("ignore", SimplifyWarning)
    simplify_points(p, n)  # compiles the kernels (or loads them from numba's cache)
    if args.timeline:
        print(f"{args.model}: {args.points} points, {timeline(p, n):.2f} s")
        return 0
    prof = cProfile.Profile()
    t0 = time.perf_counter()
    prof.enable()
    r = simplify_points(p, n)
    prof.disable()
    total = time.perf_counter() - t0
    stats = pstats.Stats(prof)
    print(
        f"{args.model}: {args.points} points, path {r.path}, {r.mesh.n_faces} faces, "
        f"{len(r.mesh.triangles)} triangles; {total:.2f} s under cProfile"
    )
    for label, module, name in STEPS:
        sec = _cumulative(stats, module, name)
        if sec is not None:
            print(f"{label:34s} {sec:7.2f} s  {100.0 * sec / total:5.1f} %")
    field_query = _queries(stats, "simplify/_reconstruct.py", "_field")
    field_query += _queries(stats, "simplify/_reconstruct.py", "_band_values")
    print(f"{'k-NN queries (cKDTree, threads)':34s} {_queries(stats):7.2f} s")
    print(f"{'  of them in the field':34s} {field_query:7.2f} s")
    print()
    stats.sort_stats("tottime").print_stats(args.top)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
