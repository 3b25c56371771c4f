"""Tiled PCA normals: exact per tile, MST orientation stitched across tiles.

Private to `pointatlas.batch` (decisions in docs/decisions/batch.md, "Tiles —
normals").
"""

from __future__ import annotations

import numpy as np

from .._core import PointAtlasError
from . import _tiles as T
from ._tiles import ArraySource, TileOptions

__all__ = ["check_normal_options", "normals_over", "tiled_normals"]


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
    smooth edges). Pieces are joined along a maximum spanning forest of |vote| (ties
    by piece keys) and, in every tree, signs are
    fixed so that its topmost owned point (largest z, then smallest index) has
    nz >= 0: Hoppe's root rule of `orient_normals`, applied to the stitched
    component. ``tops`` maps a tile to its pieces' (keys, (z, index, nz) rows).
    Returns sorted piece keys and their flips (+1 / -1).
    """
    from ._kernels.signs import signed_forest_kernel

    firsts, seconds, votes = [], [], []
    for b, (hg, _ho, hn, hp) in halo_parts.items():
        if not hg.size:
            continue
        mine = _piece_key(b, hp)
        theirs = np.asarray(piece_of[hg])
        firsts.append(np.minimum(mine, theirs))
        seconds.append(np.maximum(mine, theirs))
        votes.append(np.sign(np.einsum("ij,ij->i", hn, normals[hg])))
    for t, links in tile_links.items():  # keys within one tile: never a halo pair
        if links.size:
            firsts.append(_piece_key(t, links[:, 0].astype(np.int64)))
            seconds.append(_piece_key(t, links[:, 1].astype(np.int64)))
            votes.append(_SHARP_WEIGHT * links[:, 2])
    parts = [(k, np.asarray(v, dtype=np.float64).reshape(-1, 3)) for k, v in tops.values()]
    keys = np.concatenate([k for k, _ in parts]) if parts else np.zeros(0, np.int64)
    top = np.concatenate([v for _, v in parts]) if parts else np.zeros((0, 3))
    order = np.argsort(keys, kind="stable")
    keys, top = keys[order], top[order]
    a = np.concatenate(firsts) if firsts else np.zeros(0, np.int64)
    c = np.concatenate(seconds) if seconds else np.zeros(0, np.int64)
    v = np.concatenate(votes) if votes else np.zeros(0)
    # one vote per (a, c): halo votes are sums of +-1 (exact in any order)
    if a.size:
        o = np.lexsort((c, a))
        a, c, v = a[o], c[o], v[o]
        head = np.flatnonzero(np.r_[True, (a[1:] != a[:-1]) | (c[1:] != c[:-1])])
        a, c, v = a[head], c[head], np.add.reduceat(v, head)
    ia = np.searchsorted(keys, a)
    ic = np.searchsorted(keys, c)
    ok = (v != 0.0) & (ia < keys.size) & (ic < keys.size)
    ok[ok] &= (keys[ia[ok]] == a[ok]) & (keys[ic[ok]] == c[ok])
    a, c, v, ia, ic = a[ok], c[ok], v[ok], ia[ok], ic[ok]
    o = np.lexsort((c, a, -np.abs(v)))  # strongest first, then by keys
    comp, rel = signed_forest_kernel(keys.size, ia[o], ic[o], v[o] > 0)
    # every tree's topmost owned point: largest z, then smallest index
    o = np.lexsort((top[:, 1], -top[:, 0], comp))
    first = o[np.r_[True, comp[o][1:] != comp[o][:-1]]] if o.size else o
    root = np.where(top[first, 2] * rel[first] >= 0.0, 1.0, -1.0)
    return keys, rel * root[comp]


def tiled_normals(points, options: TileOptions, *, k=20, orient="mst", orient_k=10, viewpoint=None):
    """PCA normals by tiles, bit for bit those of the untiled ``pointatlas normals``.

    Parameters
    ----------
    points : array_like of shape (N, 3)
        Coordinates.
    options : TileOptions
        Tiling and cluster.
    k : int
        PCA neighbourhood size (the point itself included).
    orient : {"mst", "viewpoint", "up", "none"}
        Orientation; "mst" orients every tile and makes signs agree across tiles
        (see Notes); "viewpoint" and "up" are per point. "outward" needs the whole
        closed surface and is refused.
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
    Unoriented normals, "none", "viewpoint" and "up" equal the untiled ones bit for
    bit (their tiles query the owned rows only and need no stitching).
    With "mst" every tile is oriented by Hoppe's MST propagation and tiles are
    flipped as wholes to agree on the points they share (`_normal_signs`); the
    unoriented direction is still bit for bit the untiled one, the sign agrees
    with the untiled MST wherever the untiled propagation itself is consistent.
    """
    source = ArraySource(points)
    return normals_over(source, options, k=k, orient=orient, orient_k=orient_k, viewpoint=viewpoint)


class _Stitch:
    """The client's side of tiled normals: owned normals into ``normals`` and, for
    "mst", what `_normal_signs` needs; `finish` flips the pieces."""

    def __init__(self, normals, orient, spill_dir):
        n = normals.shape[0]
        self.normals = normals
        self.halo_parts, self.tops, self.tile_links = {}, {}, {}
        self.piece_of = None
        if orient == "mst":
            self.piece_of = (
                np.zeros(n, dtype=np.int64)
                if spill_dir is None
                else np.lib.format.open_memmap(spill_dir / "piece.npy", "w+", np.int64, (n,))
            )

    def on_result(self, t, res):
        self.normals[res["gidx"]] = res["normals"]
        if self.piece_of is not None:
            self.piece_of[res["gidx"]] = _piece_key(t, res["piece"])
            self.halo_parts[t] = (
                res["halo_gidx"],
                res["halo_owner"],
                res["halo_normals"],
                res["halo_piece"],
            )
            comps, rows = res["tops"]
            self.tops[t] = (_piece_key(t, comps), rows)
            self.tile_links[t] = res["links"]
        T.release_pages(self.normals, self.piece_of)

    def finish(self, run) -> None:
        if self.piece_of is None:
            return
        normals, piece_of = self.normals, self.piece_of
        keys, flips = _normal_signs(self.halo_parts, self.tops, piece_of, normals, self.tile_links)
        T.release_pages(normals, piece_of)
        run.extra["orientation_pieces"] = int(keys.size)
        run.extra["flipped_pieces"] = int(np.count_nonzero(flips < 0))
        for sl in T._chunked(normals.shape[0]):
            f = flips[np.searchsorted(keys, piece_of[sl])]
            normals[sl] = normals[sl] * f[:, None]
            T.release_pages(normals, piece_of)


def check_normal_options(n: int, k: int, orient: str) -> None:
    """One-line errors for tiled normals' options."""
    if orient not in ("mst", "viewpoint", "up", "none"):
        raise PointAtlasError(
            f"--orient {orient} needs the whole surface at once; with --tile-size use mst, "
            "viewpoint, up or none"
        )
    if k < 3 or k > n:
        raise PointAtlasError(f"--k must lie in [3, number of points = {n}]; got {k}")


def normals_over(
    source,
    options,
    *,
    k,
    orient,
    orient_k,
    viewpoint,
    out=None,
    spill_dir=None,
    client_info=None,
    label="normals",
):
    n = source.n
    check_normal_options(n, k, orient)
    grid = T._grid_for(source, options)
    stitch = _Stitch(np.zeros((n, 3)) if out is None else out, orient, spill_dir)
    params = {"k": int(k), "orient": orient, "orient_k": int(orient_k), "viewpoint": viewpoint}
    with T._maybe_client(options, client_info) as ci:
        halo0, fixed = T._auto_halo(source, k, options, client=ci[0])
        run = T.run_tiles(
            "normals",
            source,
            grid,
            params,
            options,
            ci,
            stitch.on_result,
            halo0=halo0,
            fixed=fixed,
            label=label,
            spill_dir=spill_dir,
            memory_per_point=8.0 * (3 * (k + 8) + 40),
        )
    stitch.finish(run)
    return stitch.normals, run
