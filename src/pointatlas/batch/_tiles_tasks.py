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
    return _halo_check(spec, table, rows, bad, r_k, bdist, k)


def _owned_table(spec, xyz, owned, bdist, k):
    """`_certified_table` for tasks that read only the owned rows: the owned points'
    exact k-NN rows (queried alone), the halo rows the point itself only."""
    grid = spec["grid"]
    rows = np.flatnonzero(owned)
    part, bad, r_k = exact_tile_knn(xyz, rows, k, grid.center, bdist, rows_only=True)
    table = None
    if part is not None:
        table = np.repeat(np.arange(xyz.shape[0], dtype=np.int64)[:, None], part.shape[1], axis=1)
        table[rows] = part
    return _halo_check(spec, table, rows, bad, r_k, bdist, k)


def _halo_check(spec, table, rows, bad, r_k, bdist, k):
    """The table, or the halo the tile would need when rows ``bad`` are not certified."""
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

    ``orient`` "none", "viewpoint" and "up" are per point, hence exact; they query
    the owned rows only and orient the owned normals only. "mst" orients the whole
    tile (owned + halo) by Hoppe's propagation over the k-NN rows of every tile
    point; the halo normals go back so that the client can make signs agree across
    tiles.
    """
    from ..normals import estimate_normals

    _threads(spec)
    p = spec["params"]
    grid, xyz, owner, owned, bdist = _setup(spec, data)
    k, orient, orient_k = p["k"], p["orient"], p["orient_k"]
    if orient == "mst":  # the orientation graph reads the halo rows too
        table, fail = _certified_table(spec, xyz, owned, bdist, k, min_cols=max(k, orient_k))
    else:
        table, fail = _owned_table(spec, xyz, owned, bdist, k)
    if fail:
        return fail
    out = {"status": "ok", "gidx": data["gidx"][owned]}
    if orient == "mst":
        normals, parts = mst_tile_normals(xyz, table, k, orient_k, data, owner, owned)
        out.update(parts)
        out["normals"] = normals[owned]
    else:
        normals = estimate_normals(xyz, k, neighbors=table)
        out["normals"] = orient_per_point(xyz, normals, owned, orient, p["viewpoint"])
    return out


def orient_per_point(xyz, normals, owned, orient, viewpoint=None):
    """The owned rows of ``normals`` oriented by a per-point rule ("none", "viewpoint",
    "up"): each row depends on its own point and normal only, so the owned rows alone
    give the untiled rows bit for bit."""
    from ..normals import orient_normals

    mine = normals[owned]
    if orient == "none":
        return mine
    if orient == "viewpoint":
        return orient_normals(xyz[owned], mine, method="viewpoint", viewpoint=viewpoint)
    return orient_normals(xyz[owned], mine, method=orient)


def mst_tile_normals(xyz, table, k, orient_k, data, owner, owned):
    """PCA normals of a tile (owned + halo) oriented by Hoppe's MST over ``table``,
    and what the client needs to make signs agree across tiles (halo normals, the
    orientation pieces and their links and tops): ``(normals, parts)``."""
    from ..normals import estimate_normals, orient_normals

    normals = estimate_normals(xyz, k, neighbors=table)
    ok = min(orient_k, xyz.shape[0])
    graph = np.ascontiguousarray(table[:, :ok])  # one copy for the MST and the pieces
    normals = orient_normals(xyz, normals, k=ok, method="mst", neighbors=graph)
    comp, links = _smooth_pieces(graph, normals)
    hg, ho = _halo_part(data, owner, owned)
    parts = {
        "halo_gidx": hg,
        "halo_owner": ho,
        "halo_normals": normals[~owned],
        "halo_piece": comp[~owned],
        "piece": comp[owned],
        "links": links,
        "tops": _piece_tops(comp, owned, xyz[:, 2], data["gidx"], normals[:, 2]),
    }
    return normals, parts


#: Graph edges whose normals make a larger angle than this do not join orientation
#: pieces (an MST propagation across a sharp edge is a guess; see `_smooth_pieces`).
SMOOTH_COS = math.cos(math.radians(10.0))


def _smooth_pieces(table, normals):
    """Orientation pieces of a tile: components of its k-NN graph over smooth edges
    (|n_i . n_j| >= `SMOOTH_COS`), and the links between pieces over the other edges.

    Returns the piece of every point and an (m, 3) array of (piece a, piece b, sum of
    n_i . n_j over the a-b edges), sorted by (a, b): how the tile's MST oriented
    neighbouring pieces across sharp edges, used only where no halo joins them.
    """
    from ._kernels import smooth_pieces_kernel

    table = np.ascontiguousarray(table, dtype=np.int64)
    normals = np.ascontiguousarray(normals, dtype=np.float64)
    labels, a, b, dots = smooth_pieces_kernel(table, normals, SMOOTH_COS)
    if not a.size:
        return labels, np.zeros((0, 3))
    key = a * (int(labels.max()) + 1) + b
    order = np.argsort(key, kind="stable")
    key = key[order]
    start = np.flatnonzero(np.r_[True, key[1:] != key[:-1]])
    sums = np.add.reduceat(dots[order], start)
    return labels, np.column_stack([a[order][start], b[order][start], sums]).astype(np.float64)


def _piece_tops(comp, owned, z, gidx, nz):
    """Per component with owned points: its key and (largest z, its global index,
    its nz), the smallest global index among equal z: ``(components, (m, 3) rows)``
    in increasing component order (`piece_tops_kernel`)."""
    from ._kernels import piece_tops_kernel

    rows = np.flatnonzero(owned)
    n_pieces = int(comp.max()) + 1 if comp.size else 0
    best = piece_tops_kernel(comp, n_pieces, rows, z, gidx)
    comps = np.flatnonzero(best >= 0)
    top = best[comps]
    return comps, np.column_stack([z[top], gidx[top].astype(np.float64), nz[top]])


# --------------------------------------------------------------------------- features


def features_dispatch(points, normals, params, neighbors=None):
    """The feature mode of ``params``: "fixed" (equal weights, k), "optimal_k"
    (equal weights, k_range, criterion) or "optimal" (sigmoid (a, b, k) search)."""
    from ..features import covariance_features, optimal_k_features, optimal_neighborhood

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
        return optimal_neighborhood(
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

    Only the owned rows are queried (`_owned_table`); halo rows get a table of the
    point itself only (degenerate, cheap): their results are not returned.
    """
    _threads(spec)
    p = spec["params"]
    grid, xyz, owner, owned, bdist = _setup(spec, data)
    kmax = feature_kmax(p)
    table, fail = _owned_table(spec, xyz, owned, bdist, kmax)
    if fail:
        return fail
    res = features_dispatch(xyz, data.get("normals"), p, neighbors=table)
    return {"status": "ok", "gidx": data["gidx"][owned], "fields": owned_fields(res, owned, p)}


def owned_fields(res, owned, params) -> dict:
    """The owned rows of a `FeatureResult`'s fields and ``dimension_class``; float64
    fields as ``params["float_type"]`` when given (the type the client stores them
    in: float32 for LAS/LAZ, `LAS_FEATURE_FLOAT`), rounded here as the client's
    store would round them, and half the bytes sent back."""
    from ..features import classify_dimension

    ft = params.get("float_type")
    fields = {}
    for name, v in res.scalar_fields().items():
        v = np.asarray(v)[owned]
        fields[name] = v.astype(ft) if ft is not None and v.dtype == np.float64 else v
    fields["dimension_class"] = classify_dimension(res)[owned]
    return fields


# --------------------------------------------------------------------------- denoise


def denoise_task(spec, data):
    """Denoise the whole tile and keep the owned points.

    Normal voting reads the tile's exact k-NN table (``columns`` of
    `pointatlas.denoise.denoise_halo`, owned rows certified) and the global l
    (``spacing``), so its owned points are those of the untiled run wherever the
    counts are fixed. Flatness re-queries its neighbours on the moved points. A
    tile whose heights over the first result are two sheets (a thin plate) runs
    each side apart, as the untiled command (`flatness_with_sides`,
    `voting_with_pieces` without pieces; docs/decisions/batch.md, "Tiles —
    denoising").
    """
    from ..denoise import flatness_with_sides, voting_with_pieces

    _threads(spec)
    p = spec["params"]
    grid, xyz, owner, owned, bdist = _setup(spec, data)
    nrm = data.get("normals")
    if p["method"] == "flatness":
        res = flatness_with_sides(
            xyz,
            nrm,
            k=p["k"],
            eta=p["eta"],
            eps=p["eps"],
            n_iter=p["n_iter"],
            schedule=p["schedule"],
            k_start=p["k_start"],
        )
    else:
        table = None
        if xyz.shape[0] >= p["columns"]:
            table, fail = _certified_table(spec, xyz, owned, bdist, p["columns"])
            if fail:
                return fail
        res = voting_with_pieces(
            xyz,
            nrm,
            planes=False,
            neighbors=table,
            rho=p["rho"],
            tau=p["tau"],
            n_iter=p["n_iter"],
            n_filter_iter=p["filter_iter"],
            n_update=p.get("n_update"),
            adaptive=p["method"] == "normal-voting-adaptive",
            max_step=p["max_step"],
            spacing=p["spacing"],
        )
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
    vsa = p["vsa"]
    k = vsa.k
    table, fail = _certified_table(spec, xyz, owned, bdist, k)
    if fail:
        return fail
    nrm = data["normals"]
    res = vsa_segment(xyz, nrm, options=vsa, neighbors=np.ascontiguousarray(table[:, :k]))
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
