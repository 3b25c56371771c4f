"""Parts scanned without their bottom (points only where the surface does not face
down, as a part standing on a table is seen): an open, compact, planar mesh that
ends where the points end (`_open.beyond_points`), and normals that are right left
as they are (`_sides.added_conflicts`)."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree

from pointatlas.neighbors import point_mesh_distance
from pointatlas.simplify import mesh_checks, simplify_points
from pointatlas.simplify._distance import PointSurface
from pointatlas.simplify._open import OUTLINE_CUT_STEPS, beyond_points
from pointatlas.synth import sample_mesh

from .cad_shapes import box, circle, extrude, l_bracket

COLLECTION = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "collection"


def _without_bottom(v, t, n):
    """``n`` points and true normals of the mesh where it does not face down."""
    s = sample_mesh(v, t, 2 * n, rng=0)
    p, nrm = np.asarray(s.points), np.asarray(s.normals)
    seen = np.flatnonzero(nrm[:, 2] > -0.2)[:n]
    return p[seen], nrm[seen]


def _simplified(p, n):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return simplify_points(p, n)


def _off_truth(m, v, t, p):
    """The output's vertices and samples to the truth, and the truth's samples where
    it is seen (not facing down) to the output: the larger, % of the points' diagonal."""
    mv, mt = np.asarray(m.vertices), np.asarray(m.triangles)
    ours = np.vstack([mv, sample_mesh(mv, mt, 20000, rng=1).points])
    truth = sample_mesh(v, t, 20000, rng=1)
    seen = np.asarray(truth.points)[np.asarray(truth.normals)[:, 2] > -0.2]
    d = max(point_mesh_distance(ours, v, t).max(), point_mesh_distance(seen, mv, mt).max())
    return 100.0 * d / float(np.linalg.norm(np.ptp(p, axis=0)))


def _tube():
    return extrude(circle((0, 0), 1.0, 64), holes=[circle((0, 0), 0.6, 48)], height=1.5)


@pytest.mark.parametrize(
    ("shape", "faces", "euler", "most", "off"),
    [(box, 5, 1, 150, 1.0), (l_bracket, 7, 1, 150, 1.0), (_tube, None, 0, 1000, 1.3)],
    ids=["box", "l-bracket", "tube"],
)
def test_a_part_scanned_without_its_bottom_ends_where_its_points_end(
    shape, faces, euler, most, off
):
    """Before the outline cut the surface ran on up to 4.5 grid steps past the points
    and its staircase edge was kept: the box 260 triangles 1.39 % off the truth, the
    L-bracket 126 faces in pieces (Euler characteristic 119) 3.6 % off, the tube
    9,977 triangles (23) 2.8 % off (its 6,000 points leave the truth's rim a
    spacing, about 1.2 %, from the last of them)."""
    v, t = shape()
    p, n = _without_bottom(v, t, 6000)
    r = _simplified(p, n)
    m = r.mesh
    assert "the mesh is open, cut where they end" in r.reason  # and said so
    assert mesh_checks(m.n_vertices, m.triangles) == (False, True, True)
    assert m.euler_characteristic == euler  # one open piece (a disc; the tube a ring)
    if faces is not None:
        assert m.n_faces == faces
    assert m.triangles.shape[0] <= most
    assert _off_truth(m, v, t, p) <= off


def test_the_cut_is_past_the_outline_only():
    """`beyond_points` on a sampled unit sheet: a position past its edge by more than
    `OUTLINE_CUT_STEPS` steps is beyond, one over a sampling gap inside it is not."""
    rng = np.random.default_rng(0)
    q = np.column_stack([rng.random(3000), rng.random(3000), np.zeros(3000)])
    q = q[np.hypot(q[:, 0] - 0.5, q[:, 1] - 0.5) > 0.04]  # a gap in the middle
    normals = np.tile([0.0, 0.0, 1.0], (q.shape[0], 1))
    step = 0.03
    x = np.array([[0.5, 0.5, 0.0], [1.0 + 1.5 * OUTLINE_CUT_STEPS * step, 0.5, 0.0]])
    tree = cKDTree(q)
    d = tree.query(x)[0]
    far = beyond_points(PointSurface(q, normals, tree), x, d, np.ones(2), step)
    assert far.tolist() == [False, True]


@pytest.mark.skipif(not COLLECTION.exists(), reason="the collection is not under ../shared")
def test_a_pipe_joint_scanned_without_its_bottom_keeps_its_given_normals():
    """The grid's outside reaches a bottomless scan's inside through the missing side,
    so the outside vote turns rightly oriented normals (2,985 of the pipe joint's),
    which made the sample read closed and left no surface ("every piece ... faces
    away"): a turn that cuts a rightly oriented surface is not made."""
    from pointatlas.io import read_mesh

    mesh = read_mesh(COLLECTION / "cad_juntatubo.obj")
    v, t = np.asarray(mesh.vertices), np.asarray(mesh.triangles, dtype=np.int64)
    p, n = _without_bottom(v, t, 20000)
    r = _simplified(p, n)
    assert r.n_turned == 0
    assert mesh_checks(r.mesh.n_vertices, r.mesh.triangles)[1:] == (True, True)
    assert r.mesh.triangles.shape[0] < 5000


@pytest.mark.parametrize(
    ("shape", "faces", "off"), [(box, 3, 1.0), (l_bracket, 5, 1.05)], ids=["box", "l-bracket"]
)
def test_a_part_seen_from_one_corner_gives_the_faces_it_sees(shape, faces, off):
    """One scanner view (along (1, 1, 1), only the faces turned towards it; both parts
    are seen whole where they face it): an open disc of the faces seen, each planar
    (the L-bracket's fifth was bent by 1.8 % of the diagonal by one triangle at the
    rim, now set apart: `_planar.bent_apart`), near the truth's seen part both ways
    (the box 0.48 %; the L-bracket 1.01 %: the truth's seen rim a sampling gap past
    the last of its 6,000 points)."""
    v, t = shape()
    s = sample_mesh(v, t, 24000, rng=0)
    view = np.ones(3) / np.sqrt(3.0)
    seen = np.flatnonzero(np.asarray(s.normals) @ view > 0.1)[:6000]
    p, n = np.asarray(s.points)[seen], np.asarray(s.normals)[seen]
    m = _simplified(p, n).mesh
    assert mesh_checks(m.n_vertices, m.triangles) == (False, True, True)
    assert m.euler_characteristic == 1 and int(m.face_flat.sum()) == faces
    diag = float(np.linalg.norm(np.ptp(p, axis=0)))
    assert (m.planarity_error[m.face_flat] <= 1e-6 * diag).all()
    assert np.bincount(m.triangle_face, minlength=m.n_faces)[~m.face_flat].sum() <= 1
    mv, mt = np.asarray(m.vertices), np.asarray(m.triangles)
    truth = sample_mesh(v, t, 20000, rng=1)
    there = np.asarray(truth.points)[np.asarray(truth.normals) @ view > 0.1]
    ours = np.vstack([mv, sample_mesh(mv, mt, 20000, rng=1).points])
    d = max(point_mesh_distance(ours, v, t).max(), point_mesh_distance(there, mv, mt).max())
    assert 100.0 * d / float(np.linalg.norm(np.ptp(p, axis=0))) <= off


def test_an_open_tube_whose_dipoles_cancel_is_simplified_as_open():
    """The bundled open tube (`synth:cylinder`, no caps): its normals sum to nothing by
    symmetry, so the dipole test reads it closed, and every piece of its capped voxel
    surface read as a bubble ("every piece ... faces away", an error since the bubbles'
    drop); as the open sample it is: an open ring of the tube's faces, near its points."""
    from pointatlas import data

    ps = data.load("synth:cylinder")
    r = _simplified(ps.points, ps.normals)
    m = r.mesh
    assert "the mesh is open, cut where they end" in r.reason
    assert mesh_checks(m.n_vertices, m.triangles) == (False, True, True)
    assert m.euler_characteristic == 0  # a ring
    diag = float(np.linalg.norm(np.ptp(ps.points, axis=0)))
    assert max(m.distance_max, m.back_distance_max) <= 0.005 * diag  # the default bound


def test_the_far_triangles_skipped_give_the_same_surface(monkeypatch):
    """An open sample's voxel surface runs far past its points (a tube seen from one
    side: about a fifth of its 154,080 triangles more than two cells of the grid k-NN
    away); the triangles the grid's cells alone tell are beyond the cut
    (`GridKnn.farther_than`) get no nearest point: the surface is the one with every
    nearest point found, bit for bit."""
    from pointatlas.simplify._grid_knn import GridKnn
    from pointatlas.simplify._reconstruct import reconstruct_surface

    v, t = _tube()
    s = sample_mesh(v, t, 24000, rng=0)
    seen = np.flatnonzero(np.asarray(s.normals)[:, 0] > 0.1)[:6000]
    p, n = np.asarray(s.points)[seen], np.asarray(s.normals)[seen]
    told = []
    farther_than = GridKnn.farther_than

    def counted(self, x, dist):
        far = farther_than(self, x, dist)
        told.append(int(far.sum()))
        return far

    monkeypatch.setattr(GridKnn, "farther_than", counted)
    fast = reconstruct_surface(p, n)
    assert sum(told) > 10000  # some were skipped
    monkeypatch.setattr(GridKnn, "farther_than", lambda self, x, dist: np.zeros(len(x), bool))
    every = reconstruct_surface(p, n)
    assert np.array_equal(fast.vertices, every.vertices)
    assert np.array_equal(fast.triangles, every.triangles)
    assert fast.n_trimmed == every.n_trimmed > 0
