"""Points far off the surface the others sample (a scanner's stray returns) are left
out of `simplify_points` and counted (`_checks.off_surface`): the output is the clean
sample's, bit for bit; no point of a clean sample is left out."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.spatial import cKDTree
from typer.testing import CliRunner

from pointatlas.cli import app
from pointatlas.io import write_point_set
from pointatlas.simplify import simplify_points
from pointatlas.simplify._checks import (
    OFF_NEIGHBORS,
    OFF_SPACING_NEIGHBOR,
    OFF_SURFACE,
    off_surface,
)
from pointatlas.simplify._mesh import mesh_checks
from pointatlas.synth import sample_mesh

from .cad_shapes import box, cylinder, extrude, l_bracket


def _sampled(shape, n=4000, seed=0):
    v, t = shape()
    s = sample_mesh(v, t, n, rng=seed)
    return np.asarray(s.points), np.asarray(s.normals)


def _with_strays(p, n, count=8, seed=1):
    """``count`` (at most 8) points a diagonal off the sample's centre along each
    axis, towards the corners of a cube around it, with random unit normals,
    appended after the sample's own."""
    rng = np.random.default_rng(seed)
    diag = float(np.linalg.norm(np.ptp(p, axis=0)))
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1.0)])
    far = p.mean(axis=0) + diag * corners[:count]
    normals = rng.normal(size=(count, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    return np.vstack([p, far]), np.vstack([n, normals])


def _reference(q, normals):
    """Plain loops: each point's median height over its 8 nearest others' tangent
    planes, against `OFF_SURFACE` times the median 4th-neighbour distance."""
    d, j = cKDTree(q).query(q, OFF_NEIGHBORS + 2)
    spacing = np.median(d[:, OFF_SPACING_NEIGHBOR])
    out = []
    for i in range(q.shape[0]):
        h = [abs(normals[m] @ (q[i] - q[m])) for m in j[i, 1 : OFF_NEIGHBORS + 1]]
        out.append(np.median(h) > OFF_SURFACE * spacing)
    return np.array(out)


def test_off_surface_agrees_with_a_plain_reference():
    p, n = _with_strays(*_sampled(l_bracket, 1500))
    d, j = cKDTree(p).query(p, 10)
    found = off_surface(p, n, j, d)
    assert np.array_equal(found, _reference(p, n))
    assert found[1500:].all() and not found[:1500].any()


@pytest.mark.parametrize("shape", [box, l_bracket, cylinder], ids=["box", "l-bracket", "cyl"])
def test_strays_are_left_out_and_the_output_is_the_clean_samples(shape):
    p, n = _sampled(shape)
    clean = simplify_points(p, n)
    assert clean.n_off_surface == 0 and clean.n_dropped == 0
    p2, n2 = _with_strays(p, n)
    r = simplify_points(p2, n2)
    assert r.n_off_surface == 8 and r.n_dropped == 8
    assert np.array_equal(r.point_index, np.arange(p.shape[0]))
    assert r.summary()["points_off_surface"] == 8
    assert np.array_equal(r.mesh.vertices, clean.mesh.vertices)
    assert np.array_equal(r.mesh.triangles, clean.mesh.triangles)


def test_a_part_seen_from_one_side_loses_no_point():
    """Half of an L-bracket's samples (those facing +x+y+z: one scanner's side) and a
    sparse sample (600 points): nothing is left out."""
    p, n = _sampled(l_bracket, 8000)
    seen = n @ np.array([1.0, 1.0, 1.0]) > 0.1
    d, j = cKDTree(p[seen]).query(p[seen], 10)
    assert not off_surface(p[seen], n[seen], j, d).any()
    p, n = _sampled(l_bracket, 600)
    d, j = cKDTree(p).query(p, 10)
    assert not off_surface(p, n, j, d).any()


def test_the_cli_says_how_many_points_it_left_out(tmp_path):
    src, out, rep = tmp_path / "scan.ply", tmp_path / "o.obj", tmp_path / "r.json"
    points, normals = _with_strays(*_sampled(box, 3000), count=7)
    write_point_set(src, points, normals=normals)
    res = CliRunner().invoke(app, ["simplify", str(src), str(out), "--report", str(rep)])
    assert res.exit_code == 0, res.output
    assert "7 points lie far off the surface the others sample (outliers): left out" in (
        " ".join(res.stderr.split())
    )
    assert json.loads(rep.read_text())["points_off_surface"] == 7


def _near_strays(p, n, count=12, lift=3.0):
    """``count`` points of the sample, evenly spread over it, moved ``lift`` first-grid
    steps out along their normals: stray returns near the surface (kept: below
    `OFF_SURFACE`), each more than `LOST_STEPS` steps off the voxel surface."""
    from pointatlas.simplify._voxel_grid import grid_step

    step = grid_step(p, n, cKDTree(p))[1]
    moved = np.linspace(0, p.shape[0] - 1, count).astype(np.int64)
    q = p.copy()
    q[moved] += lift * step * n[moved]
    return q, moved


@pytest.mark.parametrize("link", [True, False], ids=["alone", "unlinked"])
def test_strays_near_the_surface_do_not_build_the_surface_again(monkeypatch, link):
    """Points each alone more than `LOST_STEPS` steps off the voxel surface are stray
    returns, not a part the grid lost (`_voxel_grid.linked`): the surface is built
    once, not again on the finer grid and with parts made solid (2-3x the time with
    1 % of the points moved off). Counted alone (``unlinked``), they build it again."""
    import pointatlas.simplify._reconstruct as rec
    import pointatlas.simplify._solid as solid

    p, n = _sampled(box, 4000)
    q, moved = _near_strays(p, n)
    d, j = cKDTree(q).query(q, 10)
    assert not off_surface(q, n, j, d).any()  # kept
    if not link:
        monkeypatch.setattr(rec, "LOST_LINK", 0.0)
        monkeypatch.setattr(solid, "LOST_LINK", 0.0)
    built = []
    surface_at = rec._surface_at

    def counted(*args, **kwargs):
        built.append(1)
        return surface_at(*args, **kwargs)

    monkeypatch.setattr(rec, "_surface_at", counted)
    r = simplify_points(q, n)
    assert r.n_dropped == 0
    assert (len(built) == 1) == link
    assert mesh_checks(r.mesh.n_vertices, r.mesh.triangles) == (True, True, True)


def test_lost_strays_agree_with_a_plain_reference():
    """A square of two triangles; points at heights 0-6 steps, some off their planes:
    a stray is farther than `LOST_STEPS` steps, off, and has no other point that far
    within the link."""
    from pointatlas.simplify._voxel_grid import LOST_STEPS, lost_strays

    v = np.array([[0.0, 0, 0], [10, 0, 0], [10, 10, 0], [0, 10, 0]])
    t = np.array([[0, 1, 2], [0, 2, 3]])
    rng = np.random.default_rng(3)
    q = np.column_stack([rng.uniform(0, 10, 60), rng.uniform(0, 10, 60), rng.uniform(0, 6, 60)])
    off = rng.random(60) < 0.5
    link = 1.5
    got = lost_strays(q, v, t, 1.0, off, link)
    far = q[:, 2] > LOST_STEPS
    want = []
    for i in range(60):
        near = [j for j in range(60) if j != i and far[j] and np.linalg.norm(q[i] - q[j]) <= link]
        want.append(bool(far[i] and off[i] and not near))
    assert got.tolist() == want
    assert 0 < sum(want) < (far & off).sum()


@pytest.mark.parametrize("shape", [box, l_bracket], ids=["box", "l-bracket"])
def test_strays_the_voxel_surface_does_not_reach_are_left_out(shape):
    """On the robust path, points moved 4 grid steps out along their normals (below
    `OFF_SURFACE`, each alone farther than `LOST_STEPS` steps from the voxel surface)
    are left out and counted; the surface built with them stands (it does not reach
    them): closed, within 0.5 % of the diagonal of the truth both ways, and about as
    many triangles as the points without them give (at most a fifth more: the first
    surface, built with them, differs, so the collapses go another way; the box 48
    against 42, both on the truth)."""
    from .test_points_robust import _to_and_from_truth

    v, t = shape()
    p, n = _sampled(shape)
    q, moved = _near_strays(p, n, lift=4.0)
    r = simplify_points(q, n, path="robust")
    assert r.n_off_surface == moved.size and r.summary()["points_off_surface"] == moved.size
    rest = np.setdiff1d(np.arange(p.shape[0]), moved)
    assert np.array_equal(r.point_index, rest)
    assert mesh_checks(r.mesh.n_vertices, r.mesh.triangles) == (True, True, True)
    diag = float(np.linalg.norm(np.ptp(p, axis=0)))
    assert max(_to_and_from_truth(r.mesh, v, t)) <= 0.005 * diag
    clean = simplify_points(q[rest], n[rest], path="robust")
    assert r.mesh.triangles.shape[0] <= 1.2 * clean.mesh.triangles.shape[0]


@pytest.mark.parametrize("noise_bar", [True, False], ids=["noise-bar", "fixed-bar"])
def test_a_noisy_samples_tails_are_kept(monkeypatch, noise_bar):
    """An L-bracket's 4,000 points with Gaussian noise of one point spacing: its tails
    lie alone over `LOST_STEPS` steps from the voxel surface, off their planes by more
    than `STRAY_DROP`, but not by more than `STRAY_NOISE` times the points' median
    ratio: none is left out (with the fixed bar alone, 6 are)."""
    import pointatlas.simplify._pipeline as pipeline

    p, n = _sampled(l_bracket, 4000)
    spacing = np.median(cKDTree(p).query(p, 2)[0][:, 1])
    noisy = p + np.random.default_rng(5).normal(0.0, spacing, p.shape)
    if not noise_bar:
        monkeypatch.setattr(pipeline, "STRAY_NOISE", 0.0)
    r = simplify_points(noisy, n, path="robust")
    assert (r.n_dropped == 0) == noise_bar


def test_a_fin_the_first_surface_loses_is_not_left_out():
    """The points of a fin thinner than the grid lie lost off the first voxel surface,
    but on their neighbours' planes and beside each other: none is left out."""
    th = 0.02
    outline = [(0, 0), (1, 0), (1, 0.5), (2, 0.5), (2, 0.5 + th), (1, 0.5 + th), (1, 1), (0, 1)]
    v, t = extrude(outline, height=1.0)
    s = sample_mesh(v, t, 6000, rng=0)
    r = simplify_points(np.asarray(s.points), np.asarray(s.normals), path="robust")
    assert r.n_dropped == 0
    assert mesh_checks(r.mesh.n_vertices, r.mesh.triangles) == (True, True, True)
