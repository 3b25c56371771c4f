"""The mesh path: CAD-like parts, open sheets, rigid motions, the fallback guarantee."""

from __future__ import annotations

import numpy as np
import pytest

from pointatlas import data
from pointatlas.simplify import mesh_checks, simplify_mesh
from pointatlas.simplify._surface import simplify_surface
from pointatlas.synth import plane_patch

from . import cad_shapes as C

# (shape, exact number of faces or None, Euler characteristic = 2 - 2 genus)
SHAPES = [
    ("box", 6, 2),
    ("l_bracket", 8, 2),
    ("cube_with_square_hole", 10, 0),
    ("plate_with_two_holes", None, -2),
    ("cylinder", None, 2),
]


def _euler(n_vertices, triangles):
    und = np.sort(
        np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]), 1
    )
    return n_vertices - np.unique(und, axis=0).shape[0] + triangles.shape[0]


@pytest.mark.parametrize(("name", "n_faces", "chi"), SHAPES, ids=[s[0] for s in SHAPES])
def test_cad_parts_give_closed_manifold_meshes_of_the_right_genus(name, n_faces, chi):
    v, t = getattr(C, name)()
    assert mesh_checks(len(v), t) == (True, True, True)
    res = simplify_mesh(v, t)
    assert (res.is_closed, res.is_manifold, res.is_oriented) == (True, True, True)
    assert res.euler_characteristic == chi == _euler(res.n_vertices, res.triangles)
    assert not res.face_kept_input.any()
    if n_faces is not None:
        assert res.n_faces == n_faces
        assert res.distance_max < 1e-12  # flat faces: the output is the part itself
        assert res.planarity_error.max() < 1e-12
    # every output vertex is an input vertex, unmoved
    np.testing.assert_array_equal(res.vertices, v[res.vertex_source])
    # the polygons cover the triangles: one polygon per face without holes
    assert len(res.polygons) >= res.n_faces


def test_sparse_cad_box_is_its_own_simplification():
    v, t = C.box()
    res = simplify_mesh(v, t)
    assert res.n_vertices == 8 and res.n_faces == 6
    assert sorted(len(p) for p in res.polygons) == [4] * 6


def test_cylinder_becomes_the_prism_of_the_requested_face_count():
    v, t = C.cylinder(64)
    res = simplify_mesh(v, t, n_faces=10)
    assert res.n_faces == 10 and res.is_closed and res.is_manifold
    assert res.euler_characteristic == 2
    # two caps (64-gons in the cap plane) and eight side faces
    sizes = sorted(len(lp[0]) for lp in res.face_loops)
    assert sizes[-2:] == [8, 8] or sizes[-1] >= 8


def test_plate_holes_are_kept_as_holes_through_the_plate():
    v, t = C.plate_with_two_holes()
    res = simplify_mesh(v, t)
    holes = res.n_holes
    assert holes.max() == 2  # the top and bottom faces each have both holes
    assert int((holes == 2).sum()) == 2


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_rigid_motions_move_the_output_the_same_way(seed):
    rng = np.random.default_rng(seed)
    v, t = C.l_bracket()
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    if np.linalg.det(q) < 0:
        q[:, 0] = -q[:, 0]
    shift = rng.normal(size=3) * 100.0
    base = simplify_mesh(v, t)
    moved = simplify_mesh(v @ q.T + shift, t)
    assert moved.n_faces == base.n_faces
    np.testing.assert_array_equal(moved.vertex_source, base.vertex_source)
    np.testing.assert_allclose(moved.vertices, base.vertices @ q.T + shift, atol=1e-9)
    assert moved.is_closed and moved.is_manifold and moved.is_oriented


def test_translation_by_a_power_of_two_changes_nothing_but_the_position():
    mesh = data.load_mesh("fandisk")
    v, t = mesh.vertices, mesh.triangles
    base = simplify_mesh(v, t)
    shifted = simplify_mesh(v + 2.0**20, t)
    assert shifted.n_faces == base.n_faces
    np.testing.assert_array_equal(shifted.vertex_source, base.vertex_source)
    np.testing.assert_array_equal(shifted.face_labels, base.face_labels)


def test_open_sheet_keeps_its_boundary():
    m = plane_patch()
    v, t = m.vertices, np.asarray(m.faces)
    res = simplify_mesh(v, t)
    assert not res.is_closed and res.is_manifold and res.is_oriented
    assert res.euler_characteristic == 1  # a disk
    # the output's boundary vertices lie on the input's boundary loop
    und = np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), 1)
    e, c = np.unique(und, axis=0, return_counts=True)
    input_border = set(e[c == 1].reshape(-1).tolist())
    out = res.triangles
    und = np.sort(np.concatenate([out[:, [0, 1]], out[:, [1, 2]], out[:, [2, 0]]]), 1)
    e, c = np.unique(und, axis=0, return_counts=True)
    out_border = set(res.vertex_source[e[c == 1].reshape(-1)].tolist())
    assert out_border <= input_border
    # the corners of the sheet survive
    lo, hi = v.min(axis=0), v.max(axis=0)
    assert res.vertices.min(axis=0).tolist() == lo.tolist()
    assert res.vertices.max(axis=0).tolist() == hi.tolist()


def test_a_region_that_folds_over_keeps_its_input_triangles():
    """The fallback guarantee: the whole side of a cylinder as one region cannot be a
    planar polygon; it keeps its triangles and the mesh stays closed and manifold."""
    v, t = C.cylinder(32)
    normals = np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    labels = np.where(normals[:, 2] > 0.5, 0, np.where(normals[:, 2] < -0.5, 1, 2))
    proxies = np.array([[0, 0, 1.0], [0, 0, -1.0], [1.0, 0, 0]])
    res = simplify_surface(v, t, labels, proxies, chord_tolerance=0.01)
    assert res.face_kept_input.tolist() == [False, False, True]
    assert (res.is_closed, res.is_manifold, res.is_oriented) == (True, True, True)
    assert res.euler_characteristic == 2


@pytest.mark.parametrize(("name", "chi"), [("torus", 0), ("eight", -2), ("fandisk", 2)])
def test_bundled_models_give_closed_manifold_meshes(name, chi):
    mesh = data.load_mesh(name)
    res = simplify_mesh(mesh.vertices, mesh.triangles)
    assert (res.is_closed, res.is_manifold, res.is_oriented) == (True, True, True)
    assert res.euler_characteristic == chi


def test_max_error_bounds_the_distance():
    mesh = data.load_mesh("eight")  # fandisk: 13 levels of 1,000 faces, 30 CPU-s
    v = mesh.vertices
    bound = 0.002 * float(np.linalg.norm(v.max(axis=0) - v.min(axis=0)))
    res = simplify_mesh(v, mesh.triangles, max_error=bound)
    assert res.distance_max <= bound
    assert res.is_closed and res.is_manifold
    coarse = simplify_mesh(v, mesh.triangles)
    assert res.n_faces >= coarse.n_faces  # a tighter bound needs at least as many faces


def test_options_are_validated():
    v, t = C.box()
    with pytest.raises(ValueError, match="at most one"):
        simplify_mesh(v, t, max_angle=0.1, n_faces=4)
    with pytest.raises(ValueError, match="max_angle"):
        simplify_mesh(v, t, max_angle=float("nan"))
    with pytest.raises(ValueError, match="triangles"):
        simplify_mesh(v, t[:, :2])
    with pytest.raises(ValueError, match="index"):
        simplify_mesh(v, t + 100)
    with pytest.raises(ValueError, match="n_faces"):
        simplify_mesh(v, t, n_faces=0)


def test_planarize_flattens_faces_and_keeps_the_mesh_valid():
    v, t = C.cylinder(64)
    plain = simplify_mesh(v, t)
    flat = simplify_mesh(v, t, planarize=True)
    assert flat.n_faces == plain.n_faces
    np.testing.assert_array_equal(flat.vertex_source, plain.vertex_source)
    # both write planar polygons (a curved face as planar pieces); the faces of the
    # curved side bend, less once planarized
    assert max(flat.polygon_planarity.max(), plain.polygon_planarity.max()) < 1e-12
    assert 0.0 < flat.planarity_error.max() < plain.planarity_error.max()
    assert len(flat.polygons) <= len(plain.polygons)
    assert (flat.is_closed, flat.is_manifold, flat.is_oriented) == (True, True, True)
    moved = np.linalg.norm(flat.vertices - plain.vertices, axis=1)
    assert moved.max() <= flat.chord_tolerance * (1 + 1e-12)
    # a flat part is already planar: nothing moves
    v, t = C.l_bracket()
    np.testing.assert_array_equal(
        simplify_mesh(v, t, planarize=True).vertices, simplify_mesh(v, t).vertices
    )


def test_two_vertex_loop_keeps_integer_vertices():
    # a closed arc of two vertices (a region bounded by one edge walked both ways, as
    # a non-manifold input edge gives: the dragon scan's edge on four triangles) has no
    # half with an interior vertex to add; its kept vertices stay vertex ids
    from pointatlas.simplify._arcs import Arc, simplify_arc

    positions = np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 1, 0], [0, 0, 1], [3, 1, 0]])
    arc = Arc([5, 2, 5], (0, 1), 0.1)
    simplify_arc(arc, positions)
    assert arc.kept == [5, 2, 5] and all(isinstance(v, int) for v in arc.kept)


def test_face_planarity_is_the_whole_faces_against_a_numpy_reference():
    """A face's planarity is the largest distance of all its vertices to their
    least-squares plane (numpy's SVD per face), also for a face written in pieces."""
    from pointatlas.simplify._surface import face_planarity

    rng = np.random.default_rng(3)
    v = rng.normal(size=(60, 3))
    t = rng.integers(0, 60, size=(90, 3))
    face = rng.integers(0, 7, size=90)
    got = face_planarity(v, t, face, 8)
    for f in range(8):
        ids = np.unique(t[face == f])
        if ids.size == 0:
            assert got[f] == 0.0
            continue
        c = v[ids] - v[ids].mean(axis=0)
        want = np.abs(c @ np.linalg.svd(c)[2][-1]).max() if ids.size > 3 else 0.0
        assert got[f] == pytest.approx(want, rel=1e-9, abs=1e-12)


def test_the_report_gives_the_flat_faces_and_their_planarity():
    v, t = C.subdivide(*C.cylinder(32))
    res = simplify_mesh(v, t)
    s = res.summary()
    # the two caps are flat and exactly planar; the side's faces bend
    assert s["n_flat_faces"] == int(res.face_flat.sum()) >= 2
    assert s["max_flat_planarity_error"] < 1e-12 < s["max_planarity_error"]
