"""Invariants of the denoisers: determinism, permutation and rigid-motion
equivariance of the point update."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from pointatlas.denoise import add_noise, flatness_denoise, normal_voting_denoise
from pointatlas.synth import cube, vertex_normals
from tests.strategies import rigid_motions, seeds


def _noisy_cube(seed, n=5):
    """cube(n) with 0.3 l noise along the normals and the noisy mesh's normals.

    Random noise makes every neighbour distance distinct (no k-NN ties), so the
    neighbourhoods are defined by the geometry alone.
    """
    m = cube(n)
    noisy = add_noise(m.points, m.normals, 0.3, k=6, rng=seed)
    return noisy, vertex_normals(noisy, m.faces)


def _run(method, points, normals):
    if method == "flatness":
        r = flatness_denoise(points, k=10, n_iter=5, normals=normals)
    else:
        r = normal_voting_denoise(points, normals, adaptive=method == "adaptive", n_iter=2)
    return r


METHODS = st.sampled_from(["fixed", "adaptive", "flatness"])


@settings(deadline=None, max_examples=10)
@given(seed=seeds(), method=METHODS)
def test_same_seed_same_output(seed, method):
    a = _run(method, *_noisy_cube(seed))
    b = _run(method, *_noisy_cube(seed))
    for x, y in ((a.points, b.points), (a.normals, b.normals), (a.k, b.k)):
        assert np.array_equal(x, y)


@settings(deadline=None, max_examples=10)
@given(seed=seeds(), method=METHODS)
def test_permutation_equivariance(seed, method):
    pts, nrm = _noisy_cube(seed)
    perm = np.random.default_rng(seed).permutation(len(pts))
    a = _run(method, pts, nrm)
    b = _run(method, pts[perm], nrm[perm])
    np.testing.assert_allclose(b.points, a.points[perm], atol=1e-12)
    np.testing.assert_allclose(b.normals, a.normals[perm], atol=1e-12)
    assert np.array_equal(b.k, a.k[perm])


@settings(deadline=None, max_examples=10)
@given(seed=seeds(), motion=rigid_motions(), method=METHODS)
def test_rigid_motion_equivariance(seed, motion, method):
    rot, shift = motion
    pts, nrm = _noisy_cube(seed)
    a = _run(method, pts, nrm)
    b = _run(method, pts @ rot.T + shift, nrm @ rot.T)
    scale = 1.0 + np.abs(shift).max()
    np.testing.assert_allclose(b.points, a.points @ rot.T + shift, atol=1e-9 * scale)
    # normal voting keeps orientations; flatness normals are signed like the input's
    np.testing.assert_allclose(b.normals, a.normals @ rot.T, atol=1e-7)
