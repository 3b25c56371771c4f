"""Tiled PCA normals: exact per tile, MST orientation stitched across tiles.

Private to `pointatlas.batch` (decisions in docs/decisions/batch.md, "Tiles —
normals").
"""

from __future__ import annotations

from collections import defaultdict

import numpy as np

from .._core import PointAtlasError
from . import _tiles as T
from ._tiles import ArraySource, TileOptions

__all__ = ["normals_over", "tiled_normals"]


#: Weight of a tile's links between pieces across sharp edges (below any halo vote).
_SHARP_WEIGHT = 1e-6


def _piece_key(tile, comp):
    """Key of a tile's orientation component (tile in the high bits)."""
    return (np.int64(tile) << np.int64(32)) + np.asarray(comp, dtype=np.int64)


def _normal_signs(halo_parts, tops, piece_of, normals, tile_links):
    """Sign flips of the tiles' MST components making orientations agree across tiles.

    A piece is one smooth component of one tile's orientation graph (its signs are
    consistent). Every halo point votes between the piece it lies in and its
    owner's piece (+1 when the two normals agree, -1 when opposed); the tile's MST
    links between its pieces across sharp edges count ``_SHARP_WEIGHT`` times their
    summed dot products, so they only join what no halo joins (as an MST prefers
    smooth edges). Pieces are joined along a maximum spanning forest of |vote| and,
    in every tree, signs are
    fixed so that its topmost owned point (largest z, then smallest index) has
    nz >= 0: Hoppe's root rule of `orient_normals`, applied to the stitched
    component. Returns sorted piece keys and their flips (+1 / -1).
    """
    votes = defaultdict(float)
    for b, (hg, _ho, hn, hp) in halo_parts.items():
        if not hg.size:
            continue
        mine = _piece_key(b, hp)
        theirs = np.asarray(piece_of[hg])
        s = np.sign(np.einsum("ij,ij->i", hn, normals[hg]))
        pairs = np.column_stack([np.minimum(mine, theirs), np.maximum(mine, theirs)])
        uniq, inv = np.unique(pairs, axis=0, return_inverse=True)
        sums = np.bincount(inv.ravel(), weights=s, minlength=uniq.shape[0])
        for (a, c), v in zip(uniq.tolist(), sums.tolist(), strict=True):
            votes[(a, c)] += v
    for t, links in tile_links.items():
        for a, b, v in links.tolist():
            key = (int(_piece_key(t, int(a))), int(_piece_key(t, int(b))))
            votes[key] += _SHARP_WEIGHT * v
    keys = sorted(tops)
    parent = {key: key for key in keys}

    def find(x):
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    adj = defaultdict(list)
    for (a, b), v in sorted(votes.items(), key=lambda kv: (-abs(kv[1]), kv[0])):
        if a not in parent or b not in parent or v == 0.0:
            continue
        ra, rb = find(a), find(b)
        if ra != rb:
            parent[rb] = ra
            sign = 1.0 if v > 0 else -1.0
            adj[a].append((b, sign))
            adj[b].append((a, sign))
    flips = {}
    for key in keys:
        if key in flips:
            continue
        comp, stack, rel = [], [key], {key: 1.0}
        while stack:
            u = stack.pop()
            comp.append(u)
            for w, s in adj[u]:
                if w not in rel:
                    rel[w] = rel[u] * s
                    stack.append(w)
        best = max(comp, key=lambda u: (tops[u][0], -tops[u][1]))
        root_sign = 1.0 if tops[best][2] * rel[best] >= 0.0 else -1.0
        for u in comp:
            flips[u] = rel[u] * root_sign
    return np.array(keys, dtype=np.int64), np.array([flips[k] for k in keys])


def tiled_normals(points, options: TileOptions, *, k=20, orient="mst", orient_k=10,
                  viewpoint=None):  # fmt: skip
    """PCA normals by tiles, bit for bit those of the untiled ``pointatlas normals``.

    Parameters
    ----------
    points : array_like of shape (N, 3)
        Coordinates.
    options : TileOptions
        Tiling and cluster.
    k : int
        PCA neighbourhood size (the point itself included).
    orient : {"mst", "viewpoint", "none"}
        Orientation; "mst" orients every tile and makes signs agree across tiles
        (see Notes). "outward" needs the whole closed surface and is refused.
    orient_k : int
        k of the orientation graph.
    viewpoint : array_like of shape (3,), optional
        Sensor position for "viewpoint".

    Returns
    -------
    normals : ndarray of shape (N, 3)
    run : TiledRun

    Raises
    ------
    PointAtlasError
        Bad options, a given halo too narrow, an unreachable scheduler.

    Notes
    -----
    Unoriented normals, "none" and "viewpoint" equal the untiled ones bit for bit.
    With "mst" every tile is oriented by Hoppe's MST propagation and tiles are
    flipped as wholes to agree on the points they share (`_normal_signs`); the
    unoriented direction is still bit for bit the untiled one, the sign agrees
    with the untiled MST wherever the untiled propagation itself is consistent.
    """
    source = ArraySource(points)
    return normals_over(source, options, k=k, orient=orient, orient_k=orient_k,
                         viewpoint=viewpoint)  # fmt: skip


def normals_over(source, options, *, k, orient, orient_k, viewpoint, out=None, spill_dir=None,
                  client_info=None, label="normals"):  # fmt: skip
    if orient not in ("mst", "viewpoint", "none"):
        raise PointAtlasError(
            f"--orient {orient} needs the whole surface at once; with --tile-size use mst, "
            "viewpoint or none"
        )
    n = source.n
    if k < 3 or k > n:
        raise PointAtlasError(f"--k must lie in [3, number of points = {n}]; got {k}")
    grid = T._grid_for(source, options)
    halo0, fixed = T._auto_halo(source, k, options)
    normals = np.zeros((n, 3)) if out is None else out
    halo_parts, tops, tile_links = {}, {}, {}
    piece_of = None
    if orient == "mst":
        piece_of = (
            np.zeros(n, dtype=np.int64)
            if spill_dir is None
            else np.lib.format.open_memmap(spill_dir / "piece.npy", "w+", np.int64, (n,))
        )

    def on_result(t, res):
        normals[res["gidx"]] = res["normals"]
        if piece_of is not None:
            piece_of[res["gidx"]] = _piece_key(t, res["piece"])
            halo_parts[t] = (res["halo_gidx"], res["halo_owner"], res["halo_normals"],
                             res["halo_piece"])  # fmt: skip
            tops.update({int(_piece_key(t, c)): v for c, v in res["tops"].items()})
            tile_links[t] = res["links"]
        T.release_pages(normals, piece_of)

    params = {"k": int(k), "orient": orient, "orient_k": int(orient_k), "viewpoint": viewpoint}
    with T._maybe_client(options, client_info) as ci:
        run = T.run_tiles(
            "normals", source, grid, params, options, ci, on_result, halo0=halo0, fixed=fixed,
            label=label, spill_dir=spill_dir, memory_per_point=8.0 * (3 * (k + 8) + 40)
        )  # fmt: skip
    if orient == "mst":
        keys, flips = _normal_signs(halo_parts, tops, piece_of, normals, tile_links)
        T.release_pages(normals, piece_of)
        run.extra["orientation_pieces"] = int(keys.size)
        run.extra["flipped_pieces"] = int(np.count_nonzero(flips < 0))
        for sl in T._chunked(n):
            f = flips[np.searchsorted(keys, piece_of[sl])]
            normals[sl] = normals[sl] * f[:, None]
            T.release_pages(normals, piece_of)
    return normals, run
