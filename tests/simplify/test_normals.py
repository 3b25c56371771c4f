"""Normals for raw points (`simplify/_normals.py`, `surface_normals`): the k-NN PCA
normal where the neighbourhood is flat, elsewhere the normal of the neighbourhood
size with the least eigenentropy unless noise bends it as much; checked against a
plain-numpy reference, nearer the truth than PCA at k = 20 beside the edges of a thin
plate and across a tube's wall thinner than the sampling, and PCA's under noise."""

from __future__ import annotations

import numpy as np

from pointatlas.neighbors import query_knn
from pointatlas.normals import estimate_normals
from pointatlas.simplify import NORMAL_K_RANGE, surface_normals
from pointatlas.simplify._normals import (
    FLAT_VARIATION,
    NOISE_CORE_K,
    NOISE_CORE_RATIO,
    NOISE_FACTOR,
)
from pointatlas.synth import sample_mesh

from .cad_shapes import extrude


def _plate(thickness: float, n: int):
    """A 1 x 1 plate ``thickness`` thick sampled with ``n`` points and true normals."""
    v, t = extrude([(0, 0), (1, 0), (1, 1), (0, 1)], height=thickness)
    s = sample_mesh(v, t, n, rng=0)
    return np.asarray(s.points), np.asarray(s.normals)


def _reference(p, k=20, k_range=NORMAL_K_RANGE, flat=FLAT_VARIATION):
    """`surface_normals` in plain numpy: each point's covariance at k, and where its
    surface variation passes ``flat`` and its smallest eigenvalue `NOISE_FACTOR` times
    the first quartile of the smallest eigenvalues at ``k_range[0]`` (every point: at
    most 20,000), the eigenentropy of every size in ``k_range`` (the least, the
    smallest size on ties) and that size's smallest eigenvector; where it passes
    ``flat`` only, and that quartile passes `NOISE_CORE_RATIO` times the quartile
    at `NOISE_CORE_K` (thin walls, not noise), the smallest eigenvector at
    ``k_range[1]``."""
    idx = query_knn(p, max(k, k_range[1]))[0]

    def quartile(size):
        small = [np.linalg.eigvalsh(np.cov(p[row[:size]].T, bias=True))[0] for row in idx]
        return np.quantile(small, 0.25)

    floor = quartile(k_range[0])
    thin = floor > NOISE_CORE_RATIO * quartile(NOISE_CORE_K)
    out = np.empty_like(p)
    for i in range(p.shape[0]):
        w, u = np.linalg.eigh(np.cov(p[idx[i, :k]].T, bias=True))
        out[i] = u[:, 0]
        if w[0] / w.sum() <= flat:
            continue
        if w[0] <= NOISE_FACTOR * floor:
            if thin:
                out[i] = np.linalg.eigh(np.cov(p[idx[i, : k_range[1]]].T, bias=True))[1][:, 0]
            continue
        best = np.inf
        for size in range(k_range[0], k_range[1] + 1):
            w, u = np.linalg.eigh(np.cov(p[idx[i, :size]].T, bias=True))
            e = np.clip(w / w.sum(), 1e-300, None)
            entropy = -(e * np.log(e)).sum()
            if entropy < best - 1e-12:
                best, out[i] = entropy, u[:, 0]
    return out


def test_the_normals_are_the_plain_numpy_references():
    p, _ = _plate(0.1, 1500)
    got = surface_normals(p)
    ref = _reference(p)
    np.testing.assert_allclose(np.linalg.norm(got, axis=1), 1.0, atol=1e-12)
    agree = np.abs(np.einsum("ij,ij->i", got, ref)) > 1.0 - 1e-6
    assert agree.mean() >= 0.995  # the rest: two sizes' entropies within rounding
    # and the optimal sizes were taken on the rims (not the k = 20 normals all along)
    pca = np.abs(np.einsum("ij,ij->i", got, estimate_normals(p, k=20))) < 1.0 - 1e-6
    assert pca.mean() > 0.1


def test_flat_neighbourhoods_keep_the_pca_normals_bit_for_bit():
    rng = np.random.default_rng(0)
    plane = np.c_[rng.random((500, 2)), np.zeros(500)]
    wavy = plane + np.c_[np.zeros((500, 2)), 0.01 * np.sin(3 * plane[:, 0])]
    for p in (plane, wavy):
        np.testing.assert_array_equal(surface_normals(p), estimate_normals(p, k=20))


def test_under_noise_only_edges_leave_the_pca_normals():
    """Gaussian noise of 1 % of the side (about a third of a point spacing): most
    neighbourhoods fail the flat test, yet a noisy plane keeps PCA's normals bit for
    bit, and on a noisy box only points beside its edges take another size's; the
    clean box takes them there too."""
    rng = np.random.default_rng(1)
    plane = np.c_[rng.random((6000, 2)), 0.01 * rng.standard_normal(6000)]
    assert (_variation(plane) > FLAT_VARIATION).mean() > 0.5
    np.testing.assert_array_equal(surface_normals(plane), estimate_normals(plane, k=20))
    v, t = extrude([(0, 0), (1, 0), (1, 1), (0, 1)], height=1.0)
    clean = np.asarray(sample_mesh(v, t, 6000, rng=0).points)
    noisy = clean + rng.normal(0.0, 0.01, clean.shape)
    for p, most in ((noisy, 0.1), (clean, 0.5)):
        moved = np.abs(np.einsum("ij,ij->i", surface_normals(p), estimate_normals(p, k=20)))
        moved = moved < 1.0 - 1e-6
        # beside an edge: two coordinates within 0.12 (about 2 k-NN radii) of a face
        near_edge = (np.minimum(p, 1.0 - p) < 0.12).sum(axis=1) >= 2
        assert moved.any() and near_edge[moved].all()
        assert moved.mean() < most


def _variation(p, k=20):
    idx = query_knn(p, k)[0]
    near = p[idx] - p[idx].mean(axis=1, keepdims=True)
    w = np.linalg.eigvalsh(np.einsum("nki,nkj->nij", near, near))
    return w[:, 0] / w.sum(axis=1)


def test_beside_a_thin_plates_edges_the_normals_are_nearer_the_truth():
    """A plate 0.05 thick (about 4.5 point spacings at 4,000 points): at k = 20 the
    neighbourhoods beside its rims hold the rim and both faces; the least-entropy
    ones hold one face."""
    p, truth = _plate(0.05, 4000)
    off = np.cos(np.radians(30.0))
    ours = np.abs(np.einsum("ij,ij->i", surface_normals(p), truth)) < off
    pca = np.abs(np.einsum("ij,ij->i", estimate_normals(p, k=20), truth)) < off
    assert ours.mean() <= 0.5 * pca.mean()


def _tube(n: int, outer=2.5, inner=2.2, length=20.0):
    """An open tube's two walls (``outer`` and ``inner`` radius) sampled uniformly by
    area with ``n`` points (seeded), and their radial directions."""
    rng = np.random.default_rng(0)
    on_outer = rng.random(n) < outer / (outer + inner)
    turn, height = 2.0 * np.pi * rng.random(n), length * rng.random(n)
    radius = np.where(on_outer, outer, inner)
    radial = np.c_[np.cos(turn), np.sin(turn), np.zeros(n)]
    return radial * radius[:, None] + np.c_[np.zeros((n, 2)), height], radial


def test_across_a_wall_thinner_than_the_sampling_the_wider_plane_is_taken():
    """A tube wall 0.3 thick sampled at about one point spacing (6,000 points): every
    neighbourhood holds both of its sides, and at k = 20 their planes tilt (as a
    sampled tube of the collection's, `trimesh_round`, with 1,329 of 20,000 normals
    more than 30 degrees off); the neighbourhoods of 30 points reach farther along
    the wall than across it. The plain-numpy reference agrees."""
    p, radial = _tube(6000)
    off = np.cos(np.radians(30.0))
    got = surface_normals(p)
    ours = np.abs(np.einsum("ij,ij->i", got, radial)) < off
    pca = np.abs(np.einsum("ij,ij->i", estimate_normals(p, k=20), radial)) < off
    assert pca.mean() > 0.02 and ours.mean() < 0.002
    agree = np.abs(np.einsum("ij,ij->i", got, _reference(p))) > 1.0 - 1e-6
    assert agree.mean() >= 0.995


def test_a_given_table_with_too_few_columns_is_searched_again():
    p, _ = _plate(0.05, 800)
    table = query_knn(p, 12)
    np.testing.assert_array_equal(surface_normals(p, neighbors=table), surface_normals(p))
