"""The points path's planes and placement: each region's plane refitted and split
into its parallel layers (`_surface_regions.region_layers`), and the triangles that
placing the vertices on their planes turns over merged away (`_untangle.untangle`),
so that a sampled CAD part's faces come out as its exact planar polygons."""

from __future__ import annotations

import numpy as np
import pytest

from pointatlas.simplify import mesh_checks, simplify_points
from pointatlas.simplify._surface_regions import region_layers
from pointatlas.simplify._untangle import untangle
from pointatlas.synth import sample_mesh

from .cad_shapes import box, l_bracket
from .reference import untangle_reference


def test_a_recess_floor_becomes_its_own_layer_and_a_tilted_normal_is_refitted():
    """A face (z = 0) with a recess floor 0.3 below it (36 of its 436 points), and
    the walls' points (normals across), in one region whose proxy normal is tilted
    by 0.5 degrees: the floor becomes a region of its own, both with the face's
    true normal; the walls' points stay in the face's region."""
    g = np.arange(20.0)
    face = np.array([[x, y, 0.0] for x in g for y in g])
    floor = np.array([[x, y, -0.3] for x in 7 + np.arange(6.0) for y in 7 + np.arange(6.0)])
    wall = np.array([[6.5, y, -0.15] for y in 7 + np.arange(6.0)])
    q = np.vstack([face, floor, wall])
    normals = np.vstack([np.tile([0.0, 0, 1], (436, 1)), np.tile([-1.0, 0, 0], (6, 1))])
    tilt = np.radians(0.5)
    proxy = np.array([[np.sin(tilt), 0.0, np.cos(tilt)]])
    labels, pn = region_layers(q, normals, np.zeros(q.shape[0], np.int64), proxy, 0.05)
    assert labels[:400].tolist() == [0] * 400
    assert labels[400:436].tolist() == [1] * 36
    assert labels[436:].tolist() == [0] * 6
    assert np.abs(pn - [0.0, 0.0, 1.0]).max() <= 1e-12


def test_a_layer_too_small_or_a_curved_region_stays_whole():
    """Ten points a step below a face of 400 (under `MIN_LAYER`), and a region of 400
    points on a band of a cylinder (their heights spread without a gap wider than a
    thousandth of the radius): nothing is split."""
    g = np.arange(20.0)
    face = np.array([[x, y, 0.0] for x in g for y in g])
    q = np.vstack([face, [[x, 0.0, -1.0] for x in range(10)]])
    normals = np.tile([0.0, 0, 1], (410, 1))
    labels, _ = region_layers(q, normals, np.zeros(410, np.int64), np.array([[0.0, 0, 1]]), 0.5)
    assert (labels == 0).all()
    rng = np.random.default_rng(0)  # a band of a cylinder, normals within 10 degrees
    u, y = rng.uniform(-0.15, 0.15, 400), rng.uniform(0.0, 10.0, 400)
    cyl = np.column_stack([np.sin(u), y, np.cos(u)])
    nc = cyl * [1.0, 0.0, 1.0]
    labels, _ = region_layers(cyl, nc, np.zeros(400, np.int64), np.array([[0.0, 0, 1]]), 0.001)
    assert (labels == 0).all()


def test_untangle_keeps_the_outline_and_the_orientation():
    """Two vertices inside a triangle placed onto its edge: every triangle they leave
    without area goes, the vertex on the open outline is never merged away, and what
    is left covers the triangle with its orientation."""
    v = np.array([[0, 0, 0], [0, 2, 0], [2, 1, 0], [0.1, 1, 0], [0.3, 1.5, 0.0]])
    t = np.array([[0, 2, 3], [3, 2, 4], [4, 2, 1], [0, 3, 1], [3, 4, 1]])
    x = v.copy()
    x[3, 0] = x[4, 0] = 0.0
    lineage = np.arange(5)
    v0, placed, tri, face, source, kept, went, before = untangle(
        v, x, t, np.array([0, 0, 0, 1, 1]), np.ones(2, bool), lineage, lineage, lineage
    )
    assert tri.tolist() == [[0, 2, 1]] and source.tolist() == [0, 1, 2]
    assert placed.tolist() == [[0, 0, 0], [0, 2, 0], [2, 1, 0]]
    assert went.tolist()[:3] == [0, 1, 2] and set(went.tolist()[3:]) <= {0, 1, 2}
    assert (before == [[0.0, 0.0, 1.0]]).all()  # triangle 0 2 3's, as it was
    # nothing turned over: the same triangles back
    same = untangle(v, v, t, np.zeros(5, np.int64), np.ones(1, bool), lineage, lineage, lineage)
    assert same[2] is t or np.array_equal(same[2], t)


def test_the_kernels_merge_as_the_plain_python_passes_on_every_level(monkeypatch):
    """Every level the points path places on a sampled L-bracket (8,000 points), level
    0 with its hundreds of caps among them: `untangle`'s numba passes give the same
    triangles, vertices, faces, lineage and sides, bit for bit, as the plain Python
    passes (tests/simplify/reference.py); and some levels merge or flip."""
    import pointatlas.simplify._snap as snap

    seen = {"levels": 0, "mended": 0}

    def both(*args):
        got = untangle(*[a.copy() if isinstance(a, np.ndarray) else a for a in args])
        want = untangle_reference(*[a.copy() if isinstance(a, np.ndarray) else a for a in args])
        for g, w in zip(got, want, strict=True):
            assert g.dtype == w.dtype and np.array_equal(g, w)
        seen["levels"] += 1
        seen["mended"] += int(got[2].shape[0] != args[2].shape[0])
        return got

    monkeypatch.setattr(snap, "untangle", both)
    v, t = l_bracket()
    s = sample_mesh(v, t, 8000, rng=0)
    simplify_points(np.asarray(s.points), s.normals)
    assert seen["levels"] >= 5 and seen["mended"] >= 1


def test_a_chamfer_joined_to_a_face_becomes_its_own_region():
    """A face (z = 0, 400 points) whose region also holds a chamfer's 30 points (normal
    45 degrees off) and 5 stray points (normal across): the chamfer becomes a region
    with its own normal, the strays (under `MIN_LAYER`) stay."""
    g = np.arange(20.0)
    face = np.array([[x, y, 0.0] for x in g for y in g])
    chamfer = np.array([[20.0 + t, y, -t] for t in (0.2, 0.5, 0.8) for y in range(10)])
    stray = np.array([[-0.5, y, -0.5] for y in range(5)])
    q = np.vstack([face, chamfer, stray])
    s = np.sqrt(0.5)
    normals = np.vstack(
        [np.tile([0.0, 0, 1], (400, 1)), np.tile([s, 0, s], (30, 1)), np.tile([-1.0, 0, 0], (5, 1))]
    )
    labels, pn = region_layers(q, normals, np.zeros(435, np.int64), np.array([[0.0, 0, 1]]), 0.05)
    assert labels[:400].tolist() == [0] * 400 and labels[430:].tolist() == [0] * 5
    assert labels[400:430].tolist() == [1] * 30
    assert np.abs(pn[1] - [s, 0.0, s]).max() <= 1e-12


def test_a_level_may_leave_a_few_points_a_hair_over_the_default_bound():
    """`_point_distances._over`: up to ``spare`` distances over their floor by at most
    `SPARE_FACTOR` are counted; one farther, or more of them, fail (inf)."""
    from pointatlas.simplify._point_distances import SPARE, SPARE_FACTOR, _over

    floor = np.ones(10)
    d = np.full(10, 0.5)
    assert _over(d, floor, SPARE) == 0
    d[:SPARE] = 1.0 + 0.5 * (SPARE_FACTOR - 1.0)
    assert _over(d, floor, SPARE) == SPARE and _over(d, 1.0, SPARE) == SPARE
    assert _over(d, floor, 0) == np.inf  # no spare: over is over
    d[SPARE] = d[0]
    assert _over(d, floor, SPARE) == np.inf  # one too many
    d[: SPARE + 1] = 0.5
    d[0] = SPARE_FACTOR * 1.01
    assert _over(d, floor, SPARE) == np.inf  # one too far


@pytest.mark.parametrize(("shape", "n_faces"), [(box, 6), (l_bracket, 8)], ids=["box", "l-bracket"])
def test_a_sampled_cad_part_comes_out_as_its_exact_planar_faces(shape, n_faces):
    """20,000 points with normals on a box / an L-bracket: exactly its 6 / 8 faces as
    as many planar polygons (planarity under 1e-12 of the diagonal), every true corner
    on an output vertex (measured: exact to 1e-16), closed, manifold, oriented.
    Before the untangling the placement put back a row of vertices along an edge, up
    to 0.3 % of the diagonal off its planes (the L-bracket's faces split into 130
    polygons), and left the caps along an edge across two faces, which are now
    flipped into the face beside them (the box: 42 polygons, a corner 0.13 % off)."""
    v, t = shape()
    s = sample_mesh(v, t, 20000, rng=0)
    p = np.asarray(s.points)
    m = simplify_points(p, s.normals).mesh
    diag = float(np.linalg.norm(np.ptp(p, axis=0)))
    assert mesh_checks(m.n_vertices, m.triangles) == (True, True, True)
    assert m.n_faces == n_faces and len(m.polygons) == n_faces
    assert float(np.max(m.polygon_planarity)) <= 1e-12 * diag
    gap = np.linalg.norm(v[:, None, :] - m.vertices[None, :, :], axis=2).min(axis=1)
    assert gap.max() <= 1e-12 * diag


def test_a_narrow_region_is_a_plane_when_its_normals_agree():
    """`region_planes`' ``steady``: a narrow chamfer whose points' normals all agree is
    a plane; a band of the same shape whose normals turn through 90 degrees (PCA
    normals over an edge) is not, nor is any region without the points' normals."""
    from pointatlas.simplify._surface_regions import region_planes

    s = np.sqrt(0.5)
    q = np.array([[t, y, -t] for t in (0.0, 0.1, 0.2) for y in range(20)])
    agree = np.tile([s, 0.0, s], (60, 1))
    angle = np.repeat(np.linspace(0.0, np.pi / 2, 3), 20)
    turn = np.column_stack([np.sin(angle), np.zeros(60), np.cos(angle)])
    labels, source, proxy = np.zeros(60, np.int64), np.array([0]), np.array([[s, 0.0, s]])
    assert region_planes(q, labels, proxy, source, agree)[4].tolist() == [True]
    assert region_planes(q, labels, proxy, source, turn)[4].tolist() == [False]
    assert region_planes(q, labels, proxy, source)[4].tolist() == [False]
