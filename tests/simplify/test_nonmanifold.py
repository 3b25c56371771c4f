"""Non-manifold inputs of the mesh path: cut apart, then closed and manifold."""

import numpy as np
import pytest

from pointatlas.simplify import simplify_mesh
from pointatlas.simplify._mesh import mesh_checks
from pointatlas.simplify._nonmanifold import orient_consistently, split_nonmanifold
from pointatlas.synth import cube, icosphere


def _weld(vertices, faces):
    key = np.round(vertices, 9)
    uniq, inverse = np.unique(key, axis=0, return_inverse=True)
    return uniq, inverse.reshape(-1)[faces]


def _two_cubes(offset):
    """Two unit cubes (2 x 2 grid per side), the second moved by ``offset``, welded."""
    m = cube(2, size=1.0)
    v0 = m.vertices - m.vertices.min(axis=0)
    v = np.vstack([v0, v0 + offset])
    f = np.vstack([m.faces, m.faces + len(v0)])
    return _weld(v, f)


def _fans_per_vertex(tri, n_vert):
    """Plain reference: for every vertex, the number of triangle fans around it
    (triangles joined when they share an edge through the vertex)."""
    fans = np.zeros(n_vert, dtype=np.int64)
    for x in range(n_vert):
        ts = [t for t in range(len(tri)) if x in tri[t]]
        parent = {t: t for t in ts}

        def find(t, parent=parent):
            while parent[t] != t:
                t = parent[t]
            return t

        for i, s in enumerate(ts):
            for t in ts[i + 1 :]:
                if len(set(tri[s]) & set(tri[t])) >= 2:
                    parent[find(s)] = find(t)
        fans[x] = len({find(t) for t in ts})
    return fans


def _edge_counts(tri):
    und = np.sort(tri[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    return np.unique(und, axis=0, return_counts=True)[1]


def test_two_cubes_on_one_edge_become_two_closed_surfaces():
    v, f = _two_cubes([1.0, 1.0, 0.0])  # they share the edge x = y = 1
    assert _edge_counts(f).max() == 4
    tri, source = split_nonmanifold(v, f)
    assert source is not None and source.shape[0] == v.shape[0] + 3  # 3 vertices on the edge
    assert np.array_equal(v[source][tri], v[f])  # nothing moves
    assert _edge_counts(tri).max() == 2
    assert mesh_checks(v.shape[0] + 3, tri) == (True, True, True)
    assert (_fans_per_vertex(tri, len(source)) == 1).all()
    with pytest.warns(UserWarning, match="not manifold .*: cut apart there, 3 vertices copied"):
        res = simplify_mesh(v, f)
    assert res.is_closed and res.is_manifold and res.is_oriented
    assert res.n_faces == 12 and res.euler_characteristic == 4
    assert res.vertex_source.max() < v.shape[0] and res.distances.shape == (v.shape[0],)
    assert np.allclose(res.vertices, v[res.vertex_source])


def test_two_cubes_on_one_corner_split_the_pinched_vertex():
    v, f = _two_cubes([1.0, 1.0, 1.0])  # they share one corner
    assert _edge_counts(f).max() == 2
    assert _fans_per_vertex(f, len(v)).max() == 2
    tri, source = split_nonmanifold(v, f)
    assert source.shape[0] == v.shape[0] + 1
    assert (_fans_per_vertex(tri, len(source)) == 1).all()
    with pytest.warns(UserWarning, match="1 vertices copied"):
        res = simplify_mesh(v, f)
    assert res.is_closed and res.is_manifold and res.euler_characteristic == 4


@pytest.mark.parametrize("shape", ["icosphere", "cube"])
def test_manifold_meshes_are_left_alone(shape):
    m = icosphere(2) if shape == "icosphere" else cube(3)
    tri, source = split_nonmanifold(m.vertices, m.faces)
    assert source is None and tri is m.faces


def test_unoriented_pairs_stay_together():
    """A flipped triangle (its edges run like its neighbours') is not cut off."""
    m = icosphere(1)
    f = m.faces.copy()
    f[0] = f[0, ::-1]
    tri, source = split_nonmanifold(m.vertices, f)
    assert source is None
    assert mesh_checks(len(m.vertices), f) == (True, True, False)


def test_three_sheets_on_one_edge_leave_the_odd_one_as_boundary():
    """Three fins on one edge: one pair joins, the third fin is cut off there."""
    v = np.array([[0, 0, 0], [0, 0, 1], [1, 0, 0.5], [-1, 0.2, 0.5], [-1, -0.2, 0.5]], dtype=float)
    f = np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]])
    tri, source = split_nonmanifold(v, f)
    assert _edge_counts(tri).max() == 2
    assert np.array_equal(v[source][tri], v[f])


def _flipped(faces, share, seed=0):
    rng = np.random.default_rng(seed)
    flip = rng.random(len(faces)) < share
    out = faces.copy()
    out[flip] = faces[flip][:, ::-1]
    return out, flip


def test_reversed_triangles_are_turned_back_and_simplify_as_the_clean_mesh():
    from pointatlas import data

    m = data.load_mesh("fandisk")
    f, flip = _flipped(np.asarray(m.triangles), 0.1)
    tri, n = orient_consistently(m.vertices, f)
    assert n == flip.sum() and np.array_equal(tri, m.triangles)
    with pytest.warns(UserWarning, match=f"{n} of {len(f)} reversed"):
        res = simplify_mesh(m.vertices, f)
    clean = simplify_mesh(m.vertices, m.triangles)
    assert res.is_oriented and res.n_faces == clean.n_faces
    assert np.array_equal(res.triangles, clean.triangles)


def test_the_majority_orientation_wins():
    m = icosphere(2)
    f, flip = _flipped(m.faces, 0.7, seed=1)
    tri, n = orient_consistently(m.vertices, f)
    assert n == (~flip).sum()  # the 30 % given as the input were the minority
    assert np.array_equal(tri, m.faces[:, ::-1])


def test_moebius_band_is_left_as_it_is():
    """Not orientable: no choice of flips makes it consistent; nothing is flipped."""
    n = 12
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    ring = []
    for s in (-0.3, 0.3):
        r = 1 + s * np.cos(t / 2)
        ring.append(np.stack([r * np.cos(t), r * np.sin(t), s * np.sin(t / 2)], axis=1))
    v = np.vstack(ring)  # i: inner side, n + i: outer side (swapped after one turn)
    f = []
    for i in range(n):
        j = (i + 1) % n
        a, b = i, n + i
        c, d = (j, n + j) if j else (n + j, j)  # the half twist
        f += [[a, b, d], [a, d, c]]
    f = np.array(f)
    tri, flipped = orient_consistently(v, f)
    assert flipped == 0 and tri is f
