"""The planar pieces after the local denoise (`snap_planar_pieces`, `_planes.py`)."""

import math

import numpy as np
import pytest

from pointatlas._core import readonly_view
from pointatlas.denoise import _planes as planes
from pointatlas.denoise import add_noise, denoise, normal_voting_denoise
from pointatlas.denoise._api import snap_planar_pieces
from pointatlas.denoise._kernels import CLASS_FACE
from pointatlas.neighbors import query_knn
from pointatlas.synth import cube, cylinder, icosphere, torus
from tests.jit_off import JIT_OFF, run_module_without_jit


def _angles(normals, clean):
    cos = np.abs((normals * clean).sum(axis=1)).clip(0.0, 1.0)
    return np.degrees(np.arccos(cos))


@pytest.fixture(scope="module")
def noisy_cube():
    """cube(20) with 0.6 l of noise along the normals: the denoise takes two rounds."""
    m = cube(20)
    return m, add_noise(m.points, m.normals, 0.6, k=6, rng=1)


def _to_cube(points):
    """Distance of each point to the surface of the cube [-0.5, 0.5]^3 (outside or
    near a face: |max |x_c|| - 0.5|)."""
    return np.abs(np.abs(points).max(axis=1) - 0.5)


def test_cube_edges_sharper(noisy_cube):
    """Face points within 2 l of an edge: far more within 5 degrees (issue 17); the
    points move onto the faces."""
    m, noisy = noisy_cube
    local = normal_voting_denoise(noisy, None, adaptive=False)
    assert local.n_iter == 2
    out = snap_planar_pieces(noisy, local)
    to_edge = np.sort(0.5 - np.abs(m.points), axis=1)[:, 1]  # distance to the nearest edge
    near = (to_edge > 1e-9) & (to_edge < 2 * local.spacing)
    before = (_angles(local.normals, m.normals)[near] < 5).mean()
    after = (_angles(out.normals, m.normals)[near] < 5).mean()
    assert after > 0.65 and after > 2 * before
    took = (out.points != local.points).any(axis=1)
    assert took.mean() > 0.7
    assert _to_cube(out.points[took]).mean() < 0.6 * _to_cube(local.points[took]).mean()
    assert _to_cube(out.points).mean() < 0.8 * _to_cube(local.points).mean()
    assert np.allclose(out.displacement, np.linalg.norm(out.points - noisy, axis=1))
    moved = np.linalg.norm(out.points - local.points, axis=1)
    assert moved.max() <= planes.PIECE_DIST * local.spacing + 1e-12
    # normals unit and signed like before; the rest untouched
    assert np.allclose(np.linalg.norm(out.normals, axis=1), 1.0)
    assert ((out.normals * local.normals).sum(axis=1) >= 0).all()
    assert np.array_equal(out.k, local.k) and out.n_iter == local.n_iter
    # `denoise` = the local denoise and the pieces on one k-NN table of the input
    table = query_knn(noisy, 48)[0]
    same = snap_planar_pieces(
        noisy, normal_voting_denoise(noisy, None, adaptive=False), neighbors=table
    )
    got = denoise(noisy, None, method="normal-voting")
    assert np.array_equal(got.normals, same.normals) and np.array_equal(got.points, same.points)


CURVED = [
    icosphere(4),
    cylinder(1.0, 2.0, n_around=48, n_height=40),
    torus(4.0, 1.5, n_major=128, n_minor=40),
]


@pytest.mark.parametrize("mesh", CURVED)
def test_curved_surfaces_untouched(mesh):
    """No planar piece on a sphere, a cylinder or a torus: points and normals stay
    bit for bit (the torus' top and bottom annuli are flat within the noise, 8 % of
    its points, but no sharp edge bounds them)."""
    noisy = add_noise(mesh.points, mesh.normals, 0.3, k=6, rng=2)
    local = denoise(noisy, None, method="normal-voting", planes=False)
    out = snap_planar_pieces(noisy, local)
    assert np.array_equal(out.normals, local.normals) and np.array_equal(out.points, local.points)


def test_pieces_and_assignment(noisy_cube):
    """Pieces: at least PIECE_MIN points each, one per cube face; every assigned
    normal is its piece's plane normal up to sign, and agrees with a plain loop."""
    m, noisy = noisy_cube
    local = normal_voting_denoise(noisy, None, adaptive=False)
    pts, nrm, ell = local.points, local.normals, local.spacing
    table = query_knn(pts, planes.PIECE_SEED)[0]
    graph = np.ascontiguousarray(table[:, : planes.PIECE_GRAPH])
    order = planes._seed_order(pts, table)
    n = len(pts)
    label = np.full(n, -1, dtype=np.int64)
    centres = np.empty((n, 3))
    pn = np.empty((n, 3))
    cos_a = math.cos(math.radians(planes.PIECE_ANGLE))
    cos_edge = math.cos(math.radians(planes.PIECE_EDGE_ANGLE))
    count = planes.pieces_kernel(
        pts,
        nrm,
        graph,
        table,
        order,
        local.feature_class == CLASS_FACE,
        planes.PIECE_DIST * ell,
        cos_a,
        planes.PIECE_MIN,
        planes.PIECE_REFITS,
        cos_edge,
        planes.PIECE_EDGE_SHARE,
        label,
        centres,
        pn,
    )
    assert count == 6
    assert (np.bincount(label[label >= 0]) >= planes.PIECE_MIN).all()
    assert np.allclose(np.linalg.norm(pn[:count], axis=1), 1.0)
    # each plane is the least-squares plane of its members, and one per cube face
    faces = set()
    for q in range(count):
        mem = pts[label == q]
        c = mem.mean(axis=0)
        w, v = np.linalg.eigh((mem - c).T @ (mem - c))
        assert np.allclose(c, centres[q]) and abs(v[:, 0] @ pn[q]) > 1 - 1e-9
        axis = int(np.argmax(np.abs(pn[q])))
        assert abs(pn[q, axis]) > math.cos(math.radians(2))
        faces.add((axis, bool(c[axis] > 0)))
        assert (_angles(m.normals[label == q], pn[q]) < 5).mean() > 0.95
    assert len(faces) == 6
    out = np.empty_like(nrm)
    out_pts = np.empty_like(pts)
    piece = np.empty(n, dtype=np.int64)
    cos_b = math.cos(math.radians(planes.PIECE_ASSIGN_ANGLE_HIGH))
    amb = planes.PIECE_AMBIGUOUS * ell
    planes.assign_kernel(
        pts,
        nrm,
        graph,
        label,
        centres[:count],
        pn[:count],
        planes.PIECE_DIST * ell,
        cos_b,
        amb,
        0.75,
        out,
        out_pts,
        piece,
    )
    for i in range(n):  # the plain loop
        cands = sorted(
            {int(label[j]) for j in graph[i] if label[j] >= 0},
            key=lambda q: (abs((pts[i] - centres[q]) @ pn[q]), q),
        )
        dist = [abs((pts[i] - centres[q]) @ pn[q]) for q in cands]
        ok = (
            cands
            and dist[0] <= planes.PIECE_DIST * ell
            and (len(cands) == 1 or dist[1] >= amb)
            and abs(nrm[i] @ pn[cands[0]]) >= cos_b
        )
        assert piece[i] == (cands[0] if ok else -1)
        want = np.sign(nrm[i] @ pn[cands[0]]) * pn[cands[0]] if ok else nrm[i]
        assert np.allclose(out[i], want, atol=0, rtol=0)
        if ok:  # 0.75 of the way onto the plane
            q = cands[0]
            want = pts[i] - 0.75 * ((pts[i] - centres[q]) @ pn[q]) * pn[q]
            assert np.allclose(out_pts[i], want, rtol=0, atol=1e-12)
        else:
            assert np.array_equal(out_pts[i], pts[i])


def test_tiny_flatness_ratio_matches_numpy():
    rng = np.random.default_rng(3)
    pts = rng.normal(size=(60, 3)) * [1.0, 0.5, 0.05]
    table = query_knn(pts, 10)[0]
    got = np.empty(len(pts))
    # read-only points, as `snap_to_pieces` passes them (one kernel signature)
    planes.flatness_ratio_kernel(readonly_view(pts), table, got)
    q = pts[table] - pts[table].mean(axis=1, keepdims=True)
    lam = np.linalg.eigvalsh(np.einsum("nki,nkj->nij", q, q))
    assert np.allclose(got, lam[:, 0] / lam.sum(axis=1), rtol=1e-7, atol=1e-12)


def test_small_inputs_and_no_rounds():
    m = cube(4)  # 98 points: fewer than a piece needs
    r = denoise(m.points, m.normals, method="normal-voting")
    assert np.array_equal(r.normals, denoise(m.points, m.normals, planes=False).normals)
    zero = normal_voting_denoise(m.points, m.normals, n_iter=0)
    assert snap_planar_pieces(m.points, zero) is zero
    with pytest.raises(ValueError, match="points must have the result's shape"):
        snap_planar_pieces(m.points[:50], zero)


def test_tiny_folded_sheet():
    """Two 16 x 16 grids meeting at a right angle: two pieces, one per half, each
    taking its exact plane; points on the fold keep their normal (a second plane)."""
    g = np.arange(16) / 15.0
    u, v = (a.ravel() for a in np.meshgrid(g, g))
    rng = np.random.default_rng(5)
    half = np.column_stack([u * 0.0, u + 1 / 15.0, v])  # x = 0, y in (0, 1]
    other = np.column_stack([u, u * 0.0, v])  # y = 0, x in [0, 1]
    pts = np.vstack([half, other]) + rng.normal(scale=1e-3, size=(512, 3))
    nrm = np.vstack([np.tile([-1.0, 0, 0], (256, 1)), np.tile([0, -1.0, 0], (256, 1))])
    out, moved, piece = planes.snap_to_pieces(pts, nrm, np.ones(512, dtype=bool), 1 / 15.0)
    assert set(piece[:256]) - {-1} and set(piece[256:]) - {-1}
    assert set(piece[:256]).isdisjoint(set(piece[256:]) - {-1})
    took = piece >= 0
    assert np.allclose(np.abs(out[took] * nrm[took]).sum(axis=1), 1.0, atol=1e-4)
    fold = np.abs(pts[:, 1]) < 0.02  # the row y = 0 of the half x = 0 is 1/15 away
    assert (piece[fold & (np.arange(512) >= 256) & (np.abs(pts[:, 0]) < 0.02)] == -1).all()
    assert np.array_equal(out[~took], nrm[~took]) and np.array_equal(moved[~took], pts[~took])
    for q in set(piece) - {-1}:  # the moved points of a piece lie on one plane
        x = moved[piece == q] - moved[piece == q].mean(axis=0)
        assert np.linalg.eigvalsh(x.T @ x)[0] < 1e-12  # noise before: 2.6e-4


@pytest.mark.skipif(JIT_OFF, reason="already running with the JIT off")
def test_kernels_without_jit():
    run_module_without_jit(__file__, select="tiny")
