"""What one tile computes (run on a dask worker): normals, features, denoising, segments.

Private to `pointatlas.batch`. Every task takes ``(spec, data)``: ``spec`` a dict
(grid, tile id, halo, parameters), ``data`` the tile's points in increasing global
index order (``gidx``, ``xyz``, optional ``normals``). It returns a dict with
``status`` "ok" (results for the owned points, plus what the stitching needs) or
"halo" (the halo is too narrow for an exact result; ``needed`` says how wide it
must be).
"""

from __future__ import annotations

import math
import os

import numpy as np

from ._tiles_grid import exact_tile_knn

__all__ = ["TASKS", "features_dispatch"]


def _threads(spec) -> None:
    """One tile per worker thread: numba kernels use ``spec["threads"]`` threads."""
    threads = spec.get("threads")
    if threads:
        import numba

        numba.set_num_threads(max(1, min(int(threads), numba.config.NUMBA_NUM_THREADS)))


def _setup(spec, data):
    grid = spec["grid"]
    xyz = np.ascontiguousarray(data["xyz"], dtype=np.float64)
    owner = grid.owner(xyz[:, :2])
    owned = owner == spec["tile"]
    bdist = grid.boundary_distance(xyz[:, :2], spec["tile"], spec["halo"])
    return grid, xyz, owner, owned, bdist


def _certified_table(spec, xyz, owned, bdist, k, min_cols=0):
    """Exact k-NN rows of the owned points or the halo the tile would need."""
    grid = spec["grid"]
    rows = np.flatnonzero(owned)
    table, bad, r_k = exact_tile_knn(xyz, rows, k, grid.center, bdist, min_cols=min_cols)
    if bad.size:
        pos = np.searchsorted(rows, bad)
        short = float(np.max(r_k[pos] - bdist[bad]))
        needed = spec["halo"] + short if math.isfinite(short) else math.inf
        return None, {"status": "halo", "needed": needed, "k": int(k), "n_bad": int(bad.size)}
    return table, None


def _halo_part(data, owner, owned):
    """Global index and owner tile of the halo points (for stitching)."""
    halo = ~owned
    return data["gidx"][halo], owner[halo]


# --------------------------------------------------------------------------- normals


def normals_task(spec, data):
    """PCA normals of the owned points (exact), oriented like the untiled command.

    ``orient`` "none" and "viewpoint" are per point, hence exact. "mst" orients the
    whole tile (owned + halo) by Hoppe's propagation; the halo normals go back so
    that the client can make signs agree across tiles.
    """
    from ..normals import estimate_normals, orient_normals

    _threads(spec)
    p = spec["params"]
    grid, xyz, owner, owned, bdist = _setup(spec, data)
    k, orient, orient_k = p["k"], p["orient"], p["orient_k"]
    cols = max(k, orient_k) if orient == "mst" else k
    table, fail = _certified_table(spec, xyz, owned, bdist, k, min_cols=cols)
    if fail:
        return fail
    normals = estimate_normals(xyz, k, neighbors=table)
    out = {"status": "ok", "gidx": data["gidx"][owned]}
    if orient == "viewpoint":
        normals = orient_normals(xyz, normals, method="viewpoint", viewpoint=p["viewpoint"])
    elif orient == "mst":
        ok = min(orient_k, xyz.shape[0])
        normals = orient_normals(xyz, normals, k=ok, method="mst", neighbors=table)
        comp, links = _smooth_pieces(table[:, :ok], normals)
        hg, ho = _halo_part(data, owner, owned)
        out.update(halo_gidx=hg, halo_owner=ho, halo_normals=normals[~owned],
                   halo_piece=comp[~owned], piece=comp[owned], links=links)  # fmt: skip
        out["tops"] = _piece_tops(comp, owned, xyz[:, 2], data["gidx"], normals[:, 2])
    out["normals"] = normals[owned]
    return out


#: Graph edges whose normals make a larger angle than this do not join orientation
#: pieces (an MST propagation across a sharp edge is a guess; see `_smooth_pieces`).
SMOOTH_COS = math.cos(math.radians(10.0))


def _smooth_pieces(table, normals):
    """Orientation pieces of a tile: components of its k-NN graph over smooth edges
    (|n_i . n_j| >= `SMOOTH_COS`), and the links between pieces over the other edges.

    Returns the piece of every point and an (m, 3) array of (piece a, piece b, sum of
    n_i . n_j over the a-b edges): how the tile's MST oriented neighbouring pieces
    across sharp edges, used only where no halo joins them.
    """
    from scipy import sparse
    from scipy.sparse import csgraph

    n, k = table.shape
    rows = np.repeat(np.arange(n, dtype=np.int64), k)
    cols = table.reshape(-1)
    dots = np.einsum("ij,ij->i", normals[rows], normals[cols])
    smooth = np.abs(dots) >= SMOOTH_COS
    graph = sparse.csr_array(
        (np.ones(int(smooth.sum()), dtype=np.int8), (rows[smooth], cols[smooth])), (n, n)
    )
    _, labels = csgraph.connected_components(graph, directed=True, connection="weak")
    labels = labels.astype(np.int64)
    a, b = labels[rows[~smooth]], labels[cols[~smooth]]
    cross = a != b
    if not cross.any():
        return labels, np.zeros((0, 3))
    pairs = np.column_stack([np.minimum(a, b), np.maximum(a, b)])[cross]
    uniq, inv = np.unique(pairs, axis=0, return_inverse=True)
    sums = np.bincount(inv.ravel(), weights=dots[~smooth][cross], minlength=uniq.shape[0])
    return labels, np.column_stack([uniq.astype(np.float64), sums])


def _piece_tops(comp, owned, z, gidx, nz) -> dict:
    """Per component with owned points: (largest z, its global index, its nz); the
    smallest global index among equal z."""
    tops = {}
    rows = np.flatnonzero(owned)
    order = rows[np.lexsort((gidx[rows], -z[rows]))]
    _, first = np.unique(comp[order], return_index=True)
    for i in order[first].tolist():
        tops[int(comp[i])] = (float(z[i]), int(gidx[i]), float(nz[i]))
    return tops


# --------------------------------------------------------------------------- features


def features_dispatch(points, normals, params, neighbors=None):
    """The feature mode of ``params``: "fixed" (equal weights, k), "optimal_k"
    (equal weights, k_range, criterion) or "optimal" (sigmoid (a, b, k) search)."""
    from ..features import covariance_features, optimal_k_features, optimal_neighbourhood

    mode = params["mode"]
    flat = tuple(params["flatness"])
    if mode == "fixed":
        return covariance_features(points, params["k"], neighbors=neighbors, flatness=flat)
    if mode == "optimal_k":
        return optimal_k_features(
            points,
            k_range=tuple(params["k_range"]),
            criterion=params["criterion"],
            neighbors=neighbors,
            flatness=flat,
        )
    if mode == "optimal":
        return optimal_neighbourhood(
            points,
            normals,
            a_grid=params["a_grid"],
            b_grid=params["b_grid"],
            k_range=tuple(params["k_range"]),
            neighbors=neighbors,
            flatness=flat,
        )
    raise ValueError(f"unknown feature mode {mode!r}")


def feature_kmax(params) -> int:
    """Largest neighbourhood a feature mode reads."""
    return int(params["k"]) if params["mode"] == "fixed" else int(params["k_range"][1])


def features_task(spec, data):
    """Features of the owned points, bit for bit those of the untiled run.

    Halo rows get a table of the point itself only (degenerate, cheap): their
    results are not returned.
    """
    _threads(spec)
    p = spec["params"]
    grid, xyz, owner, owned, bdist = _setup(spec, data)
    kmax = feature_kmax(p)
    table, fail = _certified_table(spec, xyz, owned, bdist, kmax)
    if fail:
        return fail
    table = np.ascontiguousarray(table[:, :kmax])
    halo = np.flatnonzero(~owned)
    table[halo] = halo[:, None]
    from ..features import classify_dimension

    res = features_dispatch(xyz, data.get("normals"), p, neighbors=table)
    fields = {name: np.asarray(v)[owned] for name, v in res.scalar_fields().items()}
    fields["dimension_class"] = classify_dimension(res)[owned]
    return {"status": "ok", "gidx": data["gidx"][owned], "fields": fields}


# --------------------------------------------------------------------------- denoise


def denoise_halo(params, spacing: float, r_k: float) -> float:
    """Halo that keeps every owned point's result free of the tile border.

    One iteration moves a point with its neighbours' positions: after t
    iterations a point depends on points up to t neighbourhood radii (plus the
    moves) away. Flatness: ``n_iter * (r_k + spacing)`` (r_k the k-th neighbour
    distance at the largest k of the schedule). Normal voting: every filter step
    reads a ball of ``radius_factor * l`` and each outer iteration runs
    ``filter_iter`` steps and one update: ``n_iter * (filter_iter + 1) *
    (radius_factor * l + max_step * l)``.
    """
    if params["method"] == "flatness":
        return float(params["n_iter"]) * (r_k + spacing)
    from .._core.tolerances import DENOISE_RADIUS_FACTOR

    radius = DENOISE_RADIUS_FACTOR * spacing
    steps = float(params["n_iter"]) * (float(params["filter_iter"]) + 1.0)
    return steps * (radius + float(params["max_step"]) * spacing)


def denoise_task(spec, data):
    """Denoise the whole tile and keep the owned points.

    Normal voting measures lengths in l, the mean 6-NN spacing of its input; the
    tile's l differs from the global one, so the radius factor and the step bound
    are rescaled by ``l_global / l_tile`` (the radius and step in coordinates are
    then those of the untiled run up to rounding).
    """
    from ..denoise import flatness_denoise, normal_voting_denoise
    from ..neighbors import mean_spacing

    _threads(spec)
    p = spec["params"]
    grid, xyz, owner, owned, bdist = _setup(spec, data)
    nrm = data.get("normals")
    if p["method"] == "flatness":
        res = flatness_denoise(
            xyz, k=p["k"], eta=p["eta"], eps=p["eps"], n_iter=p["n_iter"],
            schedule=p["schedule"], k_start=p["k_start"], normals=nrm,
        )  # fmt: skip
    else:
        from .._core.tolerances import DENOISE_RADIUS_FACTOR

        scale = p["spacing"] / mean_spacing(xyz, 6)
        res = normal_voting_denoise(
            xyz, nrm, rho=p["rho"], tau=p["tau"], n_iter=p["n_iter"],
            n_filter_iter=p["filter_iter"], adaptive=p["method"] == "normal-voting-adaptive",
            max_step=p["max_step"] * scale, radius_factor=DENOISE_RADIUS_FACTOR * scale,
        )  # fmt: skip
    fields = {
        "displacement": res.displacement[owned],
        "feature_class": res.feature_class[owned],
        "denoise_k": res.k[owned],
    }
    if p["method"] == "flatness":
        fields["flatness"] = res.energy[owned]
    return {
        "status": "ok",
        "gidx": data["gidx"][owned],
        "points": res.points[owned],
        "normals": res.normals[owned],
        "fields": fields,
        "n_fallback": int(res.n_fallback),
    }


# --------------------------------------------------------------------------- segment


def region_stats(labels, m, xyz, normals, center, gidx):
    """Per region over the given points: count, S = sum n, sums of q and q q^T
    (q = p - center), smallest global index. Normals are made unit length."""
    nrm = normals / np.sqrt((normals * normals).sum(axis=1))[:, None]
    q = xyz - center
    st = np.zeros((m, 14))
    st[:, 0] = np.bincount(labels, minlength=m)
    for d in range(3):
        st[:, 1 + d] = np.bincount(labels, weights=nrm[:, d], minlength=m)
        st[:, 4 + d] = np.bincount(labels, weights=q[:, d], minlength=m)
    c = 7
    for a in range(3):
        for b in range(a, 3):
            st[:, c] = np.bincount(labels, weights=q[:, a] * q[:, b], minlength=m)
            c += 1
    first = np.full(m, np.iinfo(np.int64).max, dtype=np.int64)
    np.minimum.at(first, labels, gidx)
    return st, first


def segment_task(spec, data):
    """VSA on the whole tile (owned + halo) with the owned points' exact k-NN graph.

    Returns the owned points' labels (tile-local), the halo points' labels (their
    owners' labels are compared with them when stitching), the region statistics
    over the owned points and the tile's region adjacency.
    """
    from ..segment import vsa_segment

    _threads(spec)
    p = spec["params"]
    grid, xyz, owner, owned, bdist = _setup(spec, data)
    k = p["k"]
    table, fail = _certified_table(spec, xyz, owned, bdist, k)
    if fail:
        return fail
    nrm = data["normals"]
    res = vsa_segment(
        xyz, nrm, k=k, eta=p["eta"], max_angle=p["max_angle"], split=p["split"],
        merge=p["merge"], switch=p["switch"], neighbors=np.ascontiguousarray(table[:, :k]),
    )  # fmt: skip
    labels = np.asarray(res.labels, dtype=np.int64)
    m = res.n_regions
    gidx = data["gidx"]
    st, first = region_stats(labels[owned], m, xyz[owned], nrm[owned], grid.center, gidx[owned])
    hg, ho = _halo_part(data, owner, owned)
    return {
        "status": "ok",
        "gidx": gidx[owned],
        "labels": labels[owned],
        "n_regions": m,
        "stats": st,
        "first": first,
        "adjacency": np.asarray(res.adjacency, dtype=np.int64),
        "halo_gidx": hg,
        "halo_owner": ho,
        "halo_labels": labels[~owned],
    }


TASKS = {
    "normals": normals_task,
    "features": features_task,
    "denoise": denoise_task,
    "segment": segment_task,
}


def run_task(kind, spec, data):
    """Entry point on a worker (module-level, picklable); never leaks numba threads."""
    os.environ.setdefault("PYTHONHASHSEED", "0")
    return TASKS[kind](spec, data)
