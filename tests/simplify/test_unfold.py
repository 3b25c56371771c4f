"""Flat faces folded over in their plane, triangulated again from their outline."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from scipy.spatial import Delaunay

from pointatlas.simplify import mesh_checks, self_intersections
from pointatlas.simplify._surface_faces import face_of_loops
from pointatlas.simplify._unfold import delaunay_flips, folded_faces, unfolded
from tests.simplify.collection_runs import COLLECTION, without_and_with


def _ccw(p, t):
    a, b, c = p[t[:, 0]], p[t[:, 1]], p[t[:, 2]]
    return (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])


def _min_angle(p, t) -> float:
    out = np.inf
    for i in range(3):
        a, b, c = p[t[:, i]], p[t[:, (i + 1) % 3]], p[t[:, (i + 2) % 3]]
        u, w = b - a, c - a
        cos = (u * w).sum(1) / np.linalg.norm(u, axis=1) / np.linalg.norm(w, axis=1)
        out = min(out, float(np.degrees(np.arccos(np.clip(cos, -1, 1))).min()))
    return out


def _fan(n: int) -> np.ndarray:
    """A triangulation of the convex polygon 0..n-1 from its vertex 0 (earcut-like
    slivers where the polygon is long)."""
    return np.array([[0, i, i + 1] for i in range(1, n - 1)], dtype=np.int64)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_flips_of_a_convex_polygon_give_its_delaunay_triangulation(seed):
    """Every vertex of a convex polygon on its outline: the constrained Delaunay
    triangulation is the Delaunay triangulation of the points (scipy's Qhull)."""
    rng = np.random.default_rng(seed)
    angle = np.sort(rng.uniform(0, 2 * np.pi, 14))
    p = np.stack([3.0 * np.cos(angle), np.sin(angle)], axis=1)  # a long ellipse
    flipped = delaunay_flips(_fan(len(p)), p)
    assert (_ccw(p, flipped) > 0).all()
    ours = {tuple(sorted(r)) for r in flipped.tolist()}
    qhull = {tuple(sorted(r)) for r in Delaunay(p).simplices.tolist()}
    assert ours == qhull
    assert _min_angle(p, flipped) >= _min_angle(p, _fan(len(p)))


def test_the_flips_keep_the_outline_of_a_non_convex_polygon():
    # an L, triangulated by earcut, then flipped: the same outline edges, no flip
    # across the reflex corner (the new triangles would turn)
    p = np.array([[0, 0], [4, 0], [4, 1], [1, 1], [1, 4], [0, 4.0]])
    made = face_of_loops([np.arange(6)], np.column_stack([p, np.zeros(6)]), np.array([0, 0, 1.0]))
    assert made is not None
    flipped = delaunay_flips(made[1], p)
    assert (_ccw(p, flipped) > 0).all()
    edges = {(r[i], r[(i + 1) % 3]) for r in flipped.tolist() for i in range(3)}
    outline = {(i, (i + 1) % 6) for i in range(6)}
    assert outline <= edges
    assert np.isclose(0.5 * _ccw(p, flipped).sum(), 7.0)  # the L's area


def test_vertices_on_a_straight_edge_of_the_outline_are_kept():
    """earcut leaves out a vertex on the line of its neighbours where the face has a
    hole; with ``every_vertex`` it goes back in (the edge's triangle split), else
    no face."""
    # a rectangle with three vertices along its bottom edge and one along its top,
    # and a square hole (clockwise)
    xy = np.array(
        [[0, 0], [1, 0], [2, 0], [3, 0], [4, 0], [4, 2], [2, 2], [0, 2.0]]
        + [[1.5, 0.5], [1.5, 1.5], [2.5, 1.5], [2.5, 0.5]]
    )
    x = np.column_stack([xy, np.zeros(len(xy))])
    loops = [np.arange(8), np.arange(8, 12)]
    up = np.array([0, 0, 1.0])
    assert face_of_loops(loops, x, up) is None
    _, tri = face_of_loops(loops, x, up, every_vertex=True)
    assert tri.shape == (12 + 2 - 2, 3)  # n + 2 holes - 2
    assert set(tri.ravel().tolist()) == set(range(len(xy)))
    assert (_ccw(xy, tri) > 0).all()
    assert np.isclose(0.5 * _ccw(xy, tri).sum(), 8.0 - 1.0)
    # a vertex past its neighbours on the line (the outline doubles back): no face
    back = xy.copy()
    back[2] = [0.5, 0]
    assert face_of_loops(loops, np.column_stack([back, np.zeros(12)]), up, True) is None


def _box_with_folded_top(c=(0.8, 0.1)):
    """A unit box whose top face (z = 0.5) is a fan of four triangles around a
    vertex at ``c``: outside the fan's kernel, two of them overlap in the plane."""
    box = trimesh.creation.box()
    v = np.asarray(box.vertices, dtype=np.float64)
    f = np.asarray(box.faces, dtype=np.int64)
    top = (v[f][:, :, 2] > 0).all(axis=1)
    corners = np.flatnonzero(v[:, 2] > 0)
    ang = np.arctan2(v[corners, 1], v[corners, 0])
    ring = corners[np.argsort(ang)]  # counter-clockwise seen from +z
    v = np.vstack([v, [c[0], c[1], 0.5]])
    fan = np.array([[ring[i], ring[(i + 1) % 4], 8] for i in range(4)])
    tri = np.vstack([f[~top], fan])
    normal = np.round(np.asarray(box.face_normals)[~top]).astype(int)
    side = {tuple(n): k for k, n in enumerate(sorted({tuple(n) for n in normal.tolist()}))}
    face = np.array([side[tuple(n)] for n in normal.tolist()] + [5] * 4, dtype=np.int64)
    return v, tri, face


def _unfolded(v, tri, face, flat, tol):
    """`unfolded` of the faces `folded_faces` finds, on the unit box's diagonal."""
    return unfolded(v, tri, face, folded_faces(v, tri, face, flat)[0], np.sqrt(3.0), tol)


def test_a_folded_flat_face_is_triangulated_again_from_its_outline():
    v, tri, face = _box_with_folded_top()
    assert all(mesh_checks(v.shape[0], tri))  # closed, manifold, oriented: blind to it
    pairs = self_intersections(v, tri)
    assert len(pairs) > 0
    flat = np.ones(6, dtype=bool)
    folded, found = folded_faces(v, tri, face, flat)
    assert folded.tolist() == [5]
    np.testing.assert_array_equal(found, pairs)
    y, t, f, kept = _unfolded(v, tri, face, flat, 1e-9)
    assert self_intersections(y, t).shape == (0, 2)
    assert all(mesh_checks(y.shape[0], t))
    assert y.shape[0] == 8 and t.shape[0] == 12  # the vertex inside the top is gone
    np.testing.assert_array_equal(y, v[kept])
    assert kept.tolist() == list(range(8))
    top = t[f == 5]
    assert top.shape == (2, 3)
    n = np.cross(y[top[:, 1]] - y[top[:, 0]], y[top[:, 2]] - y[top[:, 0]])
    assert np.isclose(0.5 * np.linalg.norm(n, axis=1).sum(), 1.0)  # the top's area
    assert (n[:, 2] > 0).all()  # still facing out
    # the other faces' triangles as they were, in their order
    np.testing.assert_array_equal(t[f != 5], tri[face != 5])


def test_a_face_not_flat_or_bent_or_unfolded_stays_as_it_was():
    v, tri, face = _box_with_folded_top()
    flat = np.ones(6, dtype=bool)
    flat[5] = False  # not a flat region: not listed
    assert folded_faces(v, tri, face, flat)[0].size == 0
    out = _unfolded(v, tri, face, flat, 1e-9)
    assert out[1] is tri and out[0] is v
    bent = v.copy()
    bent[8, 2] += 1e-3  # the top bent past the tolerance: its outline bounds another surface
    assert _unfolded(bent, tri, face, np.ones(6, dtype=bool), 1e-9)[1] is tri
    # a fan whose vertex stays inside: nothing crosses, nothing changes
    v2, tri2, face2 = _box_with_folded_top(c=(0.1, -0.2))
    assert self_intersections(v2, tri2).shape == (0, 2)
    assert _unfolded(v2, tri2, face2, np.ones(6, dtype=bool), 1e-9)[1] is tri2


COVER = COLLECTION / "prusai3_fs-cover-mmu2s.stl"


@pytest.mark.skipif(not COVER.exists(), reason="the collection is not under ../shared")
def test_the_folded_faces_of_a_sampled_cad_part_are_unfolded(monkeypatch):
    """A sampled CAD part of the collection (a filament sensor cover): its output's
    flat faces folded over in their plane, triangle pairs crossing (25 with
    OpenBLAS' AVX-512 kernels, 9 with its AVX2 ones); triangulated again from their
    outlines, at most a fifth as many (none, 1), fewer triangles, the same
    distances."""
    from pointatlas.simplify import _snap

    plain, m = without_and_with(
        monkeypatch, _snap, "unfolded", lambda x, t, f, *a: (x, t, f, None), COVER
    )
    before = len(self_intersections(plain.vertices, plain.triangles))
    assert before >= 5
    assert m.summary()["n_self_intersections"] <= before // 5
    assert len(m.triangles) < len(plain.triangles)
    assert all(mesh_checks(m.n_vertices, m.triangles))
    assert m.euler_characteristic == plain.euler_characteristic
    assert m.hausdorff <= plain.hausdorff * (1 + 1e-9)
