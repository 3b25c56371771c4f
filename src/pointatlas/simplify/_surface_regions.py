"""The regions of the points path's voxel surface and their planes (private).

The triangles of the surface (`_reconstruct.reconstruct_surface`) take the regions of
their nearest points (`transfer_labels`), and every region's plane comes from its
points (`region_planes`). Decisions in docs/decisions/simplify.md ("The points path's
robust path").
"""

from __future__ import annotations

import numpy as np

__all__ = ["FLAT_SHARE", "region_layers", "region_planes", "transfer_labels"]

#: A region is flat when this share of its points lie near its plane.
FLAT_SHARE = 0.95
#: A region's plane is refitted to its points whose normals lie within this angle of
#: its proxy's (degrees): the points of the faces beside it that the region reaches
#: over an edge, and of the walls of a recess, tilt the proxy's normal (0.3 degrees on
#: a sampled calibration cube's faces: their points 0.15 % of the diagonal off it).
FACE_ANGLE = 10.0
#: A layer of a region's points (parallel planes apart by more than the gap) becomes a
#: region of its own when it holds this many points and this share of the region's.
MIN_LAYER = 20
MIN_LAYER_SHARE = 0.02
#: A narrow region is still a plane when `FLAT_SHARE` of its points' normals lie
#: within this angle of its normal (degrees).
STEADY_ANGLE = 5.0
#: Rounds of the refit (each on the largest layer found along the last normal).
REFITS = 2


def transfer_labels(s, graph, point_labels, nearest):
    """Regions of the triangles from the points' regions: each triangle takes its
    nearest point's region; only the largest connected piece of every region keeps
    it, the other triangles take a neighbour's region (flooded, most neighbours
    first), so every region is connected in the edge graph. Returns the triangles'
    regions, numbered 0..R-1, and the points' region of each (R,): the one it was
    flooded from, not the nearest point's of any one triangle (a flooded triangle's
    nearest point lies in another region: taking the last triangle's gave a side
    wall of a sampled fan mount its top face's plane)."""
    from scipy.sparse import csgraph

    lab = np.asarray(point_labels, dtype=np.int64)[nearest]
    coo = graph.tocoo()
    same = lab[coo.row] == lab[coo.col]
    n = lab.size
    g = _adjacency(coo.row[same], coo.col[same], n)
    _, piece = csgraph.connected_components(g, directed=False)
    area = np.bincount(piece, weights=s.areas + 1e-300)
    first = _first_of(piece)  # a triangle of every piece
    best = np.full(int(lab.max()) + 1, -1)
    order = np.argsort(area, kind="stable")  # largest last: it wins
    best[lab[first[order]]] = order
    keep = best[lab] == piece
    out = np.where(keep, lab, -1)
    rows, cols = coo.row, coo.col
    while (out < 0).any():
        open_ = out[rows] < 0
        src = open_ & (out[cols] >= 0)
        if not src.any():  # a piece with no labelled neighbour: its own region
            rest = out < 0
            out[rest] = int(lab.max()) + 1 + piece[rest]
            break
        r, c = rows[src], out[cols[src]]
        key = r * (int(lab.max()) + 1) + c
        uk, cnt = np.unique(key, return_counts=True)
        o = np.lexsort((-cnt, uk // (int(lab.max()) + 1)))
        uk = uk[o]
        tri_id = uk // (int(lab.max()) + 1)
        first = np.r_[True, tri_id[1:] != tri_id[:-1]]
        out[tri_id[first]] = uk[first] % (int(lab.max()) + 1)
    uniq, renum = np.unique(out, return_inverse=True)
    renum = renum.reshape(-1)
    source = uniq.copy()
    alone = np.flatnonzero(uniq[renum] > lab.max())  # triangles of unflooded pieces
    source[renum[alone]] = lab[alone]  # a piece is of one region
    return renum, source


def _first_of(piece):
    """A (the first) triangle of every piece."""
    _, first = np.unique(piece, return_index=True)
    return first


def _adjacency(a, b, n):
    """The (n, n) graph with edges (a, b)."""
    from scipy.sparse import coo_array

    return coo_array((np.ones(a.size, np.int8), (a, b)), shape=(n, n))


def region_layers(q, normals, labels, proxy_normals, gap: float):
    """The points' regions split into their parallel layers, with refitted normals.

    Only a region's points whose own normals lie within `FACE_ANGLE` of its
    proxy's count (not the walls of a recess, nor the points reaching over an
    edge). Along the normal they are cut into layers where their heights leave a
    gap wider than ``gap``; the normal becomes the least-squares plane's of the
    largest layer (kept when it stays within `FACE_ANGLE`; `REFITS` rounds), and
    each layer but the largest of at least `MIN_LAYER`
    points and `MIN_LAYER_SHARE` of the region becomes a region of its own, with
    the same normal (the floor of an engraved letter, which VSA joins to the face
    around it: the face was not flat, and none of its vertices went onto a plane).
    Smaller layers stay (points reaching over an edge).

    Returns ``(labels, normals)``: the points' regions, the old ones first and the
    layers numbered after them, and each region's unit normal.

    Examples
    --------
    >>> g = np.stack(np.meshgrid(np.arange(10.0), np.arange(10.0)), -1).reshape(-1, 2)
    >>> q = np.vstack([np.c_[g, np.zeros(100)], np.c_[g[:30], np.full(30, -1.0)]])
    >>> lab, n = region_layers(q, np.tile([0.0, 0, 1], (130, 1)), np.zeros(130, int),
    ...                        np.array([[0.0, 0, 1]]), 0.5)
    >>> np.bincount(lab).tolist(), n.tolist()
    ([100, 30], [[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]])
    """
    labels = np.asarray(labels, dtype=np.int64)
    pn = np.array(proxy_normals, dtype=np.float64)
    n_in = pn.shape[0]
    order = np.argsort(labels, kind="stable")
    bounds = np.searchsorted(labels[order], np.arange(n_in + 1))
    cos_face = np.cos(np.radians(FACE_ANGLE))
    out, layers = labels.copy(), []
    for r in np.flatnonzero(np.diff(bounds) >= 2 * MIN_LAYER):
        pick = order[bounds[r] : bounds[r + 1]]
        face = pick[normals[pick] @ pn[r] > cos_face]  # not the walls of a recess
        if face.size < 2 * MIN_LAYER:
            continue
        for _ in range(REFITS):  # the largest layer's plane, and its layers again
            layer = _layers(q[face] @ pn[r], gap)
            main = q[face[layer == np.argmax(np.bincount(layer))]]
            _, _, vt = np.linalg.svd(main - main.mean(axis=0), full_matrices=False)
            n = vt[-1] * np.sign(vt[-1] @ pn[r])
            pn[r] = n if n @ pn[r] > cos_face else pn[r]
        layer = _layers(q[face] @ pn[r], gap)
        size = np.bincount(layer)
        big = size >= max(MIN_LAYER, MIN_LAYER_SHARE * pick.size)
        big[np.argmax(size)] = False
        for k in np.flatnonzero(big):
            out[face[layer == k]] = n_in + len(layers)
            layers.append(pn[r])
        for group, normal in _slopes(pick[normals[pick] @ pn[r] <= cos_face], normals, cos_face):
            out[group] = n_in + len(layers)
            layers.append(normal)
    return out, np.vstack([pn, *layers]) if layers else pn


def _slopes(rest, normals, cos_face: float):
    """The groups of at least `MIN_LAYER` of a region's points ``rest`` (those whose
    normals lie beyond `FACE_ANGLE` of its plane's) whose normals lie within
    `FACE_ANGLE` of their first one's, with their mean normal: a chamfer VSA joined
    to the face beside it (placed onto the face's plane, its points were cut off)."""
    while rest.size >= MIN_LAYER:
        same = normals[rest] @ normals[rest[0]] > cos_face
        if np.count_nonzero(same) >= MIN_LAYER:
            n = normals[rest[same]].sum(axis=0)
            yield rest[same], n / np.linalg.norm(n)
        rest = rest[~same]


def _layers(h, gap: float) -> np.ndarray:
    """Layer of every height: cut where the sorted heights leave a gap over ``gap``."""
    o = np.argsort(h, kind="stable")
    layer = np.zeros(h.size, dtype=np.int64)
    layer[o[1:]] = np.cumsum(np.diff(h[o]) > gap)
    return layer


def region_planes(q, labels, proxy_normals, source, normals=None):
    """The planes of the surface's regions from their points: the proxy's normal, at
    the median offset of the region's points; and the distance to it within which
    `FLAT_SHARE` of them lie (a few points labelled across an edge do not make a
    flat face curved, nor shift its plane).

    ``labels``: the points' regions; surface region ``r`` is the points' region
    ``source[r]``. Returns ``(normals, offsets, deviation, width, steady)`` per
    surface region, ``width`` the standard deviation of its points across their
    longest direction (a band along an edge is narrow), ``steady`` whether
    `FLAT_SHARE` of its points' ``normals`` lie within `STEADY_ANGLE` of its normal
    (a narrow chamfer, not a band where estimated normals turn over an edge; all
    False without ``normals``).
    """
    labels = np.asarray(labels, dtype=np.int64)
    n_in = int(labels.max()) + 1
    pn = np.asarray(proxy_normals, dtype=np.float64)
    height = np.einsum("ij,ij->i", q, pn[labels])
    order = np.lexsort((height, labels))
    bounds = np.searchsorted(labels[order], np.arange(n_in + 1))
    off, dev, width = np.zeros(n_in), np.zeros(n_in), np.zeros(n_in)
    steady = np.zeros(n_in, dtype=bool)
    cos_steady = np.cos(np.radians(STEADY_ANGLE))
    for r in np.flatnonzero(np.diff(bounds)):
        pick = order[bounds[r] : bounds[r + 1]]
        h = height[pick]  # sorted
        off[r] = h[h.size // 2]
        dev[r] = np.quantile(np.abs(h - off[r]), FLAT_SHARE)
        if pick.size >= 3:  # the spread of the points across their longest direction
            width[r] = np.sqrt(max(np.linalg.eigvalsh(np.cov(q[pick].T))[1], 0.0))
        if normals is not None and pick.size >= MIN_LAYER:
            steady[r] = np.mean(normals[pick] @ pn[r] >= cos_steady) >= FLAT_SHARE
    return pn[source], off[source], dev[source], width[source], steady[source]
