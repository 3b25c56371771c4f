"""CAD-like closed triangle meshes with known topology, built by extruding polygons.

Each shape is what a CAD export gives: few vertices on large flat faces (the caps
are earcut triangulations of the outline, the sides one quad = two triangles per
outline edge), consistently oriented outwards.
"""

from __future__ import annotations

import mapbox_earcut
import numpy as np


def _ring(xy) -> np.ndarray:
    xy = np.asarray(xy, dtype=np.float64)
    x, y = xy[:, 0], xy[:, 1]
    area = 0.5 * (x @ np.roll(y, -1) - np.roll(x, -1) @ y)
    return xy if area > 0 else xy[::-1].copy()


def extrude(outer, holes=(), height: float = 1.0):
    """Closed prism over a polygon with holes: (vertices, triangles), outward oriented."""
    rings = [_ring(outer)] + [_ring(h)[::-1].copy() for h in holes]  # holes clockwise
    xy = np.concatenate(rings)
    n = xy.shape[0]
    ends = np.cumsum([len(r) for r in rings]).astype(np.uint32)
    cap = np.asarray(mapbox_earcut.triangulate_float64(xy, ends), dtype=np.int64).reshape(-1, 3)
    a, b, c = xy[cap[:, 0]], xy[cap[:, 1]], xy[cap[:, 2]]
    ccw = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    cap[ccw < 0] = cap[ccw < 0][:, [0, 2, 1]]
    bottom = np.column_stack([xy, np.zeros(n)])
    top = np.column_stack([xy, np.full(n, height)])
    vertices = np.concatenate([bottom, top])
    tris = [cap[:, [0, 2, 1]], cap + n]  # bottom faces down, top faces up
    start = 0
    for r in rings:
        m = len(r)
        i = start + np.arange(m)
        j = start + (np.arange(m) + 1) % m
        tris.append(np.column_stack([i, j, j + n]))
        tris.append(np.column_stack([i, j + n, i + n]))
        start += m
    return vertices, np.concatenate(tris)


def circle(center, radius, n):
    t = 2.0 * np.pi * np.arange(n) / n
    return np.column_stack([center[0] + radius * np.cos(t), center[1] + radius * np.sin(t)])


def box():
    """A sparse CAD box: 8 vertices, 12 triangles."""
    return extrude([[0, 0], [2, 0], [2, 1], [0, 1]], height=0.5)


def cylinder(n=64):
    return extrude(circle((0, 0), 1.0, n), height=2.0)


def plate_with_two_holes(n=32):
    outer = [[0, 0], [6, 0], [6, 3], [0, 3]]
    return extrude(outer, [circle((1.5, 1.5), 0.6, n), circle((4.5, 1.5), 0.6, n)], height=0.4)


def l_bracket():
    return extrude([[0, 0], [4, 0], [4, 1], [1, 1], [1, 3], [0, 3]], height=2.0)


def cube_with_square_hole():
    return extrude([[0, 0], [3, 0], [3, 3], [0, 3]], [[[1, 1], [2, 1], [2, 2], [1, 2]]], height=3.0)


def square(x, y, w):
    """The square ``w`` across with its corner at (x, y), counter-clockwise."""
    return [[x, y], [x + w, y], [x + w, y + w], [x, y + w]]


def pocketed_block(pockets, size=4.0, height=1.0, depth=0.5):
    """A square block ``size`` across with blind square pockets ``depth`` deep
    (``pockets``: (x, y, width) of each), as outward triangles of its faces (a
    surface to sample, not one mesh: the faces meet at the edges without sharing
    vertices)."""
    outer = square(0, 0, size)
    rings = [square(x, y, w) for x, y, w in pockets]
    floor = height - depth
    # the rim: the top with the pockets' openings, outer and pocket walls above the
    # floor (its bottom dropped); the base below the floor (its top dropped); floors
    parts = [_faces_facing(*extrude(outer, rings, height=depth), up=False, lift=floor)]
    parts.append(_faces_facing(*extrude(outer, height=floor), up=True))
    parts += [_faces_facing(*extrude(r, height=floor), up=True, keep=True) for r in rings]
    vertices, triangles, start = [], [], 0
    for v, t in parts:
        vertices.append(v)
        triangles.append(t + start)
        start += v.shape[0]
    return np.concatenate(vertices), np.concatenate(triangles)


def _faces_facing(vertices, triangles, up: bool, lift: float = 0.0, keep: bool = False):
    """A prism's triangles without those facing ``up`` (or down), or with only those
    facing up (``keep``), its vertices lifted by ``lift``."""
    e1 = vertices[triangles[:, 1]] - vertices[triangles[:, 0]]
    e2 = vertices[triangles[:, 2]] - vertices[triangles[:, 0]]
    nz = np.cross(e1, e2)[:, 2]
    facing = nz > 0.0 if up else nz < 0.0
    chosen = facing if keep else ~facing
    return vertices + [0.0, 0.0, lift], triangles[chosen]


def subdivide(vertices, triangles):
    """Every triangle split into four at its edges' midpoints (flat faces stay flat,
    as a CAD export tessellated finer): (vertices, triangles)."""
    v = np.asarray(vertices, dtype=np.float64)
    t = np.asarray(triangles, dtype=np.int64)
    sides = np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1)
    edges, inverse = np.unique(sides, axis=0, return_inverse=True)
    ab, bc, ca = (v.shape[0] + inverse.reshape(3, -1)).tolist()
    a, b, c = t.T.tolist()
    mid = 0.5 * (v[edges[:, 0]] + v[edges[:, 1]])
    tris = [np.column_stack(x) for x in ((a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca))]
    return np.vstack([v, mid]), np.concatenate(tris)
