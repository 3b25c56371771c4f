"""Stitched MST signs of tiled normals equal a plain Python Kruskal (docs/decisions/
batch.md, "Tiles — normals")."""

from __future__ import annotations

from collections import defaultdict

import numpy as np
import pytest

from pointatlas.batch._kernels.signs import signed_forest_kernel
from pointatlas.batch._tiles_normals import _SHARP_WEIGHT, _normal_signs, _piece_key


def _reference(halo_parts, tops, piece_of, normals, tile_links):
    """The dict-and-loop version: votes, Kruskal by (-|vote|, keys), root rule."""
    votes = defaultdict(float)
    for b, (hg, _ho, hn, hp) in halo_parts.items():
        mine = _piece_key(b, hp)
        theirs = piece_of[hg]
        s = np.sign(np.einsum("ij,ij->i", hn, normals[hg]))
        for x, y, v in zip(np.minimum(mine, theirs), np.maximum(mine, theirs), s, strict=True):
            votes[(int(x), int(y))] += float(v)
    for t, links in tile_links.items():
        for a, b, v in links.tolist():
            votes[(int(_piece_key(t, int(a))), int(_piece_key(t, int(b))))] += _SHARP_WEIGHT * v
    keys = sorted(tops)
    parent = {key: key for key in keys}

    def find(x):
        while parent[x] != x:
            x = parent[x]
        return x

    adj = defaultdict(list)
    for (a, b), v in sorted(votes.items(), key=lambda kv: (-abs(kv[1]), kv[0])):
        if a in parent and b in parent and v != 0.0 and find(a) != find(b):
            parent[find(b)] = find(a)
            adj[a].append((b, 1.0 if v > 0 else -1.0))
            adj[b].append((a, 1.0 if v > 0 else -1.0))
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
        root = 1.0 if tops[best][2] * rel[best] >= 0.0 else -1.0
        for u in comp:
            flips[u] = rel[u] * root
    return np.array(keys, dtype=np.int64), np.array([flips[k] for k in keys])


def _case(seed, n_tiles=5, n=600, pieces=12):
    rng = np.random.default_rng(seed)
    owner = rng.integers(0, n_tiles, n)
    normals = rng.normal(size=(n, 3))
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    piece = rng.integers(0, pieces, n)
    piece_of = _piece_key(owner, piece)
    tops, halo_parts, links = {}, {}, {}
    z = np.round(rng.normal(size=n), 1)  # ties in z: the smallest index wins
    for t in range(n_tiles):
        own = np.flatnonzero(owner == t)
        rows = {}
        for i in own[np.lexsort((own, -z[own]))]:
            rows.setdefault(int(piece[i]), (float(z[i]), int(i), float(normals[i, 2])))
        tops[t] = rows
        hg = np.sort(rng.choice(np.flatnonzero(owner != t), 40, replace=False))
        hn = normals[hg] * rng.choice([-1.0, 1.0], (hg.size, 1))
        hn[:3] = [0.0, 0.0, 0.0]  # zero votes are skipped
        hp = rng.integers(0, pieces + 2, hg.size)  # some halo pieces own no point
        halo_parts[t] = (hg, owner[hg], hn, hp)
        ab = np.sort(rng.choice(pieces, (8, 2)), axis=1)
        ab = np.unique(ab[ab[:, 0] < ab[:, 1]], axis=0)
        links[t] = np.column_stack([ab, rng.normal(size=ab.shape[0])]).astype(np.float64)
    return halo_parts, tops, piece_of, normals, links


@pytest.mark.parametrize("seed", range(6))
def test_normal_signs_equal_the_plain_reference(seed):
    halo_parts, tops, piece_of, normals, links = _case(seed)
    ref_keys, ref_flips = _reference(
        halo_parts,
        {int(_piece_key(t, c)): v for t, rows in tops.items() for c, v in rows.items()},
        piece_of,
        normals,
        links,
    )
    arrays = {
        t: (_piece_key(t, np.fromiter(r, np.int64, len(r))), list(r.values()))
        for t, r in tops.items()
    }
    keys, flips = _normal_signs(halo_parts, arrays, piece_of, normals, links)
    assert keys.dtype == np.int64 and flips.dtype == np.float64
    np.testing.assert_array_equal(keys, ref_keys)
    np.testing.assert_array_equal(flips, ref_flips)
    assert np.isin(flips, [-1.0, 1.0]).all()


def test_signed_forest_follows_the_edge_order():
    # a triangle: the first two edges join it, the third (a contradiction) is dropped
    comp, rel = signed_forest_kernel(
        4, np.array([0, 1, 0]), np.array([1, 2, 2]), np.array([False, False, False])
    )
    np.testing.assert_array_equal(comp, [0, 0, 0, 1])
    np.testing.assert_array_equal(rel, [1.0, -1.0, 1.0, 1.0])
