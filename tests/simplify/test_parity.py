"""Sides by the parity of ray crossings (`simplify/_parity.py`, `_signs.parity_turns`):
the votes checked against a plain-numpy cast over every disc, their values on a
sphere (outward +1, inward -1), a thin plate's right normals kept, inward patches
turned back with no help from the other points' signs, overlapping bodies' true
normals kept, a closed sample whose inward patches make it read open turned back,
open samples left alone."""

from __future__ import annotations

import numpy as np

from pointatlas.neighbors import query_knn
from pointatlas.simplify import _signs, outward_normals
from pointatlas.simplify._parity import (
    FRAME,
    MERGE_SPACINGS,
    PARITY_RADIUS,
    PARITY_TILT,
    SKIP_SPACINGS,
    parity_votes,
)
from pointatlas.simplify._reconstruct import CLOSED_DIPOLE
from pointatlas.simplify._signs import parity_turns
from pointatlas.simplify._winding import dipole_share
from pointatlas.synth import sample_mesh

from .cad_shapes import box, extrude
from .test_signs import _inward, _plate


def _crossings(t: np.ndarray, merge: float) -> int:
    """Hits along one way of a ray (distances from its start, all positive) counted
    as crossings: a hit within ``merge`` of the one before is the same crossing."""
    t = np.sort(t)
    return int(t.size and 1 + (np.diff(t) > merge).sum())


def parity_votes_reference(q, n, spacing):
    """`parity_votes` in plain numpy: every ray tested against every disc."""
    r, skip, merge = (c * spacing for c in (PARITY_RADIUS, SKIP_SPACINGS, MERGE_SPACINGS))
    out, count = np.zeros(q.shape[0]), np.zeros(q.shape[0])
    for i in range(q.shape[0]):
        for a in FRAME:
            cos = float(n[i] @ a)
            if abs(cos) < PARITY_TILT:
                continue
            along = n @ a
            use = np.abs(along) >= 1e-3
            t = np.einsum("ij,ij->i", n[use], q[use] - q[i]) / along[use]
            hit = q[i] + t[:, None] * a - q[use]
            t = t[(np.einsum("ij,ij->i", hit, hit) <= r * r) & (np.abs(t) > skip)]
            ahead, behind = _crossings(t[t > 0], merge), _crossings(-t[t < 0], merge)
            sign = 1.0 if cos > 0 else -1.0
            out[i] += sign * (1 if ahead % 2 == 0 else -1) - sign * (1 if behind % 2 == 0 else -1)
            count[i] += 2
    return np.where(count > 0, out / np.maximum(count, 1), 0.0)


def _spacing(p) -> float:
    return float(np.median(query_knn(p, 2)[1][:, 1]))


def _sphere(n: int = 3000):
    u = np.random.default_rng(0).normal(size=(n, 3))
    return u / np.linalg.norm(u, axis=1)[:, None]


def test_votes_match_the_plain_numpy_cast():
    v, t = box()
    s = sample_mesh(v, t, 1200, rng=0)
    p, n = np.asarray(s.points), np.asarray(s.normals).copy()
    n[::7] *= -1.0  # signs do not matter to the discs, only to the votes
    rng = np.random.default_rng(1)
    n[::5] += 0.2 * rng.normal(size=n[::5].shape)  # nor do exact directions
    n /= np.linalg.norm(n, axis=1)[:, None]
    h = _spacing(p)
    np.testing.assert_allclose(parity_votes(p, n, h), parity_votes_reference(p, n, h))


def test_a_sphere_votes_out_for_outward_normals_and_in_for_inward_ones():
    # a ray leaving outward crosses nothing, inward the far side once: +1 exactly,
    # but where it meets a gap the discs leave (a few % of a random sample's area)
    u = _sphere()
    h = _spacing(u)
    out, inward = parity_votes(u, u, h), parity_votes(u, -u, h)
    np.testing.assert_array_equal(out, -inward)  # the signs only turn the votes
    assert (out == 1.0).mean() > 0.95
    assert out.min() >= 0.0


def test_a_thin_plate_votes_out():
    p, truth = _plate()
    votes = parity_votes(p, truth, _spacing(p))
    assert (votes > 0).mean() > 0.95
    assert votes.mean() > 0.9


def _table(p):
    idx, dist = query_knn(p, 10)
    return np.asarray(idx, dtype=np.int64), np.asarray(dist)


def test_inward_patches_are_turned_back_by_the_crossings_alone():
    # the plate's patch and, on a box, three faces' patches at a corner
    p, truth = _plate()
    n = truth.copy()
    n[(truth[:, 2] > 0.9) & (np.linalg.norm(p[:, :2] - 0.5, axis=1) < 0.08)] *= -1.0
    v, t = box()
    s = sample_mesh(v, t, 6000, rng=0)
    b, b_truth = np.asarray(s.points), np.asarray(s.normals)
    m = b_truth.copy()
    m[np.linalg.norm(b - b.min(axis=0), axis=1) < 0.3] *= -1.0
    for pts, nrm, right in ((p, n, truth), (b, m, b_truth)):
        before = _inward(nrm, right)
        assert before > 30
        # all but a few points along the box's edges (patches under 10 points)
        assert _inward(parity_turns(pts, nrm, *_table(pts)), right) <= 0.05 * before
        np.testing.assert_array_equal(parity_turns(pts, right, *_table(pts)), right)


def test_overlapping_bodies_keep_their_true_normals():
    # one STL of two boxes that overlap (no boolean union): the faces inside the
    # other box vote inward (a ray from them crosses the other body's shell once
    # more), yet no patch is turned
    a_v, a_t = extrude([[0, 0], [2, 0], [2, 1], [0, 1]], height=0.5)
    b_v, b_t = extrude([[1, 0.3], [3, 0.3], [3, 1.3], [1, 1.3]], height=0.7)
    s = sample_mesh(np.vstack([a_v, b_v]), np.vstack([a_t, b_t + len(a_v)]), 8000, rng=0)
    p, n = np.asarray(s.points), np.asarray(s.normals)
    in_a = (p > [0, 0, 0]).all(axis=1) & (p < [2, 1, 0.5]).all(axis=1)
    in_b = (p > [1, 0.3, 0]).all(axis=1) & (p < [3, 1.3, 0.7]).all(axis=1)
    votes = parity_votes(p, n, _spacing(p))
    assert votes[in_a | in_b].mean() < -0.3 < 0.3 < votes[~(in_a | in_b)].mean()
    np.testing.assert_array_equal(parity_turns(p, n, *_table(p)), n)


def test_large_inputs_are_decided_on_a_stride(monkeypatch):
    # above `_winding.MAX_POINTS` points: decided on every 3rd point, each point as
    # its nearest there
    v, t = box()
    s = sample_mesh(v, t, 6000, rng=0)
    p, truth = np.asarray(s.points), np.asarray(s.normals)
    n = truth.copy()
    n[np.linalg.norm(p - p.min(axis=0), axis=1) < 0.45] *= -1.0
    monkeypatch.setattr(_signs, "MAX_POINTS", 2500)
    # all but a ring along the patch's border, whose nearest strided point lies across
    # it (facing the other way: not followed) and the box's edges
    assert _inward(parity_turns(p, n, *_table(p)), truth) <= 0.1 * _inward(n, truth)
    np.testing.assert_array_equal(parity_turns(p, truth, *_table(p)), truth)


def test_a_closed_sample_that_reads_open_is_turned_back():
    # five patches of a thin plate's top turned inward: 8 % of the points, and their
    # discs no longer sum to nearly zero (the sample reads open, as the einsy doors'
    # did with 40 % inward); the crossings turn them back, and then it reads closed
    p, truth = _plate()
    n = truth.copy()
    for c in ((0.25, 0.25), (0.75, 0.25), (0.25, 0.75), (0.75, 0.75), (0.5, 0.5)):
        n[(truth[:, 2] > 0.9) & (np.linalg.norm(p[:, :2] - c, axis=1) < 0.1)] *= -1.0
    assert dipole_share(p, n) > CLOSED_DIPOLE
    assert _inward(n, truth) > 300
    assert _inward(outward_normals(p, n), truth) <= 3


def test_an_open_sample_is_not_asked():
    # a hemisphere has no inside: `outward_normals` keeps a turned cap as it is
    u = _sphere(4000)
    u = u[u[:, 2] > 0.0]
    n = u.copy()
    n[u[:, 2] > 0.95] *= -1.0
    np.testing.assert_array_equal(outward_normals(u, n), n)
