"""The points path's last placement step: faces of flat regions a little bent, moved
onto their own planes (`_planar.planar_faces`), faces meeting on near-parallel planes
taken as one (`_planar.merged_planar_faces`), and the triangles that keep a face bent
set apart (`_planar.bent_apart`)."""

import numpy as np

from pointatlas.simplify._place import plane_fits
from pointatlas.simplify._planar import (
    bent_apart,
    edge_neighbours,
    merged_planar_faces,
    off_plane_relabelled,
    planar_faces,
)


def _grid(n, lift, rng):
    """An n x n grid of vertices on z = 0 in (n - 1)^2 quads of two triangles, each
    vertex lifted by up to ``lift`` (seeded)."""
    x, y = np.meshgrid(np.arange(n, dtype=float), np.arange(n, dtype=float))
    v = np.column_stack([x.ravel(), y.ravel(), rng.uniform(-lift, lift, n * n)])
    tri = []
    for j in range(n - 1):
        for i in range(n - 1):
            a, b, c, d = j * n + i, j * n + i + 1, (j + 1) * n + i + 1, (j + 1) * n + i
            tri += [(a, b, c), (a, c, d)]
    return v, np.array(tri)


def _box_corner(n, lift, seed):
    """Three faces of a cube meeting at the origin (x = 0, y = 0, z = 0), each an
    n x n grid, welded along their shared edges, every vertex then moved by up to
    ``lift`` along each axis (seeded)."""
    rng = np.random.default_rng(seed)
    verts, tris, faces = [], [], []
    for k, axes in enumerate(((0, 1, 2), (1, 2, 0), (2, 0, 1))):
        v, t = _grid(n, 0.0, rng)
        w = np.empty_like(v)
        w[:, axes[0]], w[:, axes[1]], w[:, axes[2]] = v[:, 0], v[:, 1], v[:, 2]
        offset = sum(len(p) for p in verts)
        verts.append(w)
        tris.append(t + offset)
        faces.append(np.full(len(t), k))
    v, t, face = np.vstack(verts), np.vstack(tris), np.concatenate(faces)
    _, first, inv = np.unique(v, axis=0, return_index=True, return_inverse=True)
    v = v[first] + rng.uniform(-lift, lift, (first.size, 3))
    return v, inv.reshape(-1)[t], face


def _planarity(v, t, face, n_faces):
    return plane_fits(v, t, face, n_faces)[2]


def test_a_lone_bent_face_goes_onto_its_least_squares_plane():
    """One face, no neighbours: its vertices are projected onto their own
    least-squares plane (a plain-numpy reference), nothing else moves."""
    rng = np.random.default_rng(3)
    v, t = _grid(5, 1e-3, rng)
    y = planar_faces(v, t, np.zeros(len(t), int), np.ones(1, bool), 1e-9, 0.01)
    c = v.mean(axis=0)
    n = np.linalg.svd(v - c)[2][2]
    want = v - np.outer((v - c) @ n, n)
    np.testing.assert_allclose(y, want, atol=1e-12)
    assert _planarity(y, t, np.zeros(len(t), int), 1)[0] <= 1e-9


def test_three_bent_faces_of_a_corner_come_out_planar_and_meet():
    """Three faces of a box corner, each bent by up to 1e-4 (a hundredth of a grid
    step): every face planar within 1e-9, each vertex moved at most a few times the
    bend, the corner vertex on all three planes."""
    v, t, face = _box_corner(4, 1e-4, seed=0)
    assert _planarity(v, t, face, 3).min() > 1e-5
    y = planar_faces(v, t, face, np.ones(3, bool), 1e-9, 0.01)
    assert _planarity(y, t, face, 3).max() <= 1e-9
    assert np.linalg.norm(y - v, axis=1).max() <= 5e-4
    normals, offsets = plane_fits(y, t, face, 3)[:2]
    corner = np.argmin(np.linalg.norm(v, axis=1))
    assert (face[np.flatnonzero((t == corner).any(axis=1))] == np.arange(3)[:, None]).any(1).all()
    np.testing.assert_allclose(normals @ y[corner], offsets, atol=1e-9)


def test_faces_bent_past_the_cap_and_curved_regions_stay_bit_for_bit():
    """A face bent by more than the cap, and a face whose region is not flat, keep
    their vertices exactly."""
    v, t, face = _box_corner(4, 1e-3, seed=1)
    y = planar_faces(v, t, face, np.ones(3, bool), 1e-9, 1e-4)
    assert np.array_equal(y, v)
    y = planar_faces(v, t, face, np.zeros(3, bool), 1e-9, 0.01)
    assert np.array_equal(y, v)


def test_two_parallel_faces_sharing_an_edge_the_smaller_gives_way():
    """A step with no wall: a face on z = 0 and a smaller one on z = 0.001 share an
    edge (their planes parallel, so no vertex lies on both): the larger face comes
    out planar, the smaller keeps its vertices (bent), nothing is flung."""
    rng = np.random.default_rng(5)
    v, t = _grid(5, 1e-4, rng)
    face = np.zeros(len(t), int)
    face[v[t].mean(axis=1)[:, 0] > 3.0] = 1  # the last column of quads
    right = np.unique(t[face == 1])
    v[right[v[right, 0] > 3.5], 2] += 1e-3
    y = planar_faces(v, t, face, np.ones(2, bool), 1e-9, 0.01)
    bend = _planarity(y, t, face, 2)
    assert bend[0] <= 1e-9
    assert np.linalg.norm(y - v, axis=1).max() <= 1e-3
    assert bend[1] > 1e-9


def _folded(angle_deg):
    """A 5 x 5 grid (bent by up to 1e-4, seeded) whose last column of quads (face 1,
    8 triangles) turns up about the line x = 3 by ``angle_deg``; face 0 the rest (24)."""
    rng = np.random.default_rng(7)
    v, t = _grid(5, 1e-4, rng)
    face = (v[t].mean(axis=1)[:, 0] > 3.0).astype(int)
    right = v[:, 0] > 3.5
    v[right, 2] += (v[right, 0] - 3.0) * np.tan(np.radians(angle_deg))
    return v, t, face


def test_faces_meeting_on_near_parallel_planes_come_out_one_planar_face():
    """Two bent faces 1 degree apart (within 2.5: no vertex of their shared edge can
    lie on both planes) become one planar face, labelled as the larger; each alone
    would be made planar only where its edge gives way."""
    v, t, face = _folded(1.0)
    y, merged = merged_planar_faces(v, t, face, np.ones(2, bool), 1e-9, 0.1)
    assert (merged == 0).all()
    assert _planarity(y, t, merged, 2)[0] <= 1e-9
    assert np.linalg.norm(y - v, axis=1).max() <= np.tan(np.radians(1.0))
    apart = planar_faces(v, t, face, np.ones(2, bool), 1e-9, 0.1)
    assert _planarity(apart, t, face, 2).max() > 1e-9


def test_faces_at_an_angle_or_a_merge_left_bent_stay_apart():
    """A box corner's three faces (90 degrees apart) keep their labels and get
    `planar_faces`' vertices bit for bit; so do two faces 1 degree apart whose
    merged face cannot be made planar within the cap (it gives way: apart again)."""
    v, t, face = _box_corner(4, 1e-4, 0)
    y, labels = merged_planar_faces(v, t, face, np.ones(3, bool), 1e-9, 0.01)
    np.testing.assert_array_equal(labels, face)
    np.testing.assert_array_equal(y, planar_faces(v, t, face, np.ones(3, bool), 1e-9, 0.01))
    v, t, face = _folded(1.0)
    y, labels = merged_planar_faces(v, t, face, np.ones(2, bool), 1e-9, 1e-3)
    np.testing.assert_array_equal(labels, face)
    np.testing.assert_array_equal(y, planar_faces(v, t, face, np.ones(2, bool), 1e-9, 1e-3))


def test_no_triangle_is_left_without_area():
    """A triangle of a curved neighbour whose apex lies almost on the line the face's
    planar edge would take: moving the edge would leave it a thousandth of its area
    or less, so the face gives way and keeps its vertices."""
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 2e-4], [0, 0, 0]], dtype=float)
    t = np.array([[0, 1, 2], [0, 2, 3], [2, 4, 3]])
    face = np.array([0, 0, 1])
    flat = np.array([True, False])
    alone = planar_faces(v[:4], t[:2], face[:2], flat[:1], 1e-12, 0.01)
    # the apex just off the planar edge's midpoint, on the side it is on before
    mid, was = 0.5 * (alone[2] + alone[3]), 0.5 * (v[2] + v[3])
    v[4] = mid + 1e-5 * (mid - was)
    y = planar_faces(v, t, face, flat, 1e-12, 0.01)
    assert np.array_equal(y, v)
    c = np.cross(v[t[2, 1]] - v[t[2, 0]], v[t[2, 2]] - v[t[2, 0]])
    assert np.linalg.norm(c) > 0.0


def _least_moves_reference(x, t, face, n_faces):
    """Plain numpy: with every face's normal its fit, the offsets that make the sum of
    the squared moves of the vertices onto all their faces' planes least (one dense
    least-squares problem, a loop over the vertices)."""
    normals, offsets = plane_fits(x, t, face, n_faces)[:2]
    rows, rhs = [], []
    for v in np.unique(t):
        faces = np.unique(face[(t == v).any(axis=1)])
        p = np.linalg.pinv(normals[faces], rcond=0.0437)
        block = np.zeros((3, n_faces))
        block[:, faces] = p
        rows.append(block)
        rhs.append(p @ (normals[faces] @ x[v]))
    d = np.linalg.lstsq(np.vstack(rows), np.concatenate(rhs), rcond=None)[0]
    y = x.copy()
    for v in np.unique(t):
        faces = np.unique(face[(t == v).any(axis=1)])
        p = np.linalg.pinv(normals[faces], rcond=0.0437)
        y[v] = x[v] + p @ (d[faces] - normals[faces] @ x[v])
    return y


def test_the_moves_are_the_least_squares_ones_of_a_plain_reference():
    """The box corner's three bent faces: the vertices where the plain-numpy
    reference's least-squares offsets put them."""
    v, t, face = _box_corner(5, 1e-4, seed=2)
    y = planar_faces(v, t, face, np.ones(3, bool), 1e-9, 0.01)
    np.testing.assert_allclose(y, _least_moves_reference(v, t, face, 3), atol=1e-10)


def test_at_a_vertex_that_fails_only_its_smallest_bent_face_gives_way():
    """`_planar._failed`: a vertex moved past the cap (along z: no triangle turns)
    lies on two bent faces and a planar one; only the bent face of fewest triangles
    gives way (the other is solved again without it), and of two bent faces of one
    size, the lower label."""
    from pointatlas.simplify._place import _cross
    from pointatlas.simplify._planar import _failed

    cap = 0.01
    x = np.array([[0, 0, 0], [0, 1, 0], [1, 1, 0], [1, 0, 0]], dtype=float)
    tri = np.array([[0, 3, 2], [0, 2, 1]])
    y = x.copy()
    y[0, 2] = 2.0 * cap
    # vertex 0 on faces 0, 1, 2; vertex 1 on face 1; every vertex on its planes
    rows = np.array([[0, 0], [0, 1], [0, 2], [1, 1]])
    normals = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    offsets = np.array([2.0 * cap, 0.0, 0.0])
    bent = np.array([True, True, False])
    before = _cross(x, tri)
    args = (rows, normals, offsets, bent)
    failed = _failed(x, y, tri, *args, np.array([2, 5, 3]), before, 1e-9, cap)
    np.testing.assert_array_equal(failed, [True, False, False])
    failed = _failed(x, y, tri, *args, np.array([5, 5, 3]), before, 1e-9, cap)
    np.testing.assert_array_equal(failed, [True, False, False])
    # nothing moved, every vertex on its planes: none
    args = (rows, normals, np.zeros(3), bent)
    assert not _failed(x, x, tri, *args, np.array([2, 5, 3]), before, 1e-9, cap).any()
    # face 1's plane away from both its vertices: at vertex 0 face 0 gives way (the
    # fewest triangles), at vertex 1 face 1 (its only bent face)
    off = (rows, normals, np.array([0.0, 0.5, 0.0]), bent)
    failed = _failed(x, x, tri, *off, np.array([2, 5, 3]), before, 1e-9, cap)
    np.testing.assert_array_equal(failed, [True, True, False])


def _axis_planes():
    """The box corner's true planes as (normals, offsets), in `_box_corner`'s face
    order: z = 0, x = 0, y = 0."""
    normals = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    return normals, np.zeros(3)


def test_given_planes_take_the_bent_faces_with_their_offsets_held():
    """The box corner bent by up to 1e-4, given its true planes (the points' fits):
    each vertex goes onto the nearest point on its faces' planes (plain numpy: the
    coordinates of its faces' axes set to 0), the corner onto the origin; without
    them the faces' own planes leave the vertices off the true ones."""
    v, t, face = _box_corner(4, 1e-4, seed=0)
    normals, offsets = _axis_planes()
    flat = np.ones(3, bool)
    # each face's normal is the axis its grid's third coordinate went to
    fit = plane_fits(v, t, face, 3)[0]
    np.testing.assert_allclose(np.abs(fit), np.abs(normals), atol=1e-3)
    y, labels = merged_planar_faces(v, t, face, flat, 1e-9, 0.01, planes=(normals, offsets))
    np.testing.assert_array_equal(labels, face)
    want = v.copy()
    for k in range(3):
        on = np.unique(t[face == k])
        want[on] -= np.outer(want[on] @ normals[k], normals[k])
    np.testing.assert_allclose(y, want, atol=1e-12)
    corner = np.argmin(np.linalg.norm(v, axis=1))
    np.testing.assert_allclose(y[corner], 0.0, atol=1e-12)
    own, _ = merged_planar_faces(v, t, face, flat, 1e-9, 0.01)
    assert np.abs(own - want).max() > 1e-6


def test_faces_the_given_planes_cannot_take_go_onto_their_own():
    """The given planes 0.05 off the corner's faces, the cap 0.01: no face can move
    onto them (each gives way), so each goes onto its own plane as without them (the
    same vertices bit for bit)."""
    v, t, face = _box_corner(4, 1e-4, seed=0)
    normals, offsets = _axis_planes()
    flat = np.ones(3, bool)
    y, labels = merged_planar_faces(v, t, face, flat, 1e-9, 0.01, planes=(normals, offsets + 0.05))
    own, own_labels = merged_planar_faces(v, t, face, flat, 1e-9, 0.01)
    np.testing.assert_array_equal(y, own)
    np.testing.assert_array_equal(labels, own_labels)
    assert _planarity(y, t, face, 3).max() <= 1e-9


def _neighbours_reference(t):
    """`edge_neighbours` in plain Python: edge j of triangle i runs from corner j to
    corner j + 1; the triangle across it where exactly two share it, else -1."""
    sides = {}
    for i, f in enumerate(t.tolist()):
        for j in range(3):
            sides.setdefault(frozenset((f[j], f[(j + 1) % 3])), []).append((i, j))
    out = np.full(t.shape, -1)
    for pair in sides.values():
        if len(pair) == 2:
            (a, ja), (b, jb) = pair
            out[a, ja], out[b, jb] = b, a
    return out


def test_edge_neighbours_agree_with_a_plain_reference():
    """The box corner's triangles with a fin on one of its edges (three triangles
    there: no neighbour across it) and its open border."""
    v, t, _ = _box_corner(4, 0.0, seed=0)
    fin = np.array([[t[5, 0], t[5, 1], len(v)]])
    t = np.vstack([t, fin])
    got = edge_neighbours(t)
    np.testing.assert_array_equal(got, _neighbours_reference(t))
    assert (got == -1).sum() > 3


def _mislabelled_corner():
    """The box corner (5 x 5 grids, exact) with the triangles of face 0 (z = 0) at
    its edge with face 1 (x = 0) labelled as face 1."""
    v, t, face = _box_corner(5, 0.0, seed=0)
    wrong = np.flatnonzero((face == 0) & (v[t][:, :, 0].min(axis=1) == 0.0))
    labels = face.copy()
    labels[wrong] = 1
    return v, t, face, labels, wrong


def test_triangles_off_their_planes_go_back_to_the_face_that_holds_them():
    """Each mislabelled triangle has a corner 1 from the plane x = 0 and lies on
    z = 0: given back to face 0; no other triangle changes. Left as they were, face 1
    cannot be made planar within the cap (it stays bent); given back, every face
    comes out exactly on its plane."""
    v, t, face, labels, wrong = _mislabelled_corner()
    assert wrong.size == 8  # the two triangles of each of 4 quads
    normals, offsets = _axis_planes()
    flat = np.ones(3, bool)
    got = off_plane_relabelled(v, t, labels, flat, (normals, offsets), 0.1)
    np.testing.assert_array_equal(got, face)
    bent, _ = merged_planar_faces(v, t, labels, flat, 1e-9, 0.1, planes=(normals, offsets))
    assert _planarity(bent, t, labels, 3)[1] > 0.1
    y, merged = merged_planar_faces(v, t, got, flat, 1e-9, 0.1, planes=(normals, offsets))
    assert _planarity(y, t, merged, 3).max() <= 1e-12


def test_a_triangle_no_flat_neighbour_holds_goes_to_a_curved_one():
    """Face 0 not flat: its mislabelled triangles go back to it (curved) though the
    plane x = 0 of their flat neighbours is 1 away; with no neighbour but their own
    flat face (a lone triangle labelled alone), a triangle keeps its face, and a
    triangle on its face's plane is never moved."""
    v, t, face, labels, wrong = _mislabelled_corner()
    planes = _axis_planes()
    got = off_plane_relabelled(v, t, labels, np.array([False, True, True]), planes, 0.1)
    np.testing.assert_array_equal(got, face)
    lone = t[wrong[:1]]
    kept = off_plane_relabelled(v, lone, np.array([1]), np.ones(3, bool), planes, 0.1)
    np.testing.assert_array_equal(kept, [1])
    same = off_plane_relabelled(v, t, face, np.ones(3, bool), planes, 0.1)
    np.testing.assert_array_equal(same, face)


def test_the_triangles_that_keep_a_face_bent_are_set_apart_and_the_rest_is_planar():
    """The box corner's face 1 (x = 0) holding face 0's triangles at their edge (a
    corner 1 off x = 0, the cap 0.1): exactly those triangles go to face 1's
    companion (label 3 + 1), nothing moves (every face is then on its plane), and
    the faces planar before keep their labels."""
    v, t, face, labels, wrong = _mislabelled_corner()
    flat = np.ones(3, bool)
    y, got = bent_apart(v, t, labels, flat, _axis_planes(), 1e-9, 0.1)
    np.testing.assert_array_equal(got, np.where(np.isin(np.arange(len(t)), wrong), 4, labels))
    assert np.array_equal(y, v)
    assert _planarity(y, t, got, 6)[:3].max() <= 1e-12


def test_set_apart_only_at_the_far_vertex_the_rest_goes_onto_its_plane():
    """The box corner bent by up to 1e-4 with one vertex inside face 0 (z = 0) lifted
    by 1: only face 0's triangles at that vertex are set apart (its companion, 3);
    every face then lies on its own plane within 1e-9, no vertex but the lifted one's
    neighbours' moved more than a few times the bend, and the lifted one stays."""
    v, t, face = _box_corner(4, 1e-4, seed=0)
    inner = [i for i in np.unique(t[face == 0]) if (face[(t == i).any(axis=1)] == 0).all()]
    v[inner[0], 2] += 1.0
    y, got = bent_apart(v, t, face, np.ones(3, bool), _axis_planes(), 1e-9, 0.01)
    at = (t == inner[0]).any(axis=1)
    np.testing.assert_array_equal(got, np.where(at, 3, face))
    assert _planarity(y, t, got, 6)[:3].max() <= 1e-9
    assert np.linalg.norm(y - v, axis=1).max() <= 5e-4
    assert np.array_equal(y[inner[0]], v[inner[0]])


def test_with_no_face_left_bent_it_is_the_planar_step_bit_for_bit():
    """The box corner bent by up to 1e-4, every face within the cap: the faces'
    labels stay and the vertices are `merged_planar_faces`' on their own planes."""
    v, t, face = _box_corner(4, 1e-4, seed=2)
    flat = np.ones(3, bool)
    y, got = bent_apart(v, t, face, flat, _axis_planes(), 1e-9, 0.01)
    want, labels = merged_planar_faces(v, t, face, flat, 1e-9, 0.01)
    np.testing.assert_array_equal(got, labels)
    np.testing.assert_array_equal(y, want)
