"""orient_normals: MST propagation, outward, viewpoint and up rules, components, errors."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings

from pointatlas._core import PointAtlasError
from pointatlas.neighbors import query_knn
from pointatlas.normals import estimate_normals, flipped_fraction, orient_normals

from ..strategies import rigid_motions, seeds
from .shapes import cube, random_flips, sphere, torus


def _shapes():
    return {
        "sphere": sphere(2000),
        "torus": torus(90, 30, rng=0),
        "noisy_cube": cube(18, noise=0.15, rng=1),
    }


@pytest.mark.parametrize("name", ["sphere", "torus", "noisy_cube"])
@pytest.mark.parametrize("method", ["mst", "outward"])
def test_closed_shapes_oriented_outward(name, method):
    pts, exact = _shapes()[name]
    est = random_flips(estimate_normals(pts, 15), 3)
    assert 0.3 < flipped_fraction(est, exact) < 0.7
    oriented = orient_normals(pts, est, k=10, method=method)
    assert flipped_fraction(oriented, exact) == 0.0
    # only signs change
    assert np.allclose(np.abs(np.sum(oriented * est, axis=1)), 1.0)


def test_orientation_independent_of_input_signs():
    pts, exact = torus(60, 20, rng=2)
    est = estimate_normals(pts, 12)
    a = orient_normals(pts, random_flips(est, 0))
    b = orient_normals(pts, random_flips(est, 1))
    assert np.array_equal(a, b)


def test_outward_vote_per_component():
    # the vote behind method="outward" (private helper): inward-oriented closed
    # components are flipped (-1), outward ones kept (+1), a flat patch undecided (0)
    from pointatlas.normals._orient import _outward_flip

    a, na = sphere(800)
    b, nb = torus(40, 16, rng=0)
    b = b + [20.0, 0.0, 0.0]
    rng = np.random.default_rng(0)
    c = np.column_stack([rng.random((300, 2)) - [0.0, 20.0], np.zeros(300)])
    nc = np.tile([0.0, 0.0, 1.0], (300, 1))
    pts = np.vstack([a, b, c])
    labels = np.repeat([0, 1, 2], [800, b.shape[0], 300])
    idx, _ = query_knn(pts, 10)
    inward = np.vstack([-na, nb, nc])
    assert _outward_flip(pts, inward, labels, 3, idx).tolist() == [-1.0, 1.0, 0.0]
    outward_res = orient_normals(pts, random_flips(inward, 4), method="outward")
    assert flipped_fraction(outward_res[:800], na) == 0.0
    assert flipped_fraction(outward_res[800:-300], nb) == 0.0


def test_open_patch_uses_top_rule():
    rng = np.random.default_rng(0)
    pts = np.column_stack([rng.random((400, 2)), 0.01 * rng.random(400)])
    est = random_flips(estimate_normals(pts, 10), 1)
    for method in ("mst", "outward"):
        assert (orient_normals(pts, est, method=method)[:, 2] > 0).all()


def test_disconnected_spheres_each_oriented():
    a, na = sphere(800, radius=1.0)
    b, nb = sphere(500, radius=0.3, center=(50.0, 0.0, -20.0))
    pts = np.vstack([a, b])
    exact = np.vstack([na, nb])
    est = random_flips(estimate_normals(pts, 12), 5)
    for method in ("mst", "outward"):
        assert flipped_fraction(orient_normals(pts, est, method=method), exact) == 0.0


def test_viewpoint():
    pts, exact = sphere(500)
    est = random_flips(exact, 0)
    inward = orient_normals(pts, est, method="viewpoint", viewpoint=[0.0, 0.0, 0.0])
    assert flipped_fraction(inward, exact) == 1.0
    far = orient_normals(pts, est, method="viewpoint", viewpoint=(0.0, 0.0, 100.0))
    assert (np.sum(([0.0, 0.0, 100.0] - pts) * far, axis=1) >= 0).all()
    assert np.allclose(np.abs(np.sum(far * est, axis=1)), 1.0)
    assert (far[pts[:, 2] > 0.2, 2] > 0).all()


def _up_reference(normals):
    """Plain-Python reference of method="up": the first non-zero of (z, y, x) positive."""
    out = []
    for n in normals.tolist():
        lead = next((v for v in (n[2], n[1], n[0]) if v != 0.0), 0.0)
        out.append([-v for v in n] if lead < 0.0 else n)
    return np.array(out)


def test_up_equals_the_plain_reference_and_ignores_input_signs():
    pts, exact = sphere(500)
    ties = np.array(
        [
            [0.6, 0.8, 0.0],
            [0.6, -0.8, 0.0],
            [-0.6, -0.8, -0.0],
            [-1.0, 0.0, 0.0],
            [-1.0, -0.0, -0.0],
            [0.0, 0.0, -1.0],
            [0.0, -0.0, 1.0],
        ]
    )
    nrm = np.vstack([exact, ties])
    pts = np.vstack([pts, np.zeros((ties.shape[0], 3))])
    unit = nrm / np.linalg.norm(nrm, axis=1)[:, None]
    up = orient_normals(pts, random_flips(nrm, 1), method="up")
    ref = _up_reference(unit)
    assert np.array_equal(np.signbit(up), np.signbit(ref)) and np.array_equal(up, ref)
    assert (up[:, 2] >= 0).all() and (up[pts[:, 2] > 0, 2] > 0).all()
    # n and -n give the same bits (also for nz == 0 and signed zeros)
    assert np.array_equal(np.signbit(orient_normals(pts, -nrm, method="up")), np.signbit(up))
    assert np.array_equal(orient_normals(pts, -nrm, method="up"), up)
    # per point: any subset gives its rows of the whole (what tiles rely on)
    rows = np.arange(0, pts.shape[0], 7)
    assert np.array_equal(orient_normals(pts[rows], nrm[rows], method="up"), up[rows])
    # only signs change; agrees with PDAL's always_up (flip when nz < 0) where nz != 0
    assert np.array_equal(np.abs(up), np.abs(unit))
    nz = unit[:, 2] != 0
    pdal = np.where(unit[:, 2:] < 0, -unit, unit)
    assert np.array_equal(up[nz], pdal[nz])


def test_duplicates_and_shared_neighbors():
    pts, exact = sphere(600)
    dup = np.vstack([pts, pts[::3]])
    exact_dup = np.vstack([exact, exact[::3]])
    idx, dist = query_knn(dup, 15)
    est = random_flips(estimate_normals(dup, 15, neighbors=idx), 2)
    oriented = orient_normals(dup, est, k=10, neighbors=(idx, dist))
    assert flipped_fraction(oriented, exact_dup) == 0.0
    assert np.array_equal(oriented, orient_normals(dup, est, k=10))


def test_unnormalised_input_and_dtype():
    pts, exact = sphere(300)
    out = orient_normals(pts.tolist(), (3.0 * exact).tolist())
    assert out.dtype == np.float64 and out.shape == (300, 3)
    assert np.allclose(np.linalg.norm(out, axis=1), 1.0)


def test_inputs_not_modified():
    pts, exact = sphere(300)
    est = random_flips(exact, 0)
    pts.flags.writeable = False
    est.flags.writeable = False
    before = est.copy()
    for method in ("mst", "outward"):
        orient_normals(pts, est, method=method)
    orient_normals(pts, est, method="viewpoint", viewpoint=[0, 0, 0])
    orient_normals(pts, est, method="up")
    assert np.array_equal(est, before)


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"method": "towards"}, ValueError, "method must be one of"),
        ({"method": "viewpoint"}, ValueError, "viewpoint is required"),
        ({"method": "viewpoint", "viewpoint": [0, 0]}, ValueError, r"shape \(3,\)"),
        ({"method": "viewpoint", "viewpoint": [0, 0, np.inf]}, ValueError, "finite"),
        ({"k": 1}, ValueError, r"k must be an integer in \[2, 50\]"),
        ({"edge_penalty": -1.0}, ValueError, "edge_penalty must be"),
        ({"k": 1000}, PointAtlasError, r"in \[2, 50\] \(the number of points\); got 1000"),
        ({"neighbors": np.zeros((50, 3), dtype=np.int64)}, ValueError, "m >= 10"),
    ],
)
def test_bad_input(kwargs, error, match):
    pts, exact = sphere(50)
    with pytest.raises(error, match=match):
        orient_normals(pts, exact, **kwargs)


def test_bad_normals():
    pts, exact = sphere(50)
    with pytest.raises(ValueError, match="one row per point"):
        orient_normals(pts, exact[:40])
    zero = exact.copy()
    zero[7] = 0.0
    with pytest.raises(ValueError, match="zero-length"):
        orient_normals(pts, zero)


@settings(deadline=None, max_examples=10)
@given(motion=rigid_motions(), seed=seeds())
def test_outward_orientation_invariant_under_rigid_motion(motion, seed):
    rot, shift = motion
    pts, exact = torus(40, 14, rng=seed)
    moved = pts @ rot.T + shift
    est = random_flips(estimate_normals(moved, 12), seed)
    oriented = orient_normals(moved, est, k=10)
    assert flipped_fraction(oriented, exact @ rot.T) == 0.0


def test_orientation_follows_a_permutation_of_the_input():
    # the forest runs on spatially renumbered points; whatever the input order,
    # every point gets the same sign (a tie-free noisy torus)
    pts, _ = torus(60, 20, rng=4)
    est = random_flips(estimate_normals(pts, 12), 5)
    perm = np.random.default_rng(6).permutation(pts.shape[0])
    a = orient_normals(pts, est, k=10)
    b = orient_normals(pts[perm], est[perm], k=10)
    assert np.array_equal(a[perm], b)
