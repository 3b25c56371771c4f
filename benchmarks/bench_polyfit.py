"""`simplify_points` vs CGAL PolyFit on point sets sampled from the collection.

Run from the repository root::

    .venv/bin/python benchmarks/bench_polyfit.py --every 6 --out bench-output/polyfit.csv
    # PolyFit on our point labels and on the planes CGAL's RANSAC detects as well
    .venv/bin/python benchmarks/bench_polyfit.py --every 12 --planes faces,regions,ransac

Needs CGAL 5.5 and GLPK, from Debian's packages (used by this benchmark only)::

    apt-get install -y --no-install-recommends libcgal-dev libglpk-dev

The peer is ``benchmarks/cgal_polyfit.cpp``, compiled here with g++ once into
``--build`` (a minute or two of CPU) and reused while it is newer than its source;
without the headers the benchmark says so and stops.

Every ``--every``-th model (sorted by name) is sampled as in bench_simplify_points.py
(20,000 points with face normals, `pointatlas.synth.sample_mesh`, seed 0) and goes
through `pointatlas.simplify.simplify_points` with default options. PolyFit
(``CGAL::Polygonal_surface_reconstruction``, GLPK as the solver, CGAL's default
weights: data fitting 0.43, coverage 0.27, complexity 0.3) gets the same points and
normals with a plane index per point (-1 for none), one run per ``--planes`` entry:

* ``faces`` (default): the face of our output every point is nearest to, so PolyFit
  starts from our faces;
* ``regions``: ``simplify_points``' own point labels (``labels`` of the points in
  ``point_index``, -1 for those left out). On the robust path (more than 17,000
  points) these are the segmentation's regions carried to the points' surface, before
  the decimation merges them: often many more than the faces (70 on the 20 mm cube
  whose output has 6);
* ``ransac``: none; the driver detects the planes by CGAL's efficient RANSAC (planes
  only, default parameters, seed 0), as CGAL's example without input planes does.

PolyFit is run with a wall-clock limit (``--timeout``, 120 s); it is not solved when
it has more than ``--max-planes`` planes (100: building its candidate faces alone
takes minutes with a few hundred; 36 planes already give over 4,000 candidates) or
builds more than ``--max-candidates`` candidate faces (2,500: GLPK stalls beyond). A
stall, a crash or a refusal is recorded as such and not retried.

PolyFit keeps the candidate faces it selects as separate polygons (convex: pieces of
the planes cut by the other planes; checked here), so a plane can carry several; its
``faces`` here are the polygons merged across edges between polygons of one plane,
``polygons`` the polygons as written. Its triangles are the polygons fanned. It writes
every polygon with its own copies of its corners; the bit-identical ones are welded
before the closed / manifold / oriented checks (`pointatlas.simplify.mesh_checks`).

One CSV row per model: ours (path, faces, triangles, closed, manifold, oriented, mean
and two-sided Hausdorff distance to the truth as `both_ways` of bench_simplify_rd.py,
% of the truth's diagonal, seconds) and the same per PolyFit variant, with its status
(solved, solved with no face, too many planes or candidates, timeout, failed,
crashed), planes and candidate faces; where PolyFit solved, ours again with its
triangle count as the budget (``max_triangles``; ``matched_*``) and ours at
PolyFit's error: its two-sided Hausdorff distance to the truth as our ``max_error``
(``errmatched_*``: the issue's "fewer or equal faces at equal or lower error" asks
how many faces ours needs where PolyFit's error is allowed); both unless
``--no-matched``. The summary per kind counts, on the models PolyFit solved, those
where ours (at its default, at PolyFit's triangle count, at PolyFit's error) has <=
faces and <= mean distance (and <= Hausdorff distance, distances within 1e-4 % equal),
and how many are closed.
"""

from __future__ import annotations

import argparse
import csv
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
from bench_simplify_points import KINDS, MESH_SUFFIXES
from bench_simplify_rd import both_ways

from pointatlas.io import read_mesh
from pointatlas.simplify import SimplifyWarning, mesh_checks, simplify_points
from pointatlas.synth import sample_mesh

SRC = Path(__file__).resolve().with_name("cgal_polyfit.cpp")
HEADERS = (
    Path("/usr/include/CGAL/Polygonal_surface_reconstruction.h"),
    Path("/usr/include/glpk.h"),
)
#: distances below this (% of the diagonal) count as equal, as in bench_simplify_rd.py
EPS_PCT = 1e-4
#: columns of ours at PolyFit's triangle count
MATCHED = ("faces", "triangles", "closed", "mean_pct", "hausdorff_pct")
STATUS = {
    0: "solved",
    1: "failed",
    2: "bad input",
    3: "too many candidates",
    4: "too many planes",
}


def build(build_dir: Path) -> tuple[Path | None, str]:
    """The driver, compiled once into ``build_dir`` (again when the source is newer)."""
    exe = build_dir / "cgal_polyfit"
    if exe.exists() and exe.stat().st_mtime >= SRC.stat().st_mtime:
        return exe, ""
    missing = [str(h) for h in HEADERS if not h.exists()]
    if missing:
        return None, (
            f"{', '.join(missing)} missing: apt-get install -y --no-install-recommends "
            "libcgal-dev libglpk-dev"
        )
    build_dir.mkdir(parents=True, exist_ok=True)
    cmd = [
        "g++",
        "-O2",
        "-DNDEBUG",
        "-std=c++17",
        str(SRC),
        "-o",
        str(exe),
        "-I/usr/include/eigen3",
        "-lglpk",
        "-lgmp",
        "-lmpfr",
    ]
    print(f"compiling {SRC.name} into {build_dir} (a minute or two)", flush=True)
    res = subprocess.run(cmd, capture_output=True, text=True, timeout=1800)
    if res.returncode != 0:
        return None, f"compiling {SRC.name} failed: {res.stderr.strip()[-500:]}"
    return exe, ""


def polygon_stats(vertices: np.ndarray, polygons: list[np.ndarray]) -> dict:
    """Polygons merged per plane across shared edges, and the non-convex ones."""
    diag = float(np.linalg.norm(np.ptp(vertices, axis=0))) or 1.0
    normals, offsets, nonconvex = [], [], 0
    for poly in polygons:
        q = vertices[poly]
        # Newell's normal: the polygon's area vector
        nrm = np.cross(q, np.roll(q, -1, axis=0)).sum(axis=0)
        nrm /= np.linalg.norm(nrm) or 1.0
        normals.append(nrm)
        offsets.append(float(nrm @ q.mean(axis=0)))
        e = np.roll(q, -1, axis=0) - q
        turns = np.cross(e, np.roll(e, -1, axis=0)) @ nrm
        nonconvex += bool((turns < -1e-9 * diag**2).any())
    parent = list(range(len(polygons)))

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    edge_face: dict[tuple[int, int], int] = {}
    for f, poly in enumerate(polygons):
        for a, b in zip(poly, np.roll(poly, -1), strict=True):
            key = (min(a, b), max(a, b))
            g = edge_face.setdefault(key, f)
            same = normals[f] @ normals[g] > 1 - 1e-9 and abs(offsets[f] - offsets[g]) < 1e-9 * diag
            if g != f and same:
                parent[find(f)] = find(g)
    return {
        "faces": len({find(f) for f in range(len(polygons))}),
        "nonconvex": nonconvex,
    }


def run_polyfit(exe, p, n, planes, limits: tuple[int, int], timeout: float, ransac: bool) -> dict:
    """One PolyFit run: status, planes, candidates, mesh measures (no truth yet)."""
    row: dict = {}
    with tempfile.TemporaryDirectory() as tmp:
        src, dst = Path(tmp) / "in.txt", Path(tmp) / "out.off"
        np.savetxt(src, np.column_stack([p, n, planes]), fmt=["%.17g"] * 6 + ["%d"])
        cmd = [str(exe), str(src), str(dst), *map(str, limits)] + (["ransac"] if ransac else [])
        t0 = time.perf_counter()
        try:
            res = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
        except subprocess.TimeoutExpired as exc:
            out = exc.stdout.decode() if isinstance(exc.stdout, bytes) else exc.stdout or ""
            row.update(status="timeout", seconds=time.perf_counter() - t0)
            res = None
        wall = time.perf_counter() - t0
        if res is not None:
            out = res.stdout
            if res.returncode < 0:
                row["status"] = f"crashed (signal {-res.returncode})"
            else:
                row["status"] = STATUS.get(res.returncode, f"exit {res.returncode}")
            if res.returncode not in (0, 3, 4):
                row["note"] = res.stderr.strip().replace("\n", " ")[:200]
        for line in out.splitlines():
            key, *vals = line.split()
            if key in ("planes", "candidates"):
                row[key] = int(vals[0])
            elif key == "seconds":
                row["seconds"] = float(vals[0])
        row.setdefault("seconds", wall)
        if row["status"] == "solved" and dst.read_text().split()[2] == "0":
            row["status"] = "solved, no face"  # it kept none of the candidates
        if row["status"] != "solved":
            return row
        mesh = read_mesh(dst)
    # each face comes with its own copies of its corners: weld the identical ones
    v, inverse = np.unique(np.asarray(mesh.vertices), axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    tri = inverse[np.asarray(mesh.triangles, dtype=np.int64)]
    polygons = [inverse[f] for f in mesh.face_list()]
    closed, manifold, oriented = mesh_checks(len(v), tri) if len(tri) else (False,) * 3
    row.update(
        polygon_stats(v, polygons),
        polygons=len(polygons),
        triangles=int(tri.shape[0]),
        closed=closed,
        manifold=manifold,
        oriented=oriented,
        _mesh=(v, tri),
    )
    return row


def face_labels(points, vertices, triangles, triangle_face) -> np.ndarray:
    """The face of our mesh every point is nearest to (Open3D's closest points)."""
    import open3d as o3d

    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(
        o3d.core.Tensor(np.asarray(vertices, dtype=np.float32)),
        o3d.core.Tensor(np.asarray(triangles, dtype=np.uint32)),
    )
    got = scene.compute_closest_points(o3d.core.Tensor(np.asarray(points, dtype=np.float32)))
    return np.asarray(triangle_face)[got["primitive_ids"].numpy().astype(np.int64)]


def ours(p, n, v_true, t_true, **options) -> tuple[dict, object]:
    """`simplify_points` with ``options``, measured against the truth: (row, result)."""
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SimplifyWarning)
        r = simplify_points(p, n, **options)
    seconds = time.perf_counter() - t0
    m = r.mesh
    mv, mt = np.asarray(m.vertices), np.asarray(m.triangles, dtype=np.int64)
    closed, manifold, oriented = mesh_checks(m.n_vertices, mt)
    d = both_ways(v_true, t_true, mv, mt)
    row = {
        "path": r.path,
        "faces": m.n_faces,
        "triangles": int(mt.shape[0]),
        "closed": closed,
        "manifold": manifold,
        "oriented": oriented,
        "mean_pct": d["mean"],
        "hausdorff_pct": d["hausdorff"],
        "seconds": seconds,
    }
    return row, r


def run_model(path: Path, n_points: int, exe, variants, limits, timeout, matched) -> dict:
    mesh = read_mesh(path)
    v_true, t_true = mesh.vertices, np.asarray(mesh.triangles, dtype=np.int64)
    sample = sample_mesh(v_true, t_true, n_points, rng=0)
    p, n = np.asarray(sample.points), np.asarray(sample.normals)
    row = {"model": path.name, "kind": KINDS.get(path.stem, "organic"), "points": n_points}
    t0 = time.perf_counter()
    try:
        got, r = ours(p, n, v_true, t_true)
    except Exception as exc:  # noqa: BLE001 - a crash is a result here
        row.update(path="error", seconds=time.perf_counter() - t0, note=repr(exc)[:200])
        return row
    row.update(got)
    m = r.mesh
    tri_face = np.asarray(m.triangle_face)
    labels = {"faces": face_labels(p, m.vertices, m.triangles, tri_face), "ransac": None}
    labels["regions"] = np.full(len(p), -1, dtype=np.int64)
    labels["regions"][np.asarray(r.point_index)] = np.asarray(r.labels)
    for name in variants:
        planes = labels[name] if labels[name] is not None else np.full(len(p), -1)
        got = run_polyfit(exe, p, n, planes, limits, timeout, name == "ransac")
        if "_mesh" in got:
            pv, pt = got.pop("_mesh")
            d = both_ways(v_true, t_true, pv, pt)
            got.update(mean_pct=d["mean"], hausdorff_pct=d["hausdorff"])
            if matched:
                # ours with PolyFit's triangle count as its budget
                try:
                    at, _ = ours(p, n, v_true, t_true, max_triangles=got["triangles"])
                    got.update({f"matched_{k}": at[k] for k in MATCHED})
                except Exception as exc:  # noqa: BLE001 - a crash is a result here
                    got["note"] = f"ours at PolyFit's size: {exc!r}"[:200]
                # ours allowed PolyFit's error (its Hausdorff distance, absolute)
                diag = float(np.linalg.norm(np.ptp(v_true, axis=0)))
                bound = d["hausdorff"] / 100.0 * diag
                try:
                    at, _ = ours(p, n, v_true, t_true, max_error=bound)
                    got.update({f"errmatched_{k}": at[k] for k in MATCHED})
                except Exception as exc:  # noqa: BLE001 - a crash is a result here
                    got["note"] = f"ours at PolyFit's error: {exc!r}"[:200]
        row.update({f"{name}_{k}": val for k, val in got.items()})
    return row


def _leq(a: float, b: float) -> bool:
    return a <= b + EPS_PCT


def _wins(solved, name, prefix="") -> str:
    """Of ``solved``: ours (or ours at PolyFit's size) <= faces, and <= mean distance,
    and <= Hausdorff; lower mean distance alone; closed."""
    rows = [r for r in solved if f"{prefix}mean_pct" in r]
    if not rows:
        return "none"
    ours_of = {r["model"]: {k: r[f"{prefix}{k}"] for k in MATCHED} for r in rows}

    def theirs(r, key):
        return r[f"{name}_{key}"]

    fewer = [r for r in rows if ours_of[r["model"]]["faces"] <= theirs(r, "faces")]
    both = [r for r in fewer if _leq(ours_of[r["model"]]["mean_pct"], theirs(r, "mean_pct"))]
    hd = [r for r in both if _leq(ours_of[r["model"]]["hausdorff_pct"], theirs(r, "hausdorff_pct"))]
    nearer = [r for r in rows if _leq(ours_of[r["model"]]["mean_pct"], theirs(r, "mean_pct"))]
    return (
        f"<= faces {len(fewer)}/{len(rows)}, <= faces and <= mean distance {len(both)}, "
        f"and <= Hausdorff too {len(hd)}; <= mean distance alone {len(nearer)}; faces "
        f"median {np.median([ours_of[r['model']]['faces'] for r in rows]):.0f} vs "
        f"{np.median([theirs(r, 'faces') for r in rows]):.0f}, mean distance median "
        f"{np.median([ours_of[r['model']]['mean_pct'] for r in rows]):.3f} % vs "
        f"{np.median([theirs(r, 'mean_pct') for r in rows]):.3f} %; closed "
        f"{sum(bool(ours_of[r['model']]['closed']) for r in rows)} vs "
        f"{sum(bool(theirs(r, 'closed')) for r in rows)}"
    )


def summary(rows: list[dict], variants) -> list[str]:
    lines = []
    for kind in ("cad", "organic"):
        mine = [r for r in rows if r["kind"] == kind and r.get("path") != "error"]
        if not mine:
            continue
        for name in variants:
            solved = [r for r in mine if r.get(f"{name}_status") == "solved"]
            stat = {}
            for r in mine:
                s = r.get(f"{name}_status", "-")
                stat[s] = stat.get(s, 0) + 1
            lines.append(
                f"{kind} ({len(mine)}), PolyFit on {name} planes: "
                + ", ".join(f"{k} {v}" for k, v in sorted(stat.items()))
            )
            if solved:
                lines.append(f"  ours (default) vs PolyFit: {_wins(solved, name)}")
                lines.append(
                    f"  ours at PolyFit's triangle count: {_wins(solved, name, f'{name}_matched_')}"
                )
                lines.append(
                    f"  ours at PolyFit's error: {_wins(solved, name, f'{name}_errmatched_')}"
                )
        lines.append(
            f"{kind}: ours closed {sum(bool(r['closed']) for r in mine)}/{len(mine)} models"
        )
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--models", type=Path, default=Path("../shared/data/collection"))
    ap.add_argument("--every", type=int, default=6)
    ap.add_argument("--points", type=int, default=20000)
    ap.add_argument(
        "--planes",
        default="faces",
        help="PolyFit's planes, comma-separated runs: faces (our output's faces), "
        "regions (our point labels), ransac (CGAL's efficient RANSAC)",
    )
    ap.add_argument(
        "--no-matched",
        action="store_true",
        help="skip ours at PolyFit's triangle count and at its error (two more "
        "simplify_points runs)",
    )
    ap.add_argument("--max-planes", type=int, default=100)
    ap.add_argument("--max-candidates", type=int, default=2500)
    ap.add_argument("--timeout", type=float, default=120.0, help="seconds per PolyFit run")
    ap.add_argument("--build", type=Path, default=Path("bench-output/polyfit-build"))
    ap.add_argument("--out", type=Path, default=Path("bench-output/polyfit.csv"))
    args = ap.parse_args(argv)
    exe, why = build(args.build)
    if exe is None:
        print(f"CGAL PolyFit: skipped ({why})")
        return 0
    variants = tuple(args.planes.split(","))
    if not set(variants) <= {"faces", "regions", "ransac"}:
        ap.error(f"--planes: faces, regions or ransac, not {args.planes}")
    files = sorted(p for p in args.models.iterdir() if p.suffix.lower() in MESH_SUFFIXES)
    rows = []
    for path in files[:: args.every]:
        limits = (args.max_planes, args.max_candidates)
        row = run_model(path, args.points, exe, variants, limits, args.timeout, not args.no_matched)
        rows.append(row)
        text = (
            f"{row['model']:40s} {row['kind']:7s} ours: faces={row.get('faces', '-')!s:>4} "
            f"closed={row.get('closed', '-')!s:5} mean={row.get('mean_pct', np.nan):.3f}% "
            f"H={row.get('hausdorff_pct', np.nan):.2f}% {row['seconds']:.1f}s"
        )
        for name in variants:
            text += (
                f" | {name}: {row.get(f'{name}_status', '-')} planes="
                f"{row.get(f'{name}_planes', '-')} cand={row.get(f'{name}_candidates', '-')}"
            )
            if row.get(f"{name}_status") == "solved":
                text += (
                    f" faces={row[f'{name}_faces']} closed={row[f'{name}_closed']} "
                    f"mean={row[f'{name}_mean_pct']:.3f}% H={row[f'{name}_hausdorff_pct']:.2f}%"
                )
            text += f" {row.get(f'{name}_seconds', np.nan):.1f}s"
        print(text, flush=True)
    keys = [
        "model",
        "kind",
        "points",
        "path",
        "faces",
        "triangles",
        "closed",
        "manifold",
        "oriented",
        "mean_pct",
        "hausdorff_pct",
        "seconds",
    ]
    for name in variants:
        keys += [
            f"{name}_{k}"
            for k in (
                "status",
                "planes",
                "candidates",
                "faces",
                "polygons",
                "nonconvex",
                "triangles",
                "closed",
                "manifold",
                "oriented",
                "mean_pct",
                "hausdorff_pct",
                "seconds",
                *(f"matched_{k}" for k in MATCHED),
                *(f"errmatched_{k}" for k in MATCHED),
                "note",
            )
        ]
    keys.append("note")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with open(args.out, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=keys)
        w.writeheader()
        for row in rows:
            w.writerow({k: row.get(k, "") for k in keys})
    print()
    for line in summary(rows, variants):
        print(line)
    print(f"written: {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
