"""Where a sampled collection model's output leaves the truth, step by step.

Run from the repository root::

    .venv/bin/python benchmarks/trace_simplify_points.py cad_a_a5 cad_a_a13
    .venv/bin/python benchmarks/trace_simplify_points.py hfd_edge --estimate-normals
    .venv/bin/python benchmarks/trace_simplify_points.py cad_a_a5 --vertices

Each model is sampled as `bench_simplify_points.py` samples it (20,000 points, face
normals, or estimated with ``--estimate-normals``) and run through `simplify_points`
(default options). For three surfaces of the robust path, the voxel surface as built
(`reconstruct_surface`), level 0 (its vertices fitted to the points:
`_snap.fit_to_points`) and the output, it prints the farthest of its vertices, edge
midpoints and 20,000 area samples from the truth (the mesh sampled), where it lies,
and how far that position is from the nearest input point and from the points'
discs (`PointSurface`, what the level search and the report measure): a position
far from the truth but near the discs is one the report cannot see. Then the
farthest truth sample from the output, and its distance to the nearest input point
(far: a part the points do not sample; near: a part the output lost). Distances in
% of the points' diagonal. Decisions: docs/decisions/simplify.md, "The output's edge
midpoints, measured back to the points".

With ``--estimate-normals`` it first prints how many of the estimated normals point
against the true face normals of the same points, as given to `simplify_points` and
after its input step (`_points_input._outward`, which may turn some): a step that
undoes another's turns shows there.

With ``--vertices`` it also prints, for the voxel surface and level 0, how many of
their vertices lie over ``FAR`` % of the diagonal from the truth and how far those are
from the nearest point in points' spacings (their median nearest-neighbour distance),
beside the vertices within it (their 99.9th percentile and largest, and how many are
at least as far as the nearest far one): whether the distance to the points could
tell the far vertices from the others.
"""

from __future__ import annotations

import argparse
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
from bench_simplify_points import Sampling
from scipy.spatial import cKDTree

import pointatlas.simplify._points_input as points_input
import pointatlas.simplify._snap as snap
from pointatlas.io import read_mesh
from pointatlas.neighbors import point_mesh_distance
from pointatlas.simplify import SimplifyWarning, simplify_points
from pointatlas.simplify._distance import PointSurface, point_back_samples
from pointatlas.simplify._frame import frame_of
from pointatlas.synth import sample_mesh

COLLECTION = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "collection"


def level_zero(points, normals) -> tuple[dict, object, np.ndarray]:
    """``simplify_points``' result, the robust path's first two surfaces in its
    working frame: ``{"voxel": (v, t), "level 0": (v, t)}`` (empty on the thesis
    path), caught at `_snap.fit_to_points`, and the normals of the points used after
    the input step (caught at `_points_input._outward`)."""
    caught, turned = {}, {}
    fit, outward = snap.fit_to_points, points_input._outward

    def catch(verts, tri, *args, **kwargs):
        out = fit(verts, tri, *args, **kwargs)
        caught["voxel"], caught["level 0"] = (verts.copy(), tri.copy()), (out.copy(), tri.copy())
        return out

    def catch_normals(*args, **kwargs):
        out, count = outward(*args, **kwargs)
        turned["normals"] = out.copy()
        return out, count

    snap.fit_to_points, points_input._outward = catch, catch_normals
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", SimplifyWarning)
            result = simplify_points(points, normals)
    finally:
        snap.fit_to_points, points_input._outward = fit, outward
    return caught, result, turned["normals"]


def inward_line(normals, after, truth, used) -> str:
    """How many of ``normals`` (estimated) point against the true ones ``truth``, and
    how many of ``after`` (the input step's, for the points ``used``)."""
    before = int((np.einsum("ij,ij->i", normals, truth) < 0.0).sum())
    then = int((np.einsum("ij,ij->i", after, truth[used]) < 0.0).sum())
    return (
        f"  normals  {before} of {normals.shape[0]} against the true ones as estimated, "
        f"{then} of {used.size} after the input step"
    )


def farthest(label, mesh, truth, near, diag) -> str:
    """The farthest of ``mesh``'s back samples from ``truth`` (vertices, triangles),
    and that position's distances to the nearest point and to the discs ``near``
    (a `PointSurface`), in % of ``diag``."""
    x = point_back_samples(*mesh)
    d = point_mesh_distance(x, *truth)
    i = int(np.argmax(d))
    at = x[i : i + 1]
    point = float(near.tree.query(at)[0][0])
    disc = float(near.distance(at)[0])
    where = np.array2string(at[0], precision=3)
    return (
        f"  {label:8s} {100 * d[i] / diag:5.2f} % from the truth at {where}: "
        f"{100 * point / diag:.2f} % from the nearest point, {100 * disc / diag:.2f} % "
        "from the discs"
    )


#: ``--vertices``: a surface vertex this far from the truth (% of the diagonal) is far
FAR = 0.9


def far_vertices(label, mesh, truth, tree, diag) -> str:
    """``--vertices``' line for one surface ``mesh`` (vertices, triangles)."""
    v = mesh[0]
    spacing = float(np.median(tree.query(tree.data, k=2)[0][:, 1]))
    far = point_mesh_distance(v, *truth) > FAR * diag / 100.0
    near = tree.query(v)[0] / spacing
    if not far.any():
        return f"  {label:8s} vertices: none over {FAR} % of the truth"
    first = float(near[far].min())
    return (
        f"  {label:8s} vertices: {int(far.sum())} of {v.shape[0]} over {FAR} % of the "
        f"truth, {first:.1f}-{float(np.median(near[far])):.1f} (min-median) spacings "
        f"from the nearest point; the others up to {np.quantile(near[~far], 0.999):.1f} "
        f"(99.9 %) and {near[~far].max():.1f}, {int((near[~far] >= first).sum())} of them "
        f"{first:.1f} or more"
    )


def trace(path: Path, sampling: Sampling, vertices: bool = False) -> list[str]:
    mesh = read_mesh(path)
    tri = np.asarray(mesh.triangles, dtype=np.int64)
    truth = (np.asarray(mesh.vertices), tri)
    p, n = sampling.sample(mesh.vertices, tri)
    diag = float(np.linalg.norm(np.ptp(p, axis=0)))
    caught, result, after = level_zero(p, n)
    near = PointSurface(p, n)
    lines = [f"{path.name} ({result.path}, {len(result.mesh.triangles)} triangles)"]
    if sampling.estimate:  # the same points with their true normals
        truth_n = replace(sampling, estimate=False).sample(mesh.vertices, tri)[1]
        lines.append(inward_line(n, after, truth_n, result.point_index))
    if caught:
        frame = frame_of(p[result.point_index])
        for label, (v, t) in caught.items():
            lines.append(farthest(label, (frame.to_input(v), t), truth, near, diag))
            if vertices:
                tree = cKDTree(p)
                lines.append(far_vertices(label, (frame.to_input(v), t), truth, tree, diag))
    out = (np.asarray(result.mesh.vertices), np.asarray(result.mesh.triangles))
    lines.append(farthest("output", out, truth, near, diag))
    samples = np.vstack([truth[0], sample_mesh(*truth, 20000, rng=1).points])
    d = point_mesh_distance(samples, *out)
    i = int(np.argmax(d))
    point = float(cKDTree(p).query(samples[i])[0])
    lines.append(
        f"  {'truth':8s} {100 * d[i] / diag:5.2f} % from the output at "
        f"{np.array2string(samples[i], precision=3)}: {100 * point / diag:.2f} % from the "
        "nearest point"
    )
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("models", nargs="+", help="collection file names, with or without suffix")
    ap.add_argument("--models-dir", type=Path, default=COLLECTION)
    ap.add_argument("--points", type=int, default=20000)
    ap.add_argument("--estimate-normals", action="store_true")
    ap.add_argument("--vertices", action="store_true", help="the far vertices' lines too")
    args = ap.parse_args()
    sampling = Sampling(points=args.points, estimate=args.estimate_normals)
    for name in args.models:
        path = args.models_dir / name
        if not path.exists():
            path = next(args.models_dir.glob(Path(name).stem + ".*"))
        print("\n".join(trace(path, sampling, args.vertices)), flush=True)


if __name__ == "__main__":
    main()
