"""Rate-distortion of `pointatlas simplify` on meshes against the quadric decimators
a user would otherwise run, at the same number of triangles, measured both ways.

Run from the repository root (the peers come with ``make bench``'s extra)::

    .venv/bin/python benchmarks/bench_simplify_rd.py --every 5 \
        --out bench-output/simplify_rd [--plot docs/figures/simplify_rd.png]

For every model (every ``--every``-th of ``../shared/data/collection`` plus the meshes
of ``../shared/data/models``) and every level (``--levels``: ``default``, the
default of `decimate_mesh`, 0.5 % of the diagonal both ways; a number f, a budget of
f x the input's triangles; ``regions``, the region path `simplify_mesh` at its
default), ours runs with default options otherwise; then, at exactly our triangle
count:

- Open3D ``simplify_quadric_decimation``;
- pymeshlab ``meshing_decimation_quadric_edge_collapse`` with ``planarquadric`` off
  and on (MeshLab's quadric edge collapse; the planar quadric keeps flat parts flat).

Each output is measured both ways against the input surface with one metric
(`pointatlas.neighbors.point_mesh_distance`): the input's vertices and 20,000
seeded area samples to the output, and the output's vertices and 20,000 samples to
the input. ``mean`` is the average of the two directions' mean distances,
``hausdorff`` the larger maximum, both in % of the bounding-box diagonal; ``closed``
is closed + manifold + oriented (`mesh_checks`), ``euler`` V - E + F, ``crossings``
the pairs of triangles that pass through each other (`self_intersections`, which
"closed" cannot see). One CSV row
per model, level and method; the summary prints, per kind (CAD parts, by the
manifest's notes, and organic shapes), the geometric mean of ours / the best quadric
decimator for the mean and the Hausdorff distance, the worst model, and the time
ratio; then the same against the peers whose output keeps our topology (closedness
and Euler characteristic: ours keeps the input's), since MeshLab's collapses may
close a hole or open the surface at the smallest budgets.

``--subdivide-to N`` splits every input triangle into four at its edges' midpoints
until the mesh has at least N triangles (the same surface, tessellated as a finer
export of it would be), to measure large inputs: the time of the decimators grows
with the input, ours has a fixed part (the segmentation's passes, the level
search's measures, the polygons, the report's 20,000 samples both ways).
"""

from __future__ import annotations

import argparse
import csv
import json
import time
from pathlib import Path

import numpy as np

from pointatlas.io import read_mesh
from pointatlas.neighbors import point_mesh_distance
from pointatlas.simplify import decimate_mesh, mesh_checks, self_intersections, simplify_mesh
from pointatlas.synth import face_areas, sample_mesh

DATA = Path(__file__).resolve().parent.parent.parent / "shared" / "data"
MESH_SUFFIXES = (".obj", ".off", ".ply", ".stl")
SAMPLES = 20_000


def zero_area_triangles(v, tri, diag: float) -> int:
    """Triangles of (near) zero area: at most 1e-12 of the diagonal squared."""
    return int((face_areas(v, tri) <= 1e-12 * diag**2).sum()) if len(tri) else 0


def both_ways(v_in, t_in, v_out, t_out) -> dict:
    """Two-sided distances between two triangle meshes (% of the input's diagonal)."""
    diag = float(np.linalg.norm(np.ptp(v_in, axis=0)))

    def points(v, t):
        return np.vstack([v[np.unique(t)], sample_mesh(v, t, SAMPLES, rng=0).points])

    there = point_mesh_distance(points(v_in, t_in), v_out, t_out)
    back = point_mesh_distance(points(v_out, t_out), v_in, t_in)
    return {
        "mean": 50.0 * (there.mean() + back.mean()) / diag,
        "hausdorff": 100.0 * max(there.max(), back.max()) / diag,
        "in_to_out_max": 100.0 * there.max() / diag,
        "out_to_in_max": 100.0 * back.max() / diag,
    }


def open3d_quadric(v, t, n):
    import open3d as o3d

    mesh = o3d.geometry.TriangleMesh(
        o3d.utility.Vector3dVector(np.array(v, dtype=np.float64)),
        o3d.utility.Vector3iVector(np.array(t, dtype=np.int32)),
    )
    out = mesh.simplify_quadric_decimation(target_number_of_triangles=int(n))
    return np.asarray(out.vertices), np.asarray(out.triangles, dtype=np.int64)


def meshlab_quadric(v, t, n, planar: bool):
    import pymeshlab

    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(np.array(v, dtype=np.float64), np.array(t, dtype=np.int32)))
    ms.meshing_decimation_quadric_edge_collapse(targetfacenum=int(n), planarquadric=planar)
    out = ms.current_mesh()
    return np.asarray(out.vertex_matrix()), np.asarray(out.face_matrix(), dtype=np.int64)


PEERS = {
    "open3d_quadric": open3d_quadric,
    "meshlab_quadric": lambda v, t, n: meshlab_quadric(v, t, n, planar=False),
    "meshlab_planarquadric": lambda v, t, n: meshlab_quadric(v, t, n, planar=True),
}


def euler_characteristic(t) -> int:
    """V - E + F of the vertices on triangles, the edges and the triangles."""
    t = np.asarray(t, dtype=np.int64)
    if len(t) == 0:
        return 0
    edges = np.unique(
        np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), 1), axis=0
    )
    return int(np.unique(t).size - len(edges) + len(t))


def _row(model, kind, level, method, v, t, v_out, t_out, seconds) -> dict:
    used = np.unique(t_out)
    closed = all(mesh_checks(len(v_out), t_out)) if len(t_out) else False
    return {
        "model": model,
        "kind": kind,
        "level": level,
        "method": method,
        "triangles": int(len(t_out)),
        "vertices": int(used.size),
        "closed": closed,
        "euler": euler_characteristic(t_out),
        "crossings": len(self_intersections(v_out, t_out)) if len(t_out) else 0,
        "seconds": round(seconds, 3),
        **{k: round(float(x), 5) for k, x in both_ways(v, t, v_out, t_out).items()},
    }


def ours_at(v, t, level: str):
    """(method, result) of ours at a level (see the module)."""
    if level == "regions":
        return "pointatlas_regions", simplify_mesh(v, t)
    if level == "default":
        return "pointatlas", decimate_mesh(v, t)
    return "pointatlas", decimate_mesh(v, t, max(4, round(float(level) * len(t))))


def split_until(v, t, n: int):
    """Every triangle split into four at its edges' midpoints until at least ``n``."""
    import trimesh

    while len(t) < n:
        v, t = trimesh.remesh.subdivide(v, t)
    return np.asarray(v, dtype=np.float64), np.asarray(t, dtype=np.int64)


def run_model(path: Path, kind: str, levels, subdivide_to: int = 0) -> list[dict]:
    mesh = read_mesh(path)
    v, t = split_until(np.asarray(mesh.vertices), np.asarray(mesh.triangles), subdivide_to)
    rows = []
    for level in levels:
        start = time.perf_counter()
        method, ours = ours_at(v, t, level)
        took = time.perf_counter() - start
        n = len(ours.triangles)
        rows.append(
            _row(path.stem, kind, level, method, v, t, ours.vertices, ours.triangles, took)
            | {"polygons": len(ours.polygons), "input_triangles": len(t)}
        )
        for name, peer in PEERS.items():
            start = time.perf_counter()
            v_out, t_out = peer(v, t, n)
            took = time.perf_counter() - start
            rows.append(_row(path.stem, kind, level, name, v, t, v_out, t_out, took))
    return rows


def kinds() -> dict[str, str]:
    """Model file stem -> "cad" or "organic" (the manifest's notes name CAD parts)."""
    manifest = json.loads((DATA / "manifest.json").read_text())
    return {
        Path(e["file"]).stem: "cad" if "CAD" in e.get("notes", "") else "organic" for e in manifest
    }


def summary(rows: list[dict]) -> list[str]:
    """Geometric means of ours / the best quadric decimator, per kind and method; the
    outputs that pass through themselves, per method."""
    lines = []
    for ours_method in ("pointatlas", "pointatlas_regions"):
        lines += _summary(rows, ours_method)
    crossing = []
    for method in ("pointatlas", "pointatlas_regions", *PEERS):
        mine = [r for r in rows if r["method"] == method]
        if mine:
            n = sum(r["crossings"] > 0 for r in mine)
            pairs = sum(r["crossings"] for r in mine)
            crossing.append(f"{method} {n} / {len(mine)} ({pairs} pairs)")
    lines.append("outputs that pass through themselves: " + "; ".join(crossing))
    return lines


def _summary(rows: list[dict], ours_method: str) -> list[str]:
    lines = []
    key = {(r["model"], r["level"], r["method"]): r for r in rows}
    cases = sorted(
        {(r["model"], r["level"], r["kind"]) for r in rows if r["method"] == ours_method}
    )
    for kind in ("cad", "organic"):
        mine = [c for c in cases if c[2] == kind]
        if not mine:
            continue
        ratios = {"mean": [], "hausdorff": [], "seconds": []}
        topo = {"mean": [], "hausdorff": []}  # against the peers that keep our topology
        worst, over_changed = (0.0, None), 0
        for model, level, _ in mine:
            ours = key[(model, level, ours_method)]
            peers = [key[(model, level, m)] for m in PEERS if (model, level, m) in key]
            for metric in ratios:
                ratios[metric].append(_ratio(ours, peers, metric))
            same = [
                p for p in peers if (p["closed"], p["euler"]) == (ours["closed"], ours["euler"])
            ]
            if same:
                for metric in topo:
                    topo[metric].append(_ratio(ours, same, metric))
            if ratios["mean"][-1] > 1.5 and min(peers, key=lambda p: p["mean"]) not in same:
                over_changed += 1
            if ratios["mean"][-1] > worst[0]:
                worst = (ratios["mean"][-1], f"{model} at level {level}")
        gm = {m: float(np.exp(np.mean(np.log(x)))) for m, x in ratios.items()}
        closed = np.mean([key[(m, lv, ours_method)]["closed"] for m, lv, _ in mine])
        over = sum(r > 1.5 for r in ratios["mean"])
        kept = [key[(m, lv, ours_method)] for m, lv, _ in mine if lv == "default"]
        if kept:
            share = np.exp(np.mean([np.log(r["triangles"] / r["input_triangles"]) for r in kept]))
            lines.append(
                f"{ours_method}, {kind}, default level: triangles kept (geometric mean) "
                f"{100 * share:.1f} % of the input's, Hausdorff median "
                f"{np.median([r['hausdorff'] for r in kept]):.3f} %"
            )
        lines.append(
            f"{ours_method}, {kind}: {len(mine)} cases; ours / best quadric at equal "
            f"triangles: mean distance {gm['mean']:.2f}x, two-sided Hausdorff "
            f"{gm['hausdorff']:.2f}x, time {gm['seconds']:.1f}x; worst mean "
            f"{worst[0]:.2f}x ({worst[1]}); {over} cases over 1.5x; ours closed "
            f"{100 * closed:.0f} %"
        )
        if topo["mean"]:
            gk = {m: float(np.exp(np.mean(np.log(x)))) for m, x in topo.items()}
            lines.append(
                f"{ours_method}, {kind}: of the cases over 1.5x, {over_changed} against a "
                "peer output that changed the topology (closedness or Euler characteristic "
                f"not ours); against the peers that keep it ({len(topo['mean'])} cases): "
                f"mean {gk['mean']:.2f}x, Hausdorff {gk['hausdorff']:.2f}x, "
                f"{sum(r > 1.5 for r in topo['mean'])} cases over 1.5x"
            )
    return lines


def _ratio(ours: dict, peers: list[dict], metric: str) -> float:
    """Ours / the best of ``peers``; distances below 1e-4 % of the diagonal (exact on
    both sides) count as equal, seconds below 1 ms likewise."""
    floor = 1e-4 if metric != "seconds" else 1e-3
    return (ours[metric] + floor) / (min(p[metric] for p in peers) + floor)


def plot(rows: list[dict], path: Path, models: list[str]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(models), figsize=(5 * len(models), 4), squeeze=False)
    for ax, model in zip(axes[0], models, strict=True):
        for method in ["pointatlas", *PEERS]:
            pts = sorted(
                (r["triangles"], r["mean"])
                for r in rows
                if r["model"] == model and r["method"] == method and r["level"] != "regions"
            )
            if pts:
                x, y = zip(*pts, strict=True)
                ax.loglog(x, y, "o-", label=method)
        ax.set_title(model)
        ax.set_xlabel("triangles")
        ax.set_ylabel("two-sided mean distance (% of diagonal)")
    axes[0][0].legend(loc="upper right")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--every", type=int, default=5)
    parser.add_argument(
        "--levels", nargs="+", default=["default", "0.02", "0.05", "0.1", "0.2", "regions"]
    )
    parser.add_argument("--out", type=Path, default=Path("bench-output/simplify_rd"))
    parser.add_argument("--plot", type=Path, default=None)
    parser.add_argument("--subdivide-to", type=int, default=0, metavar="N")
    parser.add_argument("--no-models", action="store_true", help="the collection only")
    args = parser.parse_args()
    kind_of = kinds()
    files = sorted(p for p in (DATA / "collection").iterdir() if p.suffix in MESH_SUFFIXES)
    files = files[:: args.every]
    if not args.no_models:
        files += sorted(p for p in (DATA / "models").iterdir() if p.suffix in MESH_SUFFIXES)
    rows = []
    for path in files:
        try:
            kind = kind_of.get(path.stem, "organic")
            mine = run_model(path, kind, args.levels, args.subdivide_to)
        except Exception as exc:  # a peer that refuses a model is reported, not fatal
            print(f"{path.name}: skipped ({type(exc).__name__}: {exc})", flush=True)
            continue
        rows += mine
        ours = [r for r in mine if r["method"].startswith("pointatlas")]
        print(
            f"{path.name}: "
            + ", ".join(f"{r['triangles']} tri mean {r['mean']:.3f}%" for r in ours),
            flush=True,
        )
    args.out.mkdir(parents=True, exist_ok=True)
    fields = list(dict.fromkeys(k for r in rows for k in r))
    with open(args.out / "simplify_rd.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=fields)
        writer.writeheader()
        writer.writerows(rows)
    for line in summary(rows):
        print(line)
    if args.plot is not None:
        present = {r["model"] for r in rows}
        showcase = [m for m in ("fandisk_12494", "cad_a_a27", "euclid_bunny") if m in present]
        plot(rows, args.plot, showcase or [rows[0]["model"]])


if __name__ == "__main__":
    main()
