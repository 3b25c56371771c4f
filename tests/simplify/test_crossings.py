"""Self-intersections: triangles of a mesh that pass through each other."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from pointatlas._core.tolerances import CROSSING_FLAT_RTOL, CROSSING_RTOL
from pointatlas.simplify import mesh_checks, self_intersections
from tests.jit_off import JIT_OFF, run_module_without_jit
from tests.simplify.collection_runs import COLLECTION, without_and_with
from tests.simplify.reference_crossings import self_intersections_reference


def _pairs(rows):
    return np.array(rows, dtype=np.int64).reshape(-1, 2)


def _tol(v):
    """The kernel's two tolerances for vertices ``v``: crossing, and one plane."""
    v = np.asarray(v, float)
    diag = np.linalg.norm(v.max(axis=0) - v.min(axis=0))
    return CROSSING_RTOL * diag, CROSSING_FLAT_RTOL * diag


def test_a_closed_sphere_does_not_cross_itself():
    s = trimesh.creation.icosphere(subdivisions=3)
    assert self_intersections(s.vertices, s.faces).shape == (0, 2)


def test_a_vertex_pushed_through_the_far_side_crosses_it():
    s = trimesh.creation.icosphere(subdivisions=2)
    v = np.array(s.vertices)
    top = int(np.argmax(v[:, 2]))
    v[top] = [0.0, 0.0, -1.3]  # through the bottom of the unit sphere
    pairs = self_intersections(v, s.faces)
    assert len(pairs) > 0
    moved = np.isin(s.faces, top).any(axis=1)
    # every crossing pair holds one of the moved vertex's triangles
    assert moved[pairs].any(axis=1).all()
    np.testing.assert_array_equal(pairs, self_intersections_reference(v, s.faces, *_tol(v)))


@pytest.mark.parametrize(
    ("vertices", "triangles", "expected"),
    [
        # a triangle through another, no corner shared
        (
            [[0, 0, 0], [2, 0, 0], [0, 2, 0], [0.5, 0.5, -1], [0.5, 0.5, 1], [2, 2, 0]],
            [[0, 1, 2], [3, 4, 5]],
            [[0, 1]],
        ),
        # the same, touching the other's edge only: not a crossing
        (
            [[0, 0, 0], [2, 0, 0], [0, 2, 0], [1, 1, -1], [1, 1, 1], [2, 2, 0]],
            [[0, 1, 2], [3, 4, 5]],
            [],
        ),
        # two triangles of one fan, one folded through the other (Open3D skips these)
        (
            [[0, 0, 0], [2, 0, 0], [0, 2, 0], [1, 0.5, -1], [1, 0.5, 1]],
            [[0, 1, 2], [0, 3, 4]],
            [[0, 1]],
        ),
        # the same fan, the second triangle only meeting the first at their corner
        (
            [[0, 0, 0], [2, 0, 0], [0, 2, 0], [-1, -0.5, -1], [-1, -0.5, 1]],
            [[0, 1, 2], [0, 3, 4]],
            [],
        ),
        # two triangles on one edge are never a crossing, even folded flat
        ([[0, 0, 0], [2, 0, 0], [0, 2, 0], [0.5, 0.5, 0]], [[0, 1, 2], [0, 1, 3]], []),
        # a copy of a triangle with its own vertices lies on it
        (
            [[0, 0, 0], [2, 0, 0], [0, 2, 0], [0, 0, 0], [2, 0, 0], [0, 2, 0]],
            [[0, 1, 2], [3, 4, 5]],
            [[0, 1]],
        ),
        # two triangles side by side in one plane, an edge touching
        (
            [[0, 0, 0], [2, 0, 0], [0, 2, 0], [2, 2, 0], [2, 0, 0], [0, 2, 0]],
            [[0, 1, 2], [3, 5, 4]],
            [],
        ),
        # overlapping in one plane
        (
            [[0, 0, 0], [2, 0, 0], [0, 2, 0], [1, 1, 0], [-1, 1, 0], [1, -1, 0]],
            [[0, 1, 2], [3, 4, 5]],
            [[0, 1]],
        ),
        # a triangle without area crosses nothing
        (
            [[0, 0, 0], [2, 0, 0], [0, 2, 0], [0.5, 0.5, -1], [0.5, 0.5, 1], [0.5, 0.5, 0]],
            [[0, 1, 2], [3, 4, 5]],
            [],
        ),
    ],
)
def test_known_pairs_match_reference(vertices, triangles, expected):
    got = self_intersections(vertices, triangles)
    np.testing.assert_array_equal(got, _pairs(expected))
    ref = self_intersections_reference(vertices, np.array(triangles), *_tol(vertices))
    np.testing.assert_array_equal(got, ref)


@pytest.mark.parametrize("seed", range(6))
def test_random_triangles_match_reference(seed):
    rng = np.random.default_rng(seed)
    v = rng.random((60, 3))
    # shared corners as well as separate ones: 40 triangles on 60 vertices
    tri = np.array([rng.choice(60, 3, replace=False) for _ in range(40)])
    got = self_intersections(v, tri)
    np.testing.assert_array_equal(got, self_intersections_reference(v, tri, *_tol(v)))
    assert len(got) > 0


@pytest.mark.parametrize("seed", range(3))
def test_flat_fans_in_a_tilted_plane_match_reference(seed):
    """Triangles of one flat face, its vertices a hair off the plane (a planar face
    of a simplified mesh): a fan crosses nothing; folding a triangle over does."""
    rng = np.random.default_rng(seed)
    angle = np.linspace(0, 2 * np.pi, 13)[:-1]
    rim = np.column_stack([np.cos(angle), np.sin(angle), 1e-9 * rng.standard_normal(12)])
    v = np.vstack([[0.0, 0.0, 0.0], rim])
    tri = np.array([[0, 1 + i, 1 + (i + 1) % 12] for i in range(12)])
    turn = np.linalg.qr(rng.standard_normal((3, 3)))[0]
    x = v @ turn.T + 5.0
    assert self_intersections(x, tri).shape == (0, 2)
    folded = x.copy()
    # rim vertex 3 dragged across the centre, between rim vertices 8 and 9
    folded[3] = x[0] + 0.7 * (x[8] + x[9] - 2 * x[0])
    got = self_intersections(folded, tri)
    assert len(got) > 0
    np.testing.assert_array_equal(got, self_intersections_reference(folded, tri, *_tol(folded)))


def _coplanar_pair(rng, shared: bool):
    """Two triangles in the plane z = 0 (3 x 2 corners each) and the corners they
    share (-1, -1 if none): near each other, often with a side of one along a side
    of the other or a hair off it (the early tests' edge cases)."""
    o = rng.normal(size=2)
    rays = rng.normal(size=(4, 2))
    if shared:
        # a side of q along a side of p (or turned a hair, or reversed) half the time
        if rng.random() < 0.5:
            hair = rng.choice([0.0, 1e-13, -1e-13, 1e-9, -1e-9, 1e-6])
            c, s_ = np.cos(hair), np.sin(hair)
            side = rays[rng.integers(2)]
            rays[2] = (
                rng.choice([1.0, -1.0])
                * rng.uniform(0.2, 2.0)
                * (np.array([[c, -s_], [s_, c]]) @ side)
            )
        p2 = np.vstack([o, o + rays[0], o + rays[1]])
        q2 = np.vstack([o, o + rays[2], o + rays[3]])
        ip, iq = rng.integers(3), rng.integers(3)
        p2, q2 = np.roll(p2, ip, axis=0), np.roll(q2, iq, axis=0)
        return p2, q2, int(ip), int(iq)
    p2 = o + rng.normal(size=(3, 2))
    q2 = o + rng.uniform(-2.0, 2.0, 2) + rng.normal(size=(3, 2))
    if rng.random() < 0.3:  # q's corner on the line of p's side (touching)
        t = rng.uniform(-0.5, 1.5)
        q2[0] = p2[0] + t * (p2[1] - p2[0])
    return p2, q2, -1, -1


@pytest.mark.parametrize("seed", range(3))
def test_coplanar_pairs_set_apart_early_match_reference_full_test(seed):
    """Two triangles in one plane whose angles at their shared corner are apart, or
    that a side's line of one sets apart from the other, are passed without the
    full test (edges crossing, a corner or centroid inside): the same answer on
    every pair, in a tilted plane far from the origin, both ways seen."""
    from pointatlas.simplify import _crossing_kernels as k

    rng = np.random.default_rng(seed)
    turn = np.linalg.qr(rng.standard_normal((3, 3)))[0]
    n = turn[:, 2].copy()
    drop = int(np.argmax(np.abs(n)))
    x, y = (drop + 1) % 3, (drop + 2) % 3
    tol = 1e-10
    seen = {"apart": 0, "crossing": 0, "full test, apart": 0}
    for trial in range(600):
        p2, q2, ip, iq = _coplanar_pair(rng, shared=trial % 3 != 0)
        p = np.c_[p2, np.zeros(3)] @ turn.T + 50.0
        q = np.c_[q2, np.zeros(3)] @ turn.T + 50.0
        if ip >= 0:
            q[iq] = p[ip]  # one corner, the same bits
        full = (
            k._edges_cross(p, q, x, y, tol)
            or k._inside(p, q, x, y, tol)
            or k._inside(q, p, x, y, tol)
        )
        assert k._coplanar_cross(p, q, n, tol, ip, iq) == full
        if ip >= 0:
            apart = k._angles_apart(p, q, ip, iq, x, y)
        else:
            apart = k._edge_apart(p, q, x, y) or k._edge_apart(q, p, x, y)
        assert not (apart and full)
        seen["apart" if apart else "crossing" if full else "full test, apart"] += 1
    assert min(seen.values()) > 20, seen


def test_far_from_the_origin_gives_the_same_pairs():
    rng = np.random.default_rng(7)
    v = rng.random((30, 3))
    tri = np.array([rng.choice(30, 3, replace=False) for _ in range(20)])
    np.testing.assert_array_equal(self_intersections(v + 1e6, tri), self_intersections(v, tri))


def test_crossings_found_are_crossings_for_open3d():
    """Open3D skips triangles with a common corner and counts triangles that only
    touch; on triangles without common corners, every crossing found here is one of
    its pairs."""
    o3d = pytest.importorskip("open3d")
    rng = np.random.default_rng(3)
    v = rng.random((90, 3))
    tri = np.arange(90).reshape(30, 3)
    got = self_intersections(v, tri)
    m = o3d.geometry.TriangleMesh(
        o3d.utility.Vector3dVector(v), o3d.utility.Vector3iVector(tri.astype(np.int32))
    )
    theirs = {tuple(sorted(p)) for p in np.asarray(m.get_self_intersecting_triangles())}
    assert len(got) > 0
    assert {tuple(p) for p in got} <= theirs


@pytest.mark.parametrize(
    ("vertices", "triangles", "message"),
    [
        ([[0, 0, 0], [1, 0, 0], [0, 1, np.nan]], [[0, 1, 2]], "vertices"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 3]], "triangles must index"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1]], "triangles must have shape"),
    ],
)
def test_bad_input_is_refused(vertices, triangles, message):
    with pytest.raises(ValueError, match=message):
        self_intersections(vertices, triangles)


@pytest.mark.skipif(JIT_OFF, reason="already running with the JIT off")
def test_kernels_without_jit():
    run_module_without_jit(__file__, select="match_reference")


def test_a_report_counts_the_crossings_of_its_triangles():
    from pointatlas.data import load_mesh
    from pointatlas.simplify import simplify_mesh

    m = load_mesh("fandisk")
    res = simplify_mesh(m.vertices, m.triangles, max_triangles=60)
    v, t = np.asarray(res.vertices), np.asarray(res.triangles)
    ref = self_intersections_reference(v, t, *_tol(v))
    np.testing.assert_array_equal(res.self_intersections, ref)
    assert res.summary()["n_self_intersections"] == len(ref)


def test_uncrossed_puts_back_the_moves_that_cross_and_keeps_the_rest():
    from pointatlas.simplify._crossings import uncrossed

    s = trimesh.creation.icosphere(subdivisions=2)
    v = np.array(s.vertices)
    tri = np.asarray(s.faces, dtype=np.int64)
    top, side = int(np.argmax(v[:, 2])), int(np.argmax(v[:, 0]))
    moved = v.copy()
    moved[top] = [0.0, 0.0, -1.3]  # through the far side
    moved[side] *= 1.05  # outwards: crosses nothing
    assert len(self_intersections(moved, tri)) > 0
    y = uncrossed(v, moved, tri)
    assert self_intersections(y, tri).shape == (0, 2)
    np.testing.assert_array_equal(y[top], v[top])
    np.testing.assert_array_equal(np.delete(y, top, axis=0), np.delete(moved, top, axis=0))
    # what crossed before the step is not the step's: left as it is
    np.testing.assert_array_equal(uncrossed(moved, moved * 1.01, tri), moved * 1.01)
    # no move: the same array back
    assert uncrossed(v, v, tri) is v


DIN_MOUNT = COLLECTION / "voron0_vhb_din_mount.stl"


@pytest.mark.skipif(not DIN_MOUNT.exists(), reason="the collection is not under ../shared")
def test_the_faces_set_apart_do_not_pass_through_each_other(monkeypatch):
    """A sampled CAD part of the collection (a DIN rail mount): the moves of its
    vertices onto the points' planes (`_planar.bent_apart`'s and the output level's)
    make triangle pairs cross (68 with OpenBLAS' AVX2 kernels, which `make test`
    pins); with the moves that did it put back (`_crossings.uncrossed`), 37. The
    steps that put crossing moves back never add a pair, keep about the same
    triangles, and the report counts what is left."""
    from pointatlas.simplify import _snap

    plain, m = without_and_with(
        monkeypatch, _snap, "uncrossed", lambda before, after, tri, **_: after, DIN_MOUNT
    )
    before = len(self_intersections(plain.vertices, plain.triangles))
    assert before >= 5 and plain.summary()["n_self_intersections"] == before
    x, tri = np.asarray(m.vertices), np.asarray(m.triangles)
    after = self_intersections_reference(x, tri, *_tol(x)).shape[0]
    assert m.summary()["n_self_intersections"] == after <= before
    assert abs(len(m.triangles) - len(plain.triangles)) <= 0.02 * len(plain.triangles)
    assert all(mesh_checks(m.n_vertices, tri))


def test_uncrossed_leaves_one_face_s_folds_when_given_the_faces():
    """`uncrossed(..., face=)`: a move that makes two triangles of one face cross is
    left (`_unfold` triangulates such a face again); of two faces, put back."""
    from pointatlas.simplify._crossings import uncrossed

    s = trimesh.creation.icosphere(subdivisions=2)
    v = np.array(s.vertices)
    tri = np.asarray(s.faces, dtype=np.int64)
    top = int(np.argmax(v[:, 2]))
    moved = v.copy()
    moved[top] = [0.0, 0.0, -1.3]  # through the far side
    pairs = self_intersections(moved, tri)
    one = np.zeros(tri.shape[0], dtype=np.int64)
    np.testing.assert_array_equal(uncrossed(v, moved, tri, face=one), moved)
    apart = np.arange(tri.shape[0])
    np.testing.assert_array_equal(uncrossed(v, moved, tri, face=apart)[top], v[top])
    assert pairs.shape[0] > 0


ADXL = COLLECTION / "voron0_minisb_adxl_mount_generic_15_5mm.stl"


@pytest.mark.skipif(not ADXL.exists(), reason="the collection is not under ../shared")
def test_the_placements_crossing_moves_are_put_back_on_the_output_level(monkeypatch):
    """A sampled CAD part of the collection (`voron0_minisb_adxl_mount_generic_15_5mm`):
    its output level placed onto the points' planes makes triangle pairs cross (18
    with OpenBLAS' AVX2 kernels); placed again with those moves put back
    (`_placed_uncrossed`), fewer cross (4), about the same triangles, closed, and
    within 1.1 % of the diagonal both ways as reported."""
    from pointatlas.simplify import _snap

    plain, m = without_and_with(
        monkeypatch,
        _snap.PointsDecimation,
        "_placed_uncrossed",
        lambda self, level, distances: distances,
        ADXL,
    )
    before = len(self_intersections(plain.vertices, plain.triangles))
    after = len(self_intersections(m.vertices, m.triangles))
    assert before >= 4 and after < before
    assert m.summary()["n_self_intersections"] == after
    assert abs(len(m.triangles) - len(plain.triangles)) <= 0.02 * len(plain.triangles)
    assert all(mesh_checks(m.n_vertices, np.asarray(m.triangles)))
    diag = float(np.linalg.norm(np.ptp(np.asarray(m.vertices), axis=0)))
    assert max(m.distance_max, m.back_distance_max) <= 0.011 * diag
