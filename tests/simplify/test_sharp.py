"""Oriented normals made sharp beside edges and thin walls (`simplify/_sharp.py`,
`sharpen_normals`): the best-supported plane through the point and two neighbours
checked against a plain-numpy reference, nearer the true face normals than the
blended ones beside the edges of a sampled plate, signs that follow the given
orientation and do not cross a thin wall, flat and noisy samples and smooth curved
ones left alone."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from pointatlas.neighbors import query_knn
from pointatlas.normals import orient_normals
from pointatlas.simplify import _normals, _sharp, sharpen_normals, surface_normals
from pointatlas.simplify._sharp import PAIR_NEIGHBORS, QUADRIC_NEIGHBORS, _plane_normals
from pointatlas.synth import sample_mesh

from .cad_shapes import circle, extrude


def _plate(thickness: float, n: int):
    """A 1 x 1 plate ``thickness`` thick sampled with ``n`` points and true normals."""
    v, t = extrude([(0, 0), (1, 0), (1, 1), (0, 1)], height=thickness)
    s = sample_mesh(v, t, n, rng=0)
    return np.asarray(s.points), np.asarray(s.normals)


def _smooth(normal, rel, tau):
    """Whether a quadric height over the plane of ``normal`` (in any orthonormal
    frame of it) fits the offsets ``rel`` to within ``tau``."""
    frame = np.linalg.svd(normal[None, :])[2][1:]
    x, y = (rel @ frame.T).T
    design = np.c_[x * x, x * y, y * y, x, y, np.ones_like(x)]
    height = rel @ normal
    coef = np.linalg.lstsq(design, height, rcond=None)[0]
    return np.abs(design @ coef - height).max() <= tau


def _reference(p, n, idx, rows, tau, pairs=PAIR_NEIGHBORS):
    """`_plane_normals` in plain numpy: every plane through the point and two of its
    ``pairs`` nearest (not about one line with it), scored by the neighbours within
    ``tau`` less those on its lesser side; the best (first on ties) refitted to the
    neighbours on it where it scores above the given normal's plane and no quadric
    over that plane fits the neighbourhood within ``tau``."""

    def score(c, rel):
        d = rel @ c
        return int((np.abs(d) <= tau).sum()) - min(int((d > tau).sum()), int((d < -tau).sum()))

    out = n[rows].copy()
    for r, i in enumerate(rows):
        rel = p[idx[i]] - p[i]
        if _smooth(n[i], rel, tau):
            continue
        own = best = score(n[i], rel)
        plane = n[i]
        for a in range(1, pairs):
            for b in range(a + 1, pairs):
                c = np.cross(rel[a], rel[b])
                if np.linalg.norm(c) <= 0.2 * np.linalg.norm(rel[a]) * np.linalg.norm(rel[b]):
                    continue
                c = c / np.linalg.norm(c)
                if score(c, rel) > best:
                    best, plane = score(c, rel), c
        if best <= own:
            continue
        on = rel[np.abs(rel @ plane) <= tau]
        out[r] = plane
        if on.shape[0] >= 6:
            w, u = np.linalg.eigh(np.cov(on.T, bias=True))
            if w[1] > 0.1 * w[2]:
                out[r] = u[:, 0]
    return out


def _far_off(normals, true, degrees: float) -> int:
    """How many ``normals`` lie more than ``degrees`` off the line of ``true``."""
    return int((np.abs((normals * true).sum(axis=1)) < np.cos(np.radians(degrees))).sum())


def _torus(n: int):
    """A torus (radii 1 and 0.2) sampled with ``n`` points and true normals."""
    m = trimesh.creation.torus(1.0, 0.2)
    s = sample_mesh(np.asarray(m.vertices), np.asarray(m.faces), n, rng=0)
    return np.asarray(s.points), np.asarray(s.normals)


def test_the_planes_match_a_plain_numpy_reference():
    # a plate, whose edges take planes, beside a torus, whose chord planes the
    # quadric test refuses
    p = np.vstack([_plate(0.1, 3000)[0], _torus(3000)[0] + 5.0])
    n = orient_normals(p, surface_normals(p))
    idx = query_knn(p, 20)[0]
    rows = np.arange(0, p.shape[0], 7)
    tau = 0.2 * float(np.median(query_knn(p, 2)[1][:, 1]))
    got, took = _plane_normals(p, idx, rows, n, tau, PAIR_NEIGHBORS, QUADRIC_NEIGHBORS, tau)
    want = _reference(p, n, idx, rows, tau)
    assert took.any() and not took.all()
    ungated = _plane_normals(p, idx, rows, n, tau, PAIR_NEIGHBORS, p.shape[0] + 1, tau)[1]
    assert (ungated & ~took)[rows >= 3000].sum() > 10
    # a normal's sign is free until `_signs`
    assert np.allclose(np.abs((got * want).sum(axis=1)), 1.0, atol=1e-9)


def test_a_smooth_curved_sample_keeps_its_normals(monkeypatch):
    """A torus sampled coarsely for its tube (3,000 points: a neighbourhood of 20
    reaches about 35 degrees round the tube): a chord plane through two neighbours
    holds more of them than the tangent plane, and without the quadric test it
    replaced 197 normals, 166 -> 225 more than 10 degrees off (measured)."""
    p, true = _torus(3000)
    blended = orient_normals(p, surface_normals(p))
    assert _far_off(sharpen_normals(p, blended), true, 10.0) <= _far_off(blended, true, 10.0)
    monkeypatch.setattr(_sharp, "QUADRIC_NEIGHBORS", p.shape[0] + 1)
    ungated = _far_off(sharpen_normals(p, blended), true, 10.0)
    assert ungated > _far_off(blended, true, 10.0) + 0.01 * p.shape[0]


def test_beside_the_edges_of_a_plate_the_normals_come_nearer_the_faces():
    p, true = _plate(0.1, 6000)
    blended = orient_normals(p, surface_normals(p))
    sharp = sharpen_normals(p, blended)
    before, after = _far_off(blended, true, 30.0), _far_off(sharp, true, 30.0)
    assert before > 0
    assert after < before / 2
    assert np.allclose(np.linalg.norm(sharp, axis=1), 1.0)


def test_signs_follow_the_given_orientation_and_stay_outward_on_a_thin_plate():
    p, true = _plate(0.02, 6000)  # a wall thinner than a neighbourhood
    blended = orient_normals(p, surface_normals(p))
    blended *= np.where((blended * true).sum(axis=1) < 0.0, -1.0, 1.0)[:, None]
    sharp = sharpen_normals(p, blended)
    flipped = sharpen_normals(p, -blended)
    assert np.array_equal(flipped, -sharp)
    # the wall is 2.3 spacings thick, not noise (`_normals.NOISE_CORE_K`): its planes
    # are searched, and a few points take a plane across both faces (6 of 6,000
    # turned inward by more than 60 degrees, measured; the given orientation none)
    inward = (sharp * true).sum(axis=1) < -0.5
    given = int(((blended * true).sum(axis=1) < -0.5).sum())
    assert int(inward.sum()) <= given + 0.002 * p.shape[0]
    # while the directions come near the faces (235 -> 105 more than 30 degrees off)
    far_off = [_far_off(m, true, 30.0) for m in (blended, sharp)]
    assert far_off[1] < far_off[0] / 2 and far_off[1] < 0.02 * p.shape[0]


def test_a_thin_walled_tube_is_not_taken_for_noise(monkeypatch):
    """A tube whose wall is about 2.2 point spacings thick: every neighbourhood of
    the noise floor's size (10) holds both sides, which read as noise of 0.6 spacings
    (nothing sharpened, the planes' tolerance 1.8 spacings); the smallest
    neighbourhoods (`NOISE_CORE_K`) tell the wall from noise."""
    v, t = extrude(circle((0, 0), 1.0, 96), [circle((0, 0), 0.9, 96)], height=6.0)
    s = sample_mesh(v, t, 8000, rng=0)
    p, true = np.asarray(s.points), np.asarray(s.normals)

    def degrees_off():
        sharp = sharpen_normals(p, orient_normals(p, surface_normals(p)))
        return np.degrees(np.arccos(np.clip(np.abs((sharp * true).sum(axis=1)), 0.0, 1.0)))

    off = degrees_off()
    assert np.median(off) < 5.0 and (off > 10.0).mean() < 0.05
    monkeypatch.setattr(_normals, "NOISE_CORE_RATIO", np.inf)  # the floor at 10 alone
    blended = degrees_off()
    assert np.median(blended) > 10.0 and (blended > 10.0).mean() > 0.5


def test_noise_does_not_let_the_quadric_take_in_an_edge(monkeypatch):
    """A plate 0.1 thick, its density falling tenfold along x, with noise of 0.2 % of
    the side: the planes' tolerance is the noise's (three deviations), and within it
    a quadric takes in the crease of an edge in the dense part (216 -> 229 normals
    more than 30 degrees off, measured); the quadric is held to the spacings'."""
    v, t = extrude([(0, 0), (1, 0), (1, 1), (0, 1)], height=0.1)
    s = sample_mesh(v, t, 48000, rng=0)
    rng = np.random.default_rng(2)
    p, true = np.asarray(s.points), np.asarray(s.normals)
    keep = rng.choice(
        np.flatnonzero(rng.random(p.shape[0]) < 10.0 ** -p[:, 0]), 6000, replace=False
    )
    p, true = p[keep] + 0.002 * rng.standard_normal((6000, 3)), true[keep]
    blended = orient_normals(p, surface_normals(p))
    gated = _far_off(sharpen_normals(p, blended), true, 30.0)
    monkeypatch.setattr(_sharp, "QUADRIC_NEIGHBORS", p.shape[0] + 1)
    assert gated <= _far_off(sharpen_normals(p, blended), true, 30.0) + 3
    assert gated < 0.7 * _far_off(blended, true, 30.0)


def test_flat_and_noisy_samples_keep_their_normals():
    rng = np.random.default_rng(1)
    plane = np.c_[rng.random((2000, 2)), np.zeros(2000)]
    n = np.tile([0.0, 0.0, 1.0], (2000, 1))
    assert np.array_equal(sharpen_normals(plane, n), n)
    noisy = plane + np.c_[np.zeros((2000, 2)), 0.01 * rng.standard_normal(2000)]
    given = orient_normals(noisy, surface_normals(noisy))
    assert np.array_equal(sharpen_normals(noisy, given), given)


def test_the_same_input_gives_the_same_normals_and_a_table_is_used_as_given():
    p, _ = _plate(0.1, 3000)
    blended = orient_normals(p, surface_normals(p))
    table = query_knn(p, 30)
    a = sharpen_normals(p, blended)
    assert np.array_equal(a, sharpen_normals(p, blended))
    assert np.array_equal(a, sharpen_normals(p, blended, neighbors=table))


def test_normals_of_another_shape_are_refused():
    p, _ = _plate(0.1, 500)
    with pytest.raises(ValueError, match=r"normals must have one row per point \(500\); got 499"):
        sharpen_normals(p, np.zeros((499, 3)))


def test_a_neighbourhood_too_small_for_a_plane_is_refused():
    p, _ = _plate(0.1, 500)
    with pytest.raises(ValueError, match=r"k must be an integer in \[3, 500\]"):
        sharpen_normals(p, np.tile([0.0, 0.0, 1.0], (500, 1)), k=2)
