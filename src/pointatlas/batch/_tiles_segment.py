"""Tiled VSA segmentation, stitched across tile borders by a union-find over regions.

Private to `pointatlas.batch` (decisions in docs/decisions/batch.md, "Tiles —
segmentation stitched across tiles").
"""

from __future__ import annotations

import heapq
import math

import numpy as np

from . import _tiles as T
from ._tiles import ArraySource, TileOptions

__all__ = ["segment_over", "tiled_segment"]

#: Automatic segmentation halos are at least this many typical (median) k-NN halos
#: wide: VSA near a tile edge sees truncated regions; wider context makes the owned
#: labels those of the untiled run more often.
SEGMENT_HALO_FACTOR = 15.0
#: A strong halo link (at least the smaller tile region's point count of halo points
#: labelled with both regions) allows proxies this many max angles apart.
STRONG_ANGLE_FACTOR = 2.0


class _Regions:
    """Stitched regions: union-find over tile regions with summed statistics."""

    def __init__(self, stats, first, eta, min_cos, tau2=0.0, tile_of=None):
        self.st = stats.copy()
        self.first = first.copy()
        self.parent = np.arange(stats.shape[0])
        self.eta = eta
        self.min_cos = min_cos
        self.tau2 = tau2
        # tile-exclusive unions (VSA's local mode): every root's set of tiles; a
        # union never holds two regions of one tile
        self.tiles = None if tile_of is None else {}
        self.tile_of = tile_of
        # the angle test of strong links (angle mode only)
        self.strong_cos = None
        if min_cos is not None:
            angle = min(math.acos(min(1.0, min_cos)) * STRONG_ANGLE_FACTOR, math.pi / 2)
            self.strong_cos = math.cos(angle)

    def find(self, x):
        p = self.parent
        root = x
        while p[root] != root:
            root = p[root]
        while p[x] != root:
            p[x], x = root, p[x]
        return root

    @staticmethod
    def l21(st):
        return max(0.0, 2.0 * (st[0] - math.sqrt(st[1] ** 2 + st[2] ** 2 + st[3] ** 2)))

    @staticmethod
    def plane_mse(st) -> float:
        """Mean squared distance to the region's proxy plane (through the centroid)."""
        length = math.sqrt(st[1] ** 2 + st[2] ** 2 + st[3] ** 2)
        if st[0] <= 0 or length == 0.0:
            return 0.0
        nrm = st[1:4] / length
        mean = st[4:7] / st[0]
        cov = np.empty((3, 3))
        c = 7
        for i in range(3):
            for j in range(i, 3):
                cov[i, j] = cov[j, i] = st[c] - st[0] * mean[i] * mean[j]
                c += 1
        return max(0.0, float(nrm @ cov @ nrm) / st[0])

    def ok(self, a, b, strong: bool = False) -> bool:
        """The VSA merge test on the union (eta: L21 < eta; else mean deviation <=
        max angle and the two proxies within the max angle), and two plane tests:
        parallel but offset planes (a roof and the ground) pass the normal tests and
        must not join. With ``bound = 4 x the parts' larger plane MSE + tau^2``, the
        union's plane MSE is at most ``bound``, and so is the squared distance it
        adds per point of the *smaller* part (the union's squared distances minus the
        parts' own, over the smaller count): a huge region (the ground of a whole
        scan) barely changes its MSE when it swallows a small roof, but the roof's
        points then lie metres from the plane.

        A ``strong`` link (the tiles put at least the smaller part's count of halo
        points in both regions) skips the per-point test and allows the proxies
        ``STRONG_ANGLE_FACTOR`` x the max angle apart: a border piece of a curved
        surface lies as far off the union's plane as a roof, and each tile's VSA
        shaped its own part (docs/decisions/batch.md).

        With ``tile_of`` (VSA's local mode) a union never holds two regions of one
        tile: that tile's local VSA kept them apart, as the untiled run does."""
        if self.tiles is not None and not self.tile_set(a).isdisjoint(self.tile_set(b)):
            return False
        if not self.near(a, b, strong):
            return False
        sa, sb = self.st[a], self.st[b]
        u = sa + sb
        if self.eta is not None:
            return self.l21(u) < self.eta
        la = math.sqrt(sa[1] ** 2 + sa[2] ** 2 + sa[3] ** 2)
        lb = math.sqrt(sb[1] ** 2 + sb[2] ** 2 + sb[3] ** 2)
        lu = math.sqrt(u[1] ** 2 + u[2] ** 2 + u[3] ** 2)
        if la == 0.0 or lb == 0.0:
            return False
        cos_ab = (sa[1] * sb[1] + sa[2] * sb[2] + sa[3] * sb[3]) / (la * lb)
        return cos_ab >= (self.strong_cos if strong else self.min_cos) and lu >= self.min_cos * u[0]

    def near(self, a, b, strong: bool = False) -> bool:
        """The plane tests of `ok`: the union's plane MSE and (unless ``strong``)
        the squared distance it adds per point of the smaller part are at most
        ``4 x the parts' larger plane MSE + tau^2``."""
        sa, sb = self.st[a], self.st[b]
        u = sa + sb
        mse_a, mse_b, mse_u = self.plane_mse(sa), self.plane_mse(sb), self.plane_mse(u)
        bound = 4.0 * max(mse_a, mse_b) + self.tau2
        if mse_u > bound:
            return False
        added = mse_u * u[0] - mse_a * sa[0] - mse_b * sb[0]
        return strong or not added > bound * min(sa[0], sb[0])

    def union(self, a, b):
        ra, rb = self.find(a), self.find(b)
        if ra == rb:
            return ra
        if rb < ra:
            ra, rb = rb, ra
        if self.tiles is not None:
            self.tiles[ra] = self.tile_set(ra) | self.tiles.pop(rb, {int(self.tile_of[rb])})
        self.parent[rb] = ra
        self.st[ra] += self.st[rb]
        self.first[ra] = min(self.first[ra], self.first[rb])
        return ra

    def tile_set(self, root):
        """The tiles whose regions the stitched region ``root`` holds."""
        if root not in self.tiles:
            self.tiles[root] = {int(self.tile_of[root])}
        return self.tiles[root]


def _greedy_merge(regions: _Regions, pairs: np.ndarray) -> int:
    """Cheapest-first merging of neighbouring stitched regions (energy increase
    first) while the VSA test holds; returns the number of merges."""
    heap = []
    l21 = regions.l21
    for a, b in pairs.tolist():
        ra, rb = regions.find(a), regions.find(b)
        if ra != rb:
            cost = l21(regions.st[ra] + regions.st[rb]) - l21(regions.st[ra]) - l21(regions.st[rb])
            heapq.heappush(heap, (cost, min(ra, rb), max(ra, rb)))
    merged = 0
    while heap:
        cost, a, b = heapq.heappop(heap)
        ra, rb = regions.find(a), regions.find(b)
        if ra == rb:
            continue
        now = l21(regions.st[ra] + regions.st[rb]) - l21(regions.st[ra]) - l21(regions.st[rb])
        if (min(ra, rb), max(ra, rb)) != (a, b) or now != cost:  # stale entry
            heapq.heappush(heap, (now, min(ra, rb), max(ra, rb)))
            continue
        if regions.ok(ra, rb):
            regions.union(ra, rb)
            merged += 1
    return merged


def _quality(st) -> dict:
    """n_regions, energy (sum of L21) and plane MSE of stitched region statistics."""
    w = st[:, 0]
    s = st[:, 1:4]
    length = np.sqrt((s * s).sum(axis=1))
    energy = float(np.maximum(2.0 * (w - length), 0.0).sum())
    prox = np.where(length[:, None] > 0, s / np.where(length > 0, length, 1.0)[:, None], 0.0)
    mean = st[:, 4:7] / w[:, None]
    cov = np.empty((st.shape[0], 3, 3))
    c = 7
    for a in range(3):
        for b in range(a, 3):
            cov[:, a, b] = cov[:, b, a] = st[:, c] - w * mean[:, a] * mean[:, b]
            c += 1
    sq = np.einsum("ri,rij,rj->r", prox, cov, prox)
    return {
        "n_regions": int(st.shape[0]),
        "energy": energy,
        "mse": float(np.maximum(sq, 0.0).sum() / w.sum()),
        "proxy_normals": prox,
        "centroids": mean,
        "region_l21": np.maximum(2.0 * (w - length), 0.0),
        "region_counts": w.astype(np.int64),
    }


def tiled_segment(points, normals, options: TileOptions, params: dict):
    """VSA segmentation by tiles, stitched across tile borders.

    Parameters
    ----------
    points, normals : ndarray of shape (N, 3)
        Coordinates and oriented normals.
    options : TileOptions
        Tiling and cluster.
    params : pointatlas.segment.VSAOptions or dict
        The `pointatlas.segment.vsa_segment` settings (a dict: `VSAOptions`
        fields). Only what can be stitched runs by tiles: seeds "all", weights
        "uniform", not classic (one-line errors otherwise). Every tile runs the
        same settings, ``local`` included: in VSA's local mode the stitched result
        agrees with an untiled local run (docs/decisions/segment.md "Local mode").

    Returns
    -------
    labels : ndarray of shape (N,), int64
        Regions numbered by smallest member index.
    quality : dict
        ``n_regions``, ``energy`` (total L21), ``mse`` (plane MSE), per region
        ``proxy_normals``, ``centroids``, ``region_l21``, ``region_counts``.
    run : TiledRun

    Notes
    -----
    Each tile runs `vsa_segment` on its points and halo with the owned points'
    exact k-NN graph. A halo point carries two labels, its owner's and the
    neighbour tile's: these pairs join regions by a union-find when the union
    passes the VSA merge test (and, in angle mode, the two proxy normals lie
    within the max angle); in VSA's local mode a union never holds two regions of
    one tile. With ``eta``, a final cheapest-first merge pass over all
    neighbouring regions (tile adjacency and halo links) then applies the same
    test, as VSA's own final merge does (VSA runs none in angle mode). With
    ``min_region_size`` every tile joins its small regions, and then the stitched
    regions still under the size (cut by tile borders) join their best neighbour
    by the same rule (`VSAOptions.min_region_size`; not in local mode, where the
    off-surface step's regions of their own stay, as in an untiled run).
    """
    return segment_over(ArraySource(points, normals), options, params)


def vsa_options(params):
    """The `VSAOptions` of a tiled segmentation (a `VSAOptions` or a dict of its
    fields), refused with one line when it cannot be stitched."""
    from .._core import PointAtlasError
    from ..segment import VSAOptions

    vsa = params if isinstance(params, VSAOptions) else VSAOptions(**params)
    if not (isinstance(vsa.seeds, str) and vsa.seeds == "all"):
        raise PointAtlasError("--seeds must be 'all' with --tile-size (regions grow per tile)")
    if not (isinstance(vsa.weights, str) and vsa.weights == "uniform"):
        raise PointAtlasError("--weights must be uniform with --tile-size")
    if vsa.classic:
        raise PointAtlasError(
            "--classic needs every point in one process; leave out --tile-size or this option"
        )
    return vsa


def segment_over(
    source,
    options,
    params,
    *,
    labels_out=None,
    spill_dir=None,
    client_info=None,
    normals_array=None,
    label="segment",
):
    vsa = vsa_options(params)
    k = vsa.k
    grid = T._grid_for(source, options)
    halo0, fixed = T._auto_halo(source, k, options)
    if not fixed:  # context for VSA near the tile edges: a multiple of the typical r_k
        typical = T._estimate_spacing(source, k, typical=True)[1]
        halo0 = max(halo0, SEGMENT_HALO_FACTOR * 1.25 * typical)
    n = source.n
    labels = np.zeros(n, dtype=np.int64) if labels_out is None else labels_out
    per_tile = {}

    def on_result(t, res):
        per_tile[t] = res

    with T._maybe_client(options, client_info) as ci:
        run = T.run_tiles(
            "segment",
            source,
            grid,
            {"vsa": vsa},
            options,
            ci,
            on_result,
            halo0=halo0,
            fixed=fixed,
            label=label,
            spill_dir=spill_dir,
            normals_array=normals_array,
            memory_per_point=8.0 * (4 * k + 80),
        )
    tau2 = float(T._estimate_spacing(source, k, typical=True)[1]) ** 2
    quality, extra = stitch(per_tile, vsa, tau2, labels)
    run.extra.update(extra)
    return labels, quality, run


def stitch(per_tile: dict, vsa, tau2: float, labels: np.ndarray):
    """Join the tiles' regions into global ones and number them (writes ``labels``).

    Parameters
    ----------
    per_tile : dict of int to dict
        Every tile's result (`segment_task`): owned labels, region statistics,
        halo labels, adjacency.
    vsa : pointatlas.segment.VSAOptions
        The run's settings (threshold mode, merge).
    tau2 : float
        Squared typical k-NN distance (the plane test's slack).
    labels : ndarray of shape (N,), int64
        Output: the final label of every point.

    Returns
    -------
    quality : dict
        See `tiled_segment`.
    extra : dict
        ``tile_regions``, ``halo_unions``, ``final_merges``.
    """
    tiles = sorted(per_tile)
    offsets, total = {}, 0
    for t in tiles:
        offsets[t] = total
        total += per_tile[t]["n_regions"]
    stats = np.zeros((total, 14))
    first = np.full(total, np.iinfo(np.int64).max, dtype=np.int64)
    for t in tiles:
        r = per_tile[t]
        o = offsets[t]
        stats[o : o + r["n_regions"]] = r["stats"]
        first[o : o + r["n_regions"]] = r["first"]
        labels[r["gidx"]] = o + r["labels"]
        T.release_pages(labels)
    # links: a halo point's label in its neighbour tile and in its owner tile
    links, adjacency = [], []
    for t in tiles:
        r = per_tile[t]
        if r["halo_gidx"].size:
            links.append(np.column_stack([labels[r["halo_gidx"]], offsets[t] + r["halo_labels"]]))
        if r["adjacency"].size:
            adjacency.append(offsets[t] + r["adjacency"])
    eta, max_angle = vsa.eta, vsa.max_angle
    if eta is None and max_angle is None:
        from .._core.tolerances import VSA_DEFAULT_MAX_ANGLE

        max_angle = VSA_DEFAULT_MAX_ANGLE
    # VSA's local mode: a tile's regions are the untiled run's (docs/decisions/segment.md
    # "Local mode"), so a stitched region holds at most one region of each tile
    tile_of = np.repeat(np.arange(len(tiles)), [per_tile[t]["n_regions"] for t in tiles])
    regions = _Regions(
        stats,
        first,
        eta,
        None if eta is not None else math.cos(max_angle),
        tau2,
        tile_of if vsa.local else None,
    )
    has_points = stats[:, 0] > 0
    pairs, n_links = _halo_unions(regions, links, has_points)
    cand = [pairs]
    if adjacency:
        adj = np.concatenate(adjacency)
        cand.append(adj[has_points[adj[:, 0]] & has_points[adj[:, 1]]])
    # VSA's own final merge runs only with eta (in angle mode the mean-deviation test
    # lets a large region absorb a small perpendicular one); so does this one
    final_pass = vsa.merge and eta is not None
    n_final = _greedy_merge(regions, np.concatenate(cand)) if final_pass else 0
    n_small = 0
    # the small regions' step of vsa_segment, over the stitched regions; not in local
    # mode, where it runs before the off-surface step, whose regions of their own the
    # tiles agree on and the untiled run keeps
    if vsa.min_region_size > 1 and not vsa.local:
        n_small = _join_small(regions, np.concatenate(cand), has_points, vsa.min_region_size)
    roots = np.array([regions.find(i) for i in range(total)], dtype=np.int64)
    live = np.unique(roots[has_points])
    live = live[np.argsort(regions.first[live], kind="stable")]
    rank = np.full(total, -1, dtype=np.int64)
    rank[live] = np.arange(live.size)
    final = rank[roots]
    for sl in T._chunked(labels.shape[0]):
        labels[sl] = final[labels[sl]]
        T.release_pages(labels)
    extra = {
        "tile_regions": int(has_points.sum()),
        "halo_unions": n_links,
        "final_merges": n_final,
        "small_regions_joined": n_small,
    }
    return _quality(regions.st[live]), extra


def _join_small(regions: _Regions, pairs: np.ndarray, has_points: np.ndarray, min_size: int):
    """Stitched regions with fewer than ``min_size`` points join, in rounds, the
    neighbouring stitched region whose union with them adds the least L21 among
    those whose plane they lie on (`_Regions.near`), as `vsa_segment`'s step
    "small_regions" does (`VSAOptions.min_region_size`); a tile joined its own
    small regions already, this joins those cut by tile borders. Returns the
    number of regions that joined."""
    from ..segment import pick_merge_targets

    total = regions.st.shape[0]
    pairs = pairs[has_points[pairs[:, 0]] & has_points[pairs[:, 1]]] if pairs.size else pairs
    joined = 0
    while pairs.size:
        roots = np.array([regions.find(i) for i in range(total)], dtype=np.int64)
        p = roots[pairs]
        p = np.unique(np.sort(p[p[:, 0] != p[:, 1]], axis=1), axis=0)
        a = np.concatenate([p[:, 0], p[:, 1]])
        b = np.concatenate([p[:, 1], p[:, 0]])
        keep = regions.st[a, 0] < min_size
        a, b = a[keep], b[keep]
        pairs_ab = zip(a.tolist(), b.tolist(), strict=True)
        keep = np.array([regions.near(x, y) for x, y in pairs_ab], dtype=bool)
        if not keep.any():
            break
        src, dst = pick_merge_targets(a[keep], b[keep], regions.st[:, 1:4])
        for x, y in zip(src.tolist(), dst.tolist(), strict=True):
            if regions.find(x) != regions.find(y):
                regions.union(x, y)
                joined += 1
    return joined


def _halo_unions(regions: _Regions, links: list, has_points: np.ndarray):
    """Union the region pairs a halo point links (strongest first) where the VSA
    test holds; returns the distinct pairs and the number of unions.

    A pair is *strong* when its halo points (both directions: a's owner and b's
    neighbour tile, and the reverse) number at least the smaller tile region's
    owned count; see `_Regions.ok`."""
    if not links:
        return np.zeros((0, 2), dtype=np.int64), 0
    pairs, counts = np.unique(np.concatenate(links), axis=0, return_counts=True)
    keep = has_points[pairs[:, 0]] & has_points[pairs[:, 1]] & (pairs[:, 0] != pairs[:, 1])
    pairs, counts = pairs[keep], counts[keep]
    _, inv = np.unique(np.sort(pairs, axis=1), axis=0, return_inverse=True)
    inv = inv.reshape(-1)
    both = np.bincount(inv, weights=counts)[inv]
    sizes = regions.st[:, 0].copy()  # the tile regions' own counts, before any union
    strong = both >= np.minimum(sizes[pairs[:, 0]], sizes[pairs[:, 1]])
    if regions.tiles is not None:
        strong |= _agreed(pairs, both, counts, regions.tile_of)
    order = np.lexsort((pairs[:, 1], pairs[:, 0], -counts))
    n_links = 0
    for i in order.tolist():
        a, b = int(pairs[i, 0]), int(pairs[i, 1])
        ra, rb = regions.find(a), regions.find(b)
        if ra != rb and regions.ok(ra, rb, bool(strong[i])):
            regions.union(a, b)
            n_links += 1
    return pairs, n_links


def _agreed(pairs, both, counts, tile_of):
    """Local mode: the pairs that hold at least half of the halo links between each
    of their two regions and the other region's tile (both ways), so the two tiles
    agree on the halo points there: one region (docs/decisions/batch.md)."""
    n_tiles = int(tile_of.max()) + 1
    # links of region r with any region of tile t, keyed r * n_tiles + t
    key = np.concatenate(
        [pairs[:, 0] * n_tiles + tile_of[pairs[:, 1]], pairs[:, 1] * n_tiles + tile_of[pairs[:, 0]]]
    )
    inv = np.unique(key, return_inverse=True)[1].reshape(-1)
    per = np.bincount(inv, weights=np.concatenate([counts, counts]))
    half = pairs.shape[0]
    return 2.0 * both >= np.maximum(per[inv[:half]], per[inv[half:]])
