"""Raw points' normals for `simplify`, step by step, against the true face normals and
against Open3D's estimate + orientation, on sampled collection models.

Run from the repository root::

    .venv/bin/python benchmarks/bench_normals_raw.py --every 6
    .venv/bin/python benchmarks/bench_normals_raw.py --every 1 --shard 0/2 --out a.csv
    .venv/bin/python benchmarks/bench_normals_raw.py --every 3 --falloff 10 --no-peer

Each model is sampled as `bench_simplify_points.py` samples it (20,000 points by
area unless its sampling options say otherwise, the same options and seeds; the
true face normals of the points kept aside, a point moved by ``--noise`` or
``--outliers`` keeping its face's) and its normals are estimated as
``pointatlas simplify`` estimates them for raw points (`simplify_estimated`'s first
estimate, k = 20), step by step:

- ``pca``: `surface_normals` (PCA, the least-entropy size where bent; no sign);
- ``orient``: `pointatlas.normals.orient_normals` (propagation over the k-NN graph);
- ``sharp``: `sharpen_normals` (planes beside edges and thin walls);
- ``outward``: `outward_normals` (sheets and patches turned outward).

Per step it counts the normals more than 30 degrees off the true normal's line
(``off``: direction, sign ignored) and, from ``orient`` on, those pointing against it
(``in``). The peer, what a user of Open3D runs: ``estimate_normals`` (k = 20) and
``orient_normals_consistent_tangent_plane`` (k = 10); its field is consistent but
has no outside, so it is given the better of its two global signs (a user would
turn it by hand). Where the dipole test calls our sample open
(`_reconstruct.is_closed_sample`), ``open`` is set.
Prints one line per model and the totals; ``--out`` writes the rows as CSV (two runs'
CSVs, before and after a change of the normals' steps, say which rows of the
simplify tables to run again).
Decisions: docs/decisions/simplify.md, "Normals for raw points".
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from bench_simplify_points import KINDS, MESH_SUFFIXES, Sampling

from pointatlas.io import read_mesh
from pointatlas.normals import orient_normals
from pointatlas.simplify import outward_normals, sharpen_normals, surface_normals
from pointatlas.simplify._reconstruct import is_closed_sample

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "collection"
#: Neighbourhood sizes: the CLI's ``--normal-k`` and Open3D's orientation graph.
K, K_ORIENT_PEER = 20, 10
#: A normal is off where its line is more than this far from the true one (degrees).
OFF_DEGREES = 30.0


def counts(n: np.ndarray, truth: np.ndarray, signed: bool) -> dict:
    """How many normals ``n`` lie off the true line, and (``signed``) point in."""
    dot = np.einsum("ij,ij->i", n, truth)
    out = {"off": int((np.abs(dot) < np.cos(np.radians(OFF_DEGREES))).sum())}
    if signed:
        out["in"] = int((dot < 0.0).sum())
    return out


def ours(p: np.ndarray, truth: np.ndarray) -> dict:
    """Our steps' counts (`counts`), the time of all of them and whether the sample
    reads open."""
    row = {}
    t0 = time.perf_counter()
    pca = surface_normals(p, k=K)
    row.update({f"pca_{key}": v for key, v in counts(pca, truth, False).items()})
    oriented = orient_normals(p, pca)
    row["orient_in"] = counts(oriented, truth, True)["in"]  # the same lines as pca's
    sharp = sharpen_normals(p, oriented)
    row.update({f"sharp_{key}": v for key, v in counts(sharp, truth, True).items()})
    out = outward_normals(p, sharp)
    row["seconds"] = time.perf_counter() - t0
    row.update({f"outward_{key}": v for key, v in counts(out, truth, True).items()})
    row["open"] = not is_closed_sample(p, out)
    return row


def peer(p: np.ndarray, truth: np.ndarray) -> dict:
    """Open3D's counts (`counts`, the better global sign) and time."""
    import open3d as o3d

    t0 = time.perf_counter()
    pc = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.array(p, dtype=np.float64)))
    pc.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(K))
    try:  # its graph is qhull's Delaunay: a topology error on some CAD samples
        pc.orient_normals_consistent_tangent_plane(K_ORIENT_PEER)
    except RuntimeError:
        return {"peer_crashed": True}
    n = np.asarray(pc.normals)
    seconds = time.perf_counter() - t0
    if np.einsum("ij,ij->i", n, truth).mean() < 0.0:
        n = -n
    found = {f"peer_{key}": v for key, v in counts(n, truth, True).items()}
    return found | {"peer_seconds": seconds, "peer_crashed": False}


def run_model(path: Path, with_peer: bool, sampling: Sampling | None = None) -> dict:
    """One model's row (``sampling``: true normals, as `bench_simplify_points.py`)."""
    mesh = read_mesh(path)
    sampling = Sampling() if sampling is None else sampling
    p, truth = sampling.sample(mesh.vertices, np.asarray(mesh.triangles, dtype=np.int64))
    row = {"model": path.name, "kind": KINDS.get(path.stem, "organic"), "points": p.shape[0]}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        row.update(ours(p, truth))
        if with_peer:
            row.update(peer(p, truth))
    return row


def line(row: dict) -> str:
    """One model's line."""
    text = (
        f"{row['model'][:40]:40s} off pca {row['pca_off']:5d} "
        f"sharp {row['sharp_off']:5d} outward {row['outward_off']:5d} | in orient "
        f"{row['orient_in']:5d} sharp {row['sharp_in']:5d} outward {row['outward_in']:5d}"
        f"{' (open)' if row['open'] else ''}"
    )
    if "peer_off" in row:
        text += f" | Open3D off {row['peer_off']:5d} in {row['peer_in']:5d}"
    elif row.get("peer_crashed"):
        text += " | Open3D: orientation crashed"
    return text


def totals(rows: list[dict]) -> list[str]:
    """The sums over all rows, and ours beside the peer's where the peer ran."""
    points = sum(r["points"] for r in rows)
    keys = [k for k in rows[0] if k.endswith(("_off", "_in")) and not k.startswith("peer")]
    lines = [
        f"{len(rows)} models, {points} points, {sum(r['open'] for r in rows)} read open: "
        + ", ".join(f"{k} {sum(r[k] for r in rows)}" for k in keys)
    ]
    ran = [r for r in rows if "peer_off" in r]
    if ran:
        n = sum(r["points"] for r in ran)
        pairs = [("outward_off", "peer_off"), ("outward_in", "peer_in")]
        lines.append(
            f"where Open3D ran ({len(ran)} models, {n} points; crashed "
            f"{sum(bool(r.get('peer_crashed')) for r in rows)}): "
            + ", ".join(
                f"{a.split('_')[1]} ours {sum(r[a] for r in ran)} "
                f"({100.0 * sum(r[a] for r in ran) / n:.2f} %), Open3D "
                f"{sum(r[b] for r in ran)} ({100.0 * sum(r[b] for r in ran) / n:.2f} %)"
                for a, b in pairs
            )
        )
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--models", type=Path, default=DATA, help="folder of meshes")
    ap.add_argument("--every", type=int, default=6, help="every n-th model (sorted by name)")
    ap.add_argument("--shard", default="0/1", help="i/n: the i-th of n shards (from 0)")
    ap.add_argument("--no-peer", action="store_true", help="leave Open3D out")
    ap.add_argument("--out", type=Path, help="CSV of the rows")
    ap.add_argument("--points", type=int, default=20000, help="points per model")
    ap.add_argument("--noise", type=float, default=0.0, help="sigma in %% of the diagonal")
    ap.add_argument("--falloff", type=float, default=1.0, help="density falling along x")
    ap.add_argument("--no-bottom", action="store_true", help="no points facing down")
    ap.add_argument("--view", action="store_true", help="the points one scanner sees")
    ap.add_argument("--outliers", type=float, default=0.0, help="%% of the points moved off")
    args = ap.parse_args(argv)
    sampling = Sampling(
        args.points, False, args.noise, args.falloff, args.no_bottom, args.view, args.outliers
    )
    i, n = (int(x) for x in args.shard.split("/"))
    paths = sorted(x for x in args.models.iterdir() if x.suffix.lower() in MESH_SUFFIXES)
    rows = []
    for path in paths[:: args.every][i::n]:
        rows.append(run_model(path, not args.no_peer, sampling))
        print(line(rows[-1]), flush=True)
    if not rows:
        print("no models", file=sys.stderr)
        return 1
    print("\n" + "\n".join(totals(rows)))
    if args.out:
        fields = list(dict.fromkeys(k for r in rows for k in r))
        with args.out.open("w", newline="") as fh:
            writer = csv.DictWriter(fh, fieldnames=fields, restval="")
            writer.writeheader()
            writer.writerows(rows)
        print(f"written: {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
