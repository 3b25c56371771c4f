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


def _soup(vertices, faces):
    """Every triangle with its own three vertices (an STL-like triangle soup)."""
    v = np.asarray(vertices)[np.asarray(faces).reshape(-1)]
    return v, np.arange(v.shape[0]).reshape(-1, 3)


@pytest.mark.parametrize("shape", ["cube", "icosphere", "fandisk"])
def test_a_triangle_soup_simplifies_as_the_indexed_mesh(shape):
    from pointatlas import data

    m = {
        "cube": lambda: cube(6),
        "icosphere": lambda: icosphere(2),
        "fandisk": lambda: data.load_mesh("fandisk"),
    }[shape]()
    f = np.asarray(m.triangles if shape == "fandisk" else m.faces)
    v = np.asarray(m.vertices, dtype=float)
    sv, sf = _soup(v, f)
    n_weld = len(sv) - len(np.unique(v[np.unique(f)], axis=0))
    with pytest.warns(UserWarning, match=f"^{n_weld} vertices at the position of another"):
        res = simplify_mesh(sv, sf)
    clean = simplify_mesh(v, f)
    assert res.is_closed and res.is_manifold and res.is_oriented
    assert res.n_faces == clean.n_faces
    # reported in the soup's ids: every output vertex is a soup vertex, placed on its
    # flat faces' planes by at most the placement bound
    moved = np.linalg.norm(sv[res.vertex_source] - res.vertices, axis=1)
    assert moved.max() <= max(res.chord_tolerance, 1e-3 * np.ptp(v, axis=0).max() * 2)
    assert res.distances.shape == (len(sv),) and res.face_labels.shape == (len(sf),)
    if shape == "icosphere":
        # curved: ties between equal chords follow the vertex ids, which a soup numbers
        # differently; the same accuracy
        assert res.distance_max == pytest.approx(clean.distance_max, rel=0.05)
        return
    # flat faces: the same mesh (corners and regions do not depend on the numbering)
    assert np.array_equal(res.vertices, clean.vertices)
    assert np.array_equal(res.face_labels, clean.face_labels)
    np.testing.assert_array_equal(res.distances, clean.distances[f.reshape(-1)])


def test_repeated_and_degenerate_triangles_are_dropped():
    m = icosphere(2)
    v, f = m.vertices, m.faces
    extra = np.vstack([f[:4][:, ::-1], f[5:6], [[0, 0, 1], [2, 3, 3]]])
    with pytest.warns(UserWarning, match="2 degenerate .* and 5 repeated triangles dropped"):
        res = simplify_mesh(v, np.vstack([f, extra]))
    clean = simplify_mesh(v, f)
    assert res.is_closed and res.is_manifold and res.is_oriented
    assert np.array_equal(res.triangles, clean.triangles)
    n = len(f)
    lab = res.face_labels
    assert lab.shape == (n + 7,) and np.array_equal(lab[:n], clean.face_labels)
    # a repeat takes its first copy's region, a degenerate triangle none
    assert np.array_equal(lab[n : n + 5], lab[[0, 1, 2, 3, 5]])
    assert np.array_equal(lab[n + 5 :], [-1, -1])


def test_a_clean_mesh_needs_no_repair():
    from pointatlas.simplify._nonmanifold import repair_mesh_input

    m = cube(4)
    assert repair_mesh_input(np.asarray(m.vertices, dtype=float), np.asarray(m.faces)) is None


def test_cli_simplifies_a_triangle_soup_ply_to_a_closed_mesh(tmp_path):
    from pointatlas.io import read_mesh, write_mesh

    from ..cli.helpers import run

    m = cube(6)
    sv, sf = _soup(np.asarray(m.vertices, dtype=float), m.faces)
    src, out = tmp_path / "soup.ply", tmp_path / "out.obj"
    write_mesh(src, sv, sf)
    result = run("simplify", src, out)
    assert result.exit_code == 0, result.output
    assert "welded" in result.output
    got = read_mesh(out)
    assert got.n_faces == 6
    assert mesh_checks(len(got.vertices), got.triangles) == (True, True, True)
    assert got.vertices.shape[0] == 8


def test_stray_vertices_move_nothing_and_get_no_distance(tmp_path):
    """Vertices on no triangle (left over in an export) change neither the default
    chord tolerance nor the output; their distance is NaN, the mean and max are the
    clean mesh's."""
    from pointatlas import data

    m = data.load_mesh("fandisk")
    v, f = np.asarray(m.vertices, dtype=float), np.asarray(m.triangles)
    stray = np.vstack([v, [[10.0, 10.0, 10.0], v[0]]])
    res, clean = simplify_mesh(stray, f), simplify_mesh(v, f)
    assert res.n_faces == clean.n_faces and np.array_equal(res.triangles, clean.triangles)
    assert np.isnan(res.distances[len(v) :]).all()
    np.testing.assert_array_equal(res.distances[: len(v)], clean.distances)
    assert (res.distance_mean, res.distance_max) == (clean.distance_mean, clean.distance_max)
    # through the CLI: --max-error as a percentage of the surface's diagonal (a curved
    # shape, whose level search reads the distances)
    from pointatlas.io import read_mesh, write_mesh

    from ..cli.helpers import run

    ico = icosphere(2)
    v, f = np.asarray(ico.vertices, dtype=float), np.asarray(ico.faces)
    stray = np.vstack([v, [[10.0, 10.0, 10.0]]])
    outs = []
    for name, verts in (("clean", v), ("stray", stray)):
        src, out = tmp_path / f"{name}.obj", tmp_path / f"{name}_out.obj"
        write_mesh(src, verts, f)
        result = run("simplify", src, out, "--max-error", "0.5%")
        assert result.exit_code == 0, result.output
        outs.append(read_mesh(out))
    assert outs[0].n_faces == outs[1].n_faces
    np.testing.assert_array_equal(outs[0].vertices, outs[1].vertices)
